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
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from pumpid.pump.synthetic import FieldCards, StepChange, synthetic_field

__all__ = ["DEMO_FIELD", "main", "make_demo_field"]

#: Arguments of :func:`pumpid.pump.synthetic.synthetic_field` for the demo.
DEMO_FIELD: dict[str, Any] = {
    "n_wells": 6, "days": 3, "cards_per_day": 24,
    "formats": ("csv", "scada", "json", "parquet"), "seed": 7, "model": "kelvin",
    "broken_fraction": 0.01, "cards": FieldCards(observe="u", n_samples=100, hold="none"),
    "change": StepChange(well=3, parameter="k1", factor=1.3, at=40),
}  # fmt: skip


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
    """``python -m pumpid.fleet.demo FOLDER``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 1:
        print("usage: python -m pumpid.fleet.demo FOLDER", file=sys.stderr)
        return 2
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
