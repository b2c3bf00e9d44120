"""Does the way a file writes its time column change what a card costs? Real cards, four ways.

Run from the repository root (after ``make install``)::

    .venv/bin/python benchmarks/bench_time_columns.py            # every public stroke
    .venv/bin/python benchmarks/bench_time_columns.py --limit 4  # quicker

Controllers and historians write a card's time in many ways; the samples are the same. Each
public real card that has a uniform time (Sandia's surface cards and split strokes, CUPB's
and dzhang's cards timed from the stroke rate, the oilfield set's first ``--limit``) is
written to a CSV file four ways and read and fitted end to end (``read_card`` then
``pumpid.fit``, Kelvin, the defaults):

* ``seconds``: seconds from zero, six significant decimals (the baseline, measured in the
  same run);
* ``seconds of the day``: the stroke recorded at 21:36 on the ninth day of a record, seconds
  counted from the record's start (777,600 s and more);
* ``rounded``: seconds from zero written to four decimals (a 1/30 s step rounds to 3e-3 of
  itself; a 0.02 s step stays exact);
* ``stamps``: ISO 8601 date/time stamps, one a sample, to the microsecond.

Each form prints the median and 90th percentile time a card and its ratio to the baseline's
median, and how many cards ended with another status than the baseline's. The samples are
the same, but not every time: a rounded step is another step, and times far from zero hold
their step to 1e-12 of it; on a card whose cost is flat along a valley (the same cost to six
digits) that is enough to move the verdict between ``boundary`` and ``undetermined``. A card
whose times are equal steps written far from zero or rounded had been simulated step by
step as non-uniformly sampled, 20-40 s a card; here every form should cost what the
baseline costs.

This is a benchmark, not a test: it prints figures and checks nothing.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from datetime import datetime, timedelta
from pathlib import Path

# Small matrices: a multi-threaded BLAS only oversubscribes the cores.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_optimum import real_cards  # noqa: E402

import pumpid  # noqa: E402
from pumpid.cards import Card, CardError, read_card  # noqa: E402

#: Where the "seconds of the day" form starts: 21:36 on a record's ninth day.
LATE = 777_600.0


def _times(card: Card, form: str) -> list[str]:
    t = np.asarray(card.t, dtype=float)
    if form == "seconds":
        return [f"{x:.6f}" for x in t]
    if form == "seconds of the day":
        return [f"{LATE + x:.6f}" for x in t]
    if form == "rounded":
        return [f"{x:.4f}" for x in t]
    start = datetime(2024, 3, 9, 21, 36)
    return [(start + timedelta(seconds=float(x))).isoformat(sep=" ", timespec="microseconds")
            for x in t]


def _write(folder: Path, card: Card, form: str) -> Path:
    path = folder / "card.csv"
    rows = "".join(f"{s},{float(p)!r},{float(f)!r}\n" for s, p, f in
                   zip(_times(card, form), card.position, card.load, strict=True))
    head = f"time,position_{card.position_unit or 'in'},load_{card.load_unit or 'lbf'}\n"
    path.write_text(head + rows, encoding="utf-8")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--limit", type=int, default=None,
                        help="cards of each public set (default: all but the oilfield's 40)")
    args = parser.parse_args()
    sets = real_cards(args.limit)
    if not sets:
        print("no public real cards found beside the repository: nothing to measure")
        return
    sets["oilfield"] = sets["oilfield"][: args.limit or 40]
    cards = [c for group in sets.values() for c in group if c.t is not None and c.is_uniform]
    forms = ("seconds", "seconds of the day", "rounded", "stamps")
    pumpid.fit(pumpid.Kelvin, cards[0])  # compile outside the timings
    times: dict[str, list[float]] = {f: [] for f in forms}
    status: dict[str, list[str]] = {f: [] for f in forms}
    with tempfile.TemporaryDirectory() as tmp:
        for card in cards:
            for form in forms:
                path = _write(Path(tmp), card, form)
                start = time.perf_counter()
                try:
                    key = pumpid.fit(pumpid.Kelvin, read_card(path)).status.key
                except (CardError, ValueError):  # a version that cannot read the form
                    key = "not read"
                times[form].append(time.perf_counter() - start)
                status[form].append(key)
    base = float(np.median(times["seconds"]))
    print(f"{len(cards)} public real cards with a uniform time, read and fitted (Kelvin, "
          "defaults), one time column written four ways")
    print(f"  {'time column':22s} {'median ms':>10s} {'p90 ms':>8s} {'x baseline':>11s}  "
          "status not the baseline's")
    for form in forms:
        ms = 1e3 * np.asarray(times[form])
        moved = sum(a != b for a, b in zip(status[form], status["seconds"], strict=True))
        unread = status[form].count("not read")
        print(f"  {form:22s} {np.median(ms):10.1f} {np.percentile(ms, 90):8.1f} "
              f"{np.median(ms) / (1e3 * base):11.2f}  {moved} of {len(cards)}"
              + (f" ({unread} not read)" if unread else ""))


if __name__ == "__main__":
    main()
