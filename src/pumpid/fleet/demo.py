"""The demo field of ``make demo``: a small synthetic field with one well that changes.

``python -m pumpid.fleet.demo FOLDER`` writes the field's card files into ``FOLDER`` (made
by :func:`pumpid.pump.synthetic.synthetic_field`, the project's documented generator) and
its truth table as ``FOLDER/../truth.csv``; ``make demo`` then runs ``pumpid batch`` and
``pumpid report`` on it like on any field.

The field (:data:`DEMO_FIELD`): six wells, a card every hour for three days (432 cards),
in four file layouts (CSV, a SCADA export, JSON, the Parquet long layout), about 1 % of the
cards broken (an unreadable file, a NaN, a truncated list, a constant load), Kelvin wells
whose mass displacement ``u`` follows the polished rod, and one step change: well W003's
Kelvin spring ``k1`` rises by 30 % from ``card_index`` 40 of ``truth.csv`` on (0-based: the
well's 41st card, W003_20240102T1600Z).

The seed is one whose steady wells all fit away from Kelvin's rigid limit for ``k0``. On
wells whose cards sit at that limit on some cards and not on others, the time constant of
the model's third pole jumps between its interior value and zero from card to card, and the
fits still call it determined; the change detector then flags it (other seeds show this).

``python -m pumpid.fleet.demo --pumps FOLDER`` writes the demo's pump field instead
(:data:`DEMO_PUMP_FIELD`, made by :func:`pumpid.fleet.pumpfield.write_pump_field`): four
rod-pumped wells with the same three-taper string, a card every six hours for four days
(64 cards), 1 % load noise and 1 % card-to-card scatter of the fluid level; its well file
``FOLDER/../wells.json`` and its truth table ``FOLDER/../truth.csv``. ``make demo`` runs
``pumpid batch --well-file`` on it (each card's pump identified, about 0.05 s a
card) and ``pumpid report``, apart from the Kelvin field: those wells have no rod string
to describe, and identifying their 432 cards would cost tens of seconds for nothing. Wells P001
(a full pump) and P004 (a steady 85 % fillage) are steady; from ``card_index``
:data:`PUMP_CHANGE_AT` on, well P002's fillage falls from 1 to 0.75 (fluid pound starting)
and well P003's fluid load drops by 18 % (a leaking valve). The field ends three cards
after the changes: the report is run as it would be three cards into them.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from pumpid.pump.synthetic import FieldCards, StepChange, synthetic_field

from .pumpfield import PumpWell, write_pump_field

__all__ = ["DEMO_FIELD", "DEMO_PUMP_FIELD", "PUMP_CHANGE_AT", "demo_pump_wells", "main",
           "make_demo_field", "make_pump_field"]

#: Arguments of :func:`pumpid.pump.synthetic.synthetic_field` for the demo.
DEMO_FIELD: dict[str, Any] = {
    "n_wells": 6, "days": 3, "cards_per_day": 24,
    "formats": ("csv", "scada", "json", "parquet"), "seed": 7, "model": "kelvin",
    "broken_fraction": 0.01, "cards": FieldCards(observe="u", n_samples=100, hold="none"),
    "change": StepChange(well=3, parameter="k1", factor=1.3, at=40),
}  # fmt: skip


#: The first card (0-based index) of the pump field's two changes.
PUMP_CHANGE_AT = 12


def demo_pump_wells(at: int = PUMP_CHANGE_AT) -> dict[str, PumpWell]:
    """The pump field's wells, the two changes from card ``at`` on."""
    return {
        "P001": PumpWell(),
        "P002": PumpWell(fillage=lambda k: 1.0 if k < at else 0.75),
        "P003": PumpWell(load_factor=lambda k: 1.0 if k < at else 0.82),
        "P004": PumpWell(fillage=0.85),
    }


#: Arguments of :func:`pumpid.fleet.pumpfield.write_pump_field` for the demo (the wells
#: from :func:`demo_pump_wells`).
DEMO_PUMP_FIELD: dict[str, Any] = {"cards": 16, "n_samples": 100, "noise": 0.01,
                                   "level_scatter": 0.01, "seed": 11}


