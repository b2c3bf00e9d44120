"""A synthetic field on disk for batch tests: many wells, mixed formats, broken cards."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from pumpid.pump.synthetic import FieldCards, StepChange, synthetic_field

#: Formats of the test fields: every layout that says which card is which and when.
#: (The whitespace layout has no place for ids, rate or time; it has its own test.)
FORMATS = ("csv", "scada", "json", "parquet")


def make_field(folder: Path, *, n_wells: int = 25, days: int = 20, cards_per_day: int = 4,
               broken_fraction: float = 0.05, seed: int = 17, model: str = "msd",
               change: StepChange | Sequence[StepChange] | None = None,
               n_samples: int = 60) -> pd.DataFrame:
    """Write a field and return its truth table with ``path``: each card's file as the
    batch names it (``folder`` joined with the path below it).

    The SCADA wells' good cards are merged into one multi-well export (``scada/export.txt``)
    as a controller writes them; a note and a hidden file lie beside the cards, which a
    folder search must leave out.
    """
    truth = synthetic_field(folder, n_wells=n_wells, days=days, cards_per_day=cards_per_day,
                            formats=FORMATS, seed=seed, model=model,
                            broken_fraction=broken_fraction,
                            cards=FieldCards(n_samples=n_samples, hold="none"), change=change)
    scada = sorted(f for f in truth.loc[truth["format"] == "scada", "file"].unique()
                   if Path(f).stem.startswith("W") and "_" not in Path(f).stem)
    lines: list[str] = []
    for rel in scada:
        text = (folder / rel).read_text(encoding="utf-8").splitlines()
        lines += text if not lines else text[1:]
        (folder / rel).unlink()
    if lines:
        (folder / "scada" / "export.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
        truth.loc[truth["file"].isin(scada), "file"] = "scada/export.txt"
    (folder / "README.md").write_text("not a card\n", encoding="utf-8")
    (folder / "csv" / ".partial.csv").write_text("half a card\n", encoding="utf-8")
    truth["path"] = [os.path.normpath(os.path.join(str(folder), f)) for f in truth["file"]]
    return truth
