"""What a batch run did, in counts and words: :class:`BatchSummary`."""

from __future__ import annotations

import heapq
import math
import re
import shlex
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa

from pumpid.cards import printable
from pumpid.report.words import plural

__all__ = ["BatchSummary", "reason_kind"]

_QUOTED = re.compile(r"'[^']*'|\"[^\"]*\"")
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def reason_kind(reason: str) -> str:
    """A reason with its particulars (quoted names, numbers) blanked, to count alike ones."""
    return _NUMBER.sub("N", _QUOTED.sub("'…'", reason or "(no reason given)")).strip()


#: How many unreadable files and kinds of failure reason the summary names.
_SHOWN_FILES = 20
_SHOWN_REASONS = 10


@dataclass
class BatchSummary:
    """What a run did: counts, what could not be read, the costliest cards, failures.

    Attributes
    ----------
    results : Path
        The results folder.
    engine : str
        Where the partitions were fitted, in words.
    cards, partitions : int
        Rows and partitions in the results (this run's and any earlier run's).
    fitted, skipped : int
        Cards fitted in this run; cards of partitions an earlier run had written.
    statuses : Counter
        Rows per status.
    unreadable : list of (str, str)
        Files that could not be read at all: name and reason.
    costliest : list of (str, int, int)
        The cards with the most model evaluations (card id, evaluations, samples): a fit's
        time is about proportional to both.
    failures : list of (str, int, str)
        Failed and invalid cards grouped by kind of reason (alike but for names and numbers):
        the first card's status and reason in its own words, the cards, that card.
    elapsed : float
        Seconds of this run, reading and writing included.
    duplicates : int
        Cards that repeat an earlier card of the run exactly (``duplicate_of`` set).
    pump_statuses : Counter
        Rows per status of the pump's identification (``pumpid batch --well-file``;
        empty without it or with ``--no-identify``).
    interrupted : bool
        The run was stopped before the end; ``discarded`` partitions were dropped.
    pump_only : bool
        The pump's identification is each card's fit (``--pump-only``): its statuses are
        the cards' own, said once.
    """

    results: Path
    engine: str = ""
    cards: int = 0
    partitions: int = 0
    fitted: int = 0
    skipped: int = 0
    statuses: Counter[str] = field(default_factory=Counter)
    pump_statuses: Counter[str] = field(default_factory=Counter)
    unreadable: list[tuple[str, str]] = field(default_factory=list)
    costliest: list[tuple[str, int, int]] = field(default_factory=list)
    failures: list[tuple[str, int, str]] = field(default_factory=list)
    elapsed: float = 0.0
    duplicates: int = 0
    interrupted: bool = False
    discarded: int = 0
    pump_only: bool = False
    _heap: list[tuple[int, int, str]] = field(default_factory=list, repr=False)
    _reasons: dict[str, list[Any]] = field(default_factory=dict, repr=False)

    def add(self, table: pa.Table) -> None:
        """Count one partition's rows."""
        cols = table.select(["card_id", "status", "reason", "nfev", "n_samples"]).to_pydict()
        self.partitions += 1
        self.cards += table.num_rows
        if "duplicate_of" in table.column_names:
            self.duplicates += table.num_rows - table.column("duplicate_of").null_count
        self.statuses.update(cols["status"])
        if "identify_status" in table.column_names:
            pumps = table.column("identify_status").to_pylist()
            self.pump_statuses.update(s for s in pumps if s is not None)
            if not self.pump_only and "identify_reason" in table.column_names:
                # A pump asked for and not computed is a failure of the run like a fit's.
                # A card whose own fit failed or was invalid is counted once, below.
                for cid, fitted, status, reason in zip(
                        cols["card_id"], cols["status"], pumps,
                        table.column("identify_reason").to_pylist(), strict=True):
                    if (status in ("failed", "invalid-input")
                            and fitted not in ("failed", "invalid-input")):
                        self._count_failure(f"pump {status}", reason, cid)
        for cid, status, reason, nfev, n in zip(cols["card_id"], cols["status"], cols["reason"],
                                                cols["nfev"], cols["n_samples"], strict=True):
            if nfev is not None:
                entry = (int(nfev), int(n or 0), str(cid))
                if len(self._heap) < 5:
                    heapq.heappush(self._heap, entry)
                else:
                    heapq.heappushpop(self._heap, entry)
            if status in ("failed", "invalid-input"):
                self._count_failure(status, reason, cid)

    def _count_failure(self, status: str, reason: str | None, cid: Any) -> None:
        reason = reason or "(no reason given)"
        kind = f"{status}: {reason_kind(reason)}"
        # The first card's own words stand for the kind: with its names and numbers
        # blanked, "has 200 values but ... has 199" read "has N values but ... has N".
        slot = self._reasons.setdefault(kind, [0, str(cid), f"{status}: {reason}"])
        slot[0] += 1

    def close(self) -> None:
        """Fix the lists from the counts."""
        self.costliest = [(cid, nfev, n) for nfev, n, cid in sorted(self._heap, reverse=True)]
        self.failures = sorted(((v[2], v[0], v[1]) for v in self._reasons.values()),
                               key=lambda x: (-x[1], x[0]))

    def rate(self) -> float:
        """Cards fitted per second in this run, end to end."""
        return self.fitted / self.elapsed if self.elapsed > 0 else math.nan

    def text(self) -> str:
        """The summary in words, as ``pumpid batch`` prints it and ``_summary.txt`` keeps it.

        Names, card ids and reasons come from the files: control characters, terminal
        escapes and bidirectional overrides are shown escaped (:func:`pumpid.cards.printable`).
        """
        state = "interrupted" if self.interrupted else "complete"
        lines = [f"pumpid batch: {state}; results in {printable(str(self.results))}",
                 f"  engine: {printable(self.engine)}",
                 f"  cards: {self.cards} in {plural(self.partitions, 'partition')} "
                 f"({self.fitted} fitted in this run in {self.elapsed:.1f} s, "
                 f"{self.rate():.1f} cards/s end to end; {self.skipped} from an earlier run)"]
        if self.interrupted:
            # The folder itself, quoted for a shell: "--out RESULTS" was printed as is.
            lines.append(f"  partitions dropped at the interrupt: {self.discarded}; "
                         "continue with: pumpid batch --resume --out "
                         f"{printable(shlex.quote(str(self.results)))}")
        statuses = sorted(self.statuses.items(), key=lambda x: -x[1])
        lines.append(f"  cards per status{' (the pump identified)' if self.pump_only else ''}: "
                     + (", ".join(f"{printable(str(s))} {n}" for s, n in statuses) or "none"))
        if self.pump_statuses and not self.pump_only:
            pumps = sorted(self.pump_statuses.items(), key=lambda x: -x[1])
            lines.append("  pumps identified, cards per status: "
                         + ", ".join(f"{printable(str(s))} {n}" for s, n in pumps))
        if self.duplicates:
            lines.append(f"  duplicate cards: {self.duplicates} repeat an earlier card of the "
                         "run exactly (named in duplicate_of; the report counts them once)")
        lines.append(f"  unreadable files: {len(self.unreadable)}")
        for name, why in self.unreadable[:_SHOWN_FILES]:
            lines.append(f"    {printable(str(name))}: {printable(str(why))}")
        if len(self.unreadable) > _SHOWN_FILES:
            lines.append(f"    ... and {len(self.unreadable) - _SHOWN_FILES} more (status "
                         "invalid-input in the results)")
        if self.failures:
            lines.append("  failed or invalid cards by reason:")
            for said, n, example in self.failures[:_SHOWN_REASONS]:
                alike = (f"; {n - 1} more alike but for names and numbers" if n > 1 else "")
                lines.append(f"    {plural(n, 'card')}: {printable(str(said))} (card "
                             f"{printable(str(example))}{alike})")
            if len(self.failures) > _SHOWN_REASONS:
                lines.append(f"    ... and {len(self.failures) - _SHOWN_REASONS} more kinds of "
                             "reason")
        if self.costliest:
            lines.append("  costliest cards (model evaluations; a fit's time grows with them "
                         "and the samples):")
            for cid, nfev, n in self.costliest:
                lines.append(f"    {printable(str(cid))}: {plural(nfev, 'evaluation')} of "
                             f"{plural(n, 'sample')}")
        return "\n".join(lines)
