"""``pumpid demo``: fit the bundled example card, predict the next stroke, write a report."""

from __future__ import annotations

import argparse
import collections
from pathlib import Path
from typing import Any

from ..cards import printable
from ..report.output import OutputFolder
from .common import EXIT_OK, err
from .render import Row, RunInfo, TextPrinter

__all__ = ["cmd_demo", "register"]


def cmd_demo(args: argparse.Namespace) -> int:
    """Fit the bundled example card (observed output u) and write the report."""
    from importlib import resources

    from ..cards import read_cards
    from ..job import FitOptions, fit
    from ..pump import predict_card
    from ..report import write_outputs

    folder = OutputFolder(args.out)
    for said in folder.prepare():
        err(said)
    ref = resources.files("pumpid") / "data" / "example_cards.csv"
    with resources.as_file(ref) as file:
        cards = read_cards(file)
    path = Path(file)
    first, second = cards[0], cards[1]
    # The polished-rod load acts on the mass: its displacement u is what the card's position
    # measures (stated here so that the demo does not depend on the model's default).
    res = fit("kelvin", first, options=FitOptions.for_cards(observe="u"))
    pred = predict_card(res, second)
    with folder.staging() as stage:
        write_outputs(res, stage, notes=list(first.notes), prediction=pred)
        said = folder.commit_files(stage)
    for s in said:
        err(s)
    printer = TextPrinter()
    printer.start(RunInfo(
        model=res.model_name, title="", observe=res.observe,
        observe_meaning="displacement of the mass, where the polished-rod load acts",
        method=res.method, out=args.out,
        assumptions=("the bundled example well: synthetic cards made by "
                     "scripts/make_example_cards.py (a crank-rocker unit's polished-rod "
                     "motion, the load a known Kelvin model needs for it, 0.1 % noise); the "
                     "first stroke is fitted as one period of a periodic motion with a "
                     "position offset, and the fitted model predicts the second stroke from "
                     "its load.",)))
    printer.file(path.name, cards)
    row = Row(card_id=first.card_id, source=first.source, status=res.status.key,
              reason=res.reason, result=res, card=first, prediction=pred,
              output=str(folder.path))
    printer.row(row)
    printer.finish(collections.Counter([res.status.key]), interrupted=False, out=None,
                   index=None)
    print(f"report: {printable(str(folder.path / 'report.html'))}")
    return EXIT_OK


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``pumpid demo``."""
    p = subparsers.add_parser("demo", help="fit the bundled example card and write a report")
    p.add_argument("--out", default="demo-output", help="output folder (default demo-output)")
    p.set_defaults(func=cmd_demo)
    return p