def make_pump_field(folder: str | Path, *, at: int = PUMP_CHANGE_AT,
                    **options: Any) -> Path:
    """Write the pump field's cards into ``folder``, its well file and truth table beside.

    Parameters
    ----------
    folder : path
        Where the card files go.
    at : int
        The first card of the two changes.
    **options
        Over :data:`DEMO_PUMP_FIELD` (``cards``, ``seed``, ...).

    Returns
    -------
    Path
        The truth table (``truth.csv`` in ``folder``'s parent): one row per card with the
        pump it was made from (``fillage``, ``fluid_load`` in lbf) and ``changed``.
    """
    out = Path(folder)
    truth = write_pump_field(out, demo_pump_wells(at), **{**DEMO_PUMP_FIELD, **options})
    truth["changed"] = truth["well_id"].isin(("P002", "P003")) & (truth["card_index"] >= at)
    path = out.parent / "truth.csv"
    truth.to_csv(path, index=False)
    return path


def make_demo_field(folder: str | Path) -> Path:
    """Write the demo field's cards into ``folder`` and its truth table beside it.

    Returns
    -------
    Path
        The truth table (``truth.csv`` in ``folder``'s parent): one row per card with the
        parameters it was made from.
    """
    out = Path(folder)
    truth = synthetic_field(out, **DEMO_FIELD)
    path = out.parent / "truth.csv"
    truth.to_csv(path, index=False, date_format="%Y-%m-%dT%H:%M:%SZ")
    return path


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m pumpid.fleet.demo [--pumps] FOLDER``."""
    args = list(sys.argv[1:] if argv is None else argv)
    usage = "usage: python -m pumpid.fleet.demo [--pumps] FOLDER"
    if args[:1] in (["-h"], ["--help"]):
        print(f"{usage}\n\nWrites make demo's synthetic Kelvin field (or with --pumps its "
              "pump field) into FOLDER; the truth table (and the well file) go beside it.")
        return 0
    pumps = args[:1] == ["--pumps"]
    args = args[1:] if pumps else args
    if len(args) != 1 or args[0].startswith("-"):
        # An option it does not know is not a folder to write a field into (write
        # ./-name for a folder whose name starts with a dash).
        print(usage, file=sys.stderr)
        return 2
    if pumps:
        return _pump_words(args[0], make_pump_field(args[0]))
    truth = make_demo_field(args[0])
    field = DEMO_FIELD
    n = field["n_wells"] * field["days"] * field["cards_per_day"]
    # Named from the truth table itself, so that the words cannot drift from it.
    table = pd.read_csv(truth)
    first = table[table["changed"]].sort_values("card_index").iloc[0]
    change = field["change"]
    print(f"demo field: {n} cards of {field['n_wells']} wells over {field['days']} days in "
          f"{args[0]} (truth: {truth}); well {first['well_id']}'s {change.parameter} rises by "
          f"{change.factor - 1:.0%} from card_index {first['card_index']} of the truth table "
          f"(card {first['card_id']})")
    return 0


def _pump_words(folder: str, truth: Path) -> int:
    table = pd.read_csv(truth)
    wells = table["well_id"].unique()
    # Named from the truth table itself, so that the words cannot drift from it.
    words = []
    for well, rows in table.groupby("well_id"):
        changed = rows[rows["changed"]]
        if changed.empty:
            continue
        before, after = rows[~rows["changed"]], changed
        first = changed.iloc[0]
        fill = (before["fillage"].median(), after["fillage"].median())
        load = before["fluid_load"].median(), after["fluid_load"].median()
        what = (f"fillage {fill[0]:.2f} -> {fill[1]:.2f} (fraction)" if fill[0] != fill[1]
                else f"fluid load {load[0]:.0f} -> {load[1]:.0f} lbf "
                     f"({load[1] / load[0] - 1:+.0%})")
        words.append(f"well {well}: {what} from card_index {first['card_index']} "
                     f"(card {first['card_id']})")
    print(f"demo pump field: {len(table)} cards of {len(wells)} wells in {folder} (well "
          f"file: {truth.parent / 'wells.json'}, truth: {truth}); " + "; ".join(words))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
