"""Alerts as the changes of a well: one change seen in several quantities counts once.

The change detector tests each quantity of a well on its own, so one physical change shows
as several alerts: a leaking pump's fluid load falls and its intake pressure (the discharge
pressure less the fluid load over the plunger area) rises by the same number of standard
errors; a fluid pound lowers the net stroke, the fillage and the displacement together. A
field of two such wells read "9 alerts". Here the alerts of one well whose spans of cards
overlap (the first changed card of one lies at or before the alarm card of the other, in
time, or in card order where the well has no times) are one **event**, numbered over the
run from the largest (by its largest alert in standard errors) down.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["change_size", "count_events", "events_of", "number_events",
           "ordered_by_event"]


def change_size(alerts: pd.DataFrame) -> pd.Series:
    """Each alert's |change_se| to 9 digits: one change seen in two quantities (a pump's
    intake pressure follows its fluid load) ties, and the alerts' own order (by quantity)
    decides, not a difference of 7e-13."""
    size = pd.to_numeric(alerts["change_se"], errors="coerce").abs()
    return size.map(lambda v: float(f"{v:.9g}") if np.isfinite(v) else v)


def _spans(group: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Each alert's first and alarm positions: times where every alert of the well has
    them, else the cards' indices in the quantity's history."""
    first = pd.to_datetime(group["first_time"], utc=True)
    alarm = pd.to_datetime(group["alarm_time"], utc=True)
    if first.notna().all() and alarm.notna().all():
        return (first.dt.tz_localize(None).to_numpy(dtype="datetime64[ns]").astype(np.int64),
                alarm.dt.tz_localize(None).to_numpy(dtype="datetime64[ns]").astype(np.int64))
    return (pd.to_numeric(group["first_index"]).to_numpy(dtype=np.int64),
            pd.to_numeric(group["alarm_index"]).to_numpy(dtype=np.int64))


def number_events(alerts: pd.DataFrame) -> pd.Series:
    """The event of each alert (1, 2, ...; aligned with ``alerts``' index).

    Parameters
    ----------
    alerts : pandas.DataFrame
        :func:`pumpid.fleet.changes.detect_changes`' result (``well_id``, ``change_se``,
        ``first_card_id``, ``first_time``, ``alarm_time``, ``first_index``,
        ``alarm_index``).

    Returns
    -------
    pandas.Series of int
        Alerts of one well whose spans of cards overlap share a number; event 1 holds the
        run's largest alert, and the others follow by their largest alert, the earlier
        event first on a tie.
    """
    if alerts.empty:
        return pd.Series(np.zeros(0, dtype=np.int64), index=alerts.index, name="event")
    # A size not known ranks last (it was taken for an infinite one: change 1).
    size = change_size(alerts).fillna(0.0).to_numpy()
    wells = alerts["well_id"].astype(str).to_numpy()
    label = np.empty(len(alerts), dtype=np.int64)
    # Each event's largest alert and first position, by its label.
    biggest: list[float] = []
    starts: list[int] = []
    firsts = alerts["first_card_id"].astype(str).to_numpy()
    for well in dict.fromkeys(wells):
        rows = np.flatnonzero(wells == well)
        first, alarm = _spans(alerts.iloc[rows])
        order = np.lexsort((alarm, first))
        reach = None
        cards: set[str] = set()
        for r in order:
            # Sorted by first card: an alert joins the event in progress when it starts
            # no later than the latest alarm seen in that event, or at one of its first
            # cards (without times the positions count each quantity's own usable cards,
            # which differ when a quantity is missing on some).
            if reach is None or (first[r] > reach and firsts[rows[r]] not in cards):
                biggest.append(0.0)
                starts.append(int(first[r]))
                reach, cards = alarm[r], set()
            else:
                reach = max(reach, alarm[r])
            cards.add(firsts[rows[r]])
            label[rows[r]] = len(biggest) - 1
            biggest[-1] = max(biggest[-1], float(size[rows[r]]))
    ranked = sorted(range(len(biggest)), key=lambda e: (-biggest[e], starts[e], e))
    number = {e: i + 1 for i, e in enumerate(ranked)}
    return pd.Series([number[k] for k in label], index=alerts.index, name="event")


def events_of(alerts: pd.DataFrame) -> pd.Series:
    """The alerts' ``event`` column, numbered here when they carry none (alerts given by
    a caller)."""
    return alerts["event"] if "event" in alerts.columns else number_events(alerts)


def ordered_by_event(alerts: pd.DataFrame) -> pd.DataFrame:
    """``alerts`` with an ``event`` column (computed when missing), event by event and,
    within one, the largest alert first (ties in the alerts' own order)."""
    return (alerts.assign(event=events_of(alerts), _size=change_size(alerts))
            .sort_values(["event", "_size"], ascending=[True, False], kind="stable")
            .drop(columns="_size"))


def count_events(alerts: pd.DataFrame) -> int:
    """How many changes the alerts are (their ``event`` column, computed when missing)."""
    return int(events_of(alerts).nunique()) if not alerts.empty else 0
