"""The file layouts a synthetic field is written in, and its broken cards.

File layouts written by :func:`~pumpid.pump.synthetic.synthetic_field`
-----------------------------------------------------------------------
Values are in inches (position) and pounds-force (load). Card ids are
``<well>_<YYYYmmddTHHMM>Z`` (the card's time, UTC), unique in the field. Every card of a
well goes to one file, except for broken cards (each in a file of its own, so that the
rest of the well stays readable) and the whitespace layout (one card per file).

``csv/<well>.csv``
    Header ``card_id,well_id,timestamp,spm,position_in,load_lbf``; one row per sample;
    ``timestamp`` is ISO 8601 with ``Z`` (the readers keep it in ``Card.metadata``).
``scada/<well>.txt``
    Pipe-delimited controller export, one card per row:
    ``Well|Card ID|Timestamp|SPM|Surface Positions (in)|Surface Loads (lbf)``.
``json/<well>.json``
    ``{"well": ..., "units": {"position": "in", "load": "lbf"}, "cards": [{"card_id": ...,
    "timestamp": ..., "spm": ..., "position": [...], "load": [...]}, ...]}``.
``whitespace/<well>/<card_id>.txt``
    Two columns without header (position, load), ``#`` comments on top; the format has no
    place for ids, rate or time: the card id is the file name, and well id and SPM come
    from the truth table; a linear model's smooth loop does not tell its columns apart,
    so name them (``read_cards(path, well_id=..., spm=..., columns={"position": 0,
    "load": 1})``).
``parquet/<well>.parquet``
    The long layout, one row per sample (read with
    :func:`pumpid.fleet.dataset.read_parquet_cards`): ``well_id`` (str), ``card_id`` (str),
    ``time`` (datetime64[ns, UTC], the card's time), ``sample`` (int, 0-based order within
    the card), ``position``, ``load`` (float), ``spm`` (float, constant within a card),
    ``position_unit``, ``load_unit`` (str, constant).

Broken cards (``broken_fraction``) are of the kinds ``"nan"`` (a NaN load sample),
``"truncated"`` (the load list shorter than the position list; in the Parquet layout, a card
of 5 samples), ``"constant-load"`` and, once per field, ``"unreadable"`` (a file of binary
garbage). Every one of them makes the readers raise :class:`pumpid.cards.CardError`.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

__all__ = ["BROKEN_KINDS", "FIELD_FORMATS", "break_card", "write_cards", "write_unreadable"]

#: File layouts :func:`~pumpid.pump.synthetic.synthetic_field` can write.
FIELD_FORMATS = ("csv", "scada", "json", "whitespace", "parquet")
#: Kinds of broken card :func:`~pumpid.pump.synthetic.synthetic_field` can make.
BROKEN_KINDS = ("nan", "truncated", "constant-load", "unreadable")


def _fmt_values(values: ArrayLike) -> list[str]:
    return [f"{v:.8g}" for v in np.asarray(values, dtype=float)]


def break_card(
    kind: str, position: NDArray[np.float64], load: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A broken copy of a card's samples, which the readers refuse.

    Parameters
    ----------
    kind : str
        ``"nan"``, ``"truncated"`` or ``"constant-load"`` (from :data:`BROKEN_KINDS`; an
        ``"unreadable"`` card is a file, see :func:`write_unreadable`).
    position, load : ndarray
        The card's samples (not changed).

    Returns
    -------
    (ndarray, ndarray)
        Position and load, broken.
    """
    pos, ld = position.copy(), load.copy()
    if kind == "nan":
        ld[ld.size // 3] = np.nan
    elif kind == "truncated":
        ld = ld[: ld.size - 7]
    elif kind == "constant-load":
        ld[:] = round(float(ld.mean()), 1)
    return pos, ld


def _write_csv(path: Path, cards: Sequence[dict[str, Any]]) -> None:
    lines = ["card_id,well_id,timestamp,spm,position_in,load_lbf"]
    for c in cards:
        stamp = c["time"].strftime("%Y-%m-%dT%H:%M:%SZ")
        pos, load = _fmt_values(c["position"]), _fmt_values(c["load"])
        for i in range(max(len(pos), len(load))):
            p = pos[i] if i < len(pos) else ""
            if i < len(load):
                lines.append(f"{c['card_id']},{c['well_id']},{stamp},{c['spm']:.6g},{p},{load[i]}")
            else:  # a truncated card: the row simply stops after the position
                lines.append(f"{c['card_id']},{c['well_id']},{stamp},{c['spm']:.6g},{p}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _write_scada(path: Path, cards: Sequence[dict[str, Any]]) -> None:
    lines = ["Well|Card ID|Timestamp|SPM|Surface Positions (in)|Surface Loads (lbf)"]
    for c in cards:
        stamp = c["time"].strftime("%Y-%m-%d %H:%M:%S")
        lines.append(
            f"{c['well_id']}|{c['card_id']}|{stamp}|{c['spm']:.6g}|"
            f"{','.join(_fmt_values(c['position']))}|{','.join(_fmt_values(c['load']))}"
        )
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _write_json(path: Path, cards: Sequence[dict[str, Any]]) -> None:
    doc = {
        "well": cards[0]["well_id"],
        "units": {"position": "in", "load": "lbf"},
        "cards": [
            {
                "card_id": c["card_id"],
                "timestamp": c["time"].strftime("%Y-%m-%dT%H:%M:%SZ"),
                "spm": round(float(c["spm"]), 6),
                "position": [float(v) for v in _fmt_values(c["position"])],
                "load": [float(v) for v in _fmt_values(c["load"])],
            }
            for c in cards
        ],
    }
    # NaN is written as the bare token NaN (not strict JSON, but what such exports contain).
    path.write_text(json.dumps(doc, indent=1), encoding="utf-8")


def _write_whitespace(path: Path, card: dict[str, Any]) -> None:
    pos, load = _fmt_values(card["position"]), _fmt_values(card["load"])
    lines = [
        f"# synthetic card {card['card_id']} of well {card['well_id']}",
        f"# time {card['time'].strftime('%Y-%m-%dT%H:%M:%SZ')}, {card['spm']:.6g} SPM",
        "# columns: position (in), load (lbf)",
    ]
    for i in range(len(pos)):
        lines.append(f"{pos[i]:>14} {load[i]:>14}" if i < len(load) else f"{pos[i]:>14}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _write_parquet(path: Path, cards: Sequence[dict[str, Any]]) -> None:
    frames = []
    for c in cards:
        pos, load = np.asarray(c["position"], float), np.asarray(c["load"], float)
        n = pos.size
        if load.size != n:  # the long layout cannot hold unequal lists: a short card instead
            n = 5
            pos, load = pos[:n], load[:n]
        frames.append(
            pd.DataFrame(
                {
                    "well_id": c["well_id"],
                    "card_id": c["card_id"],
                    "time": pd.Series([c["time"]] * n, dtype="datetime64[ns, UTC]"),
                    "sample": np.arange(n, dtype=np.int64),
                    "position": pos,
                    "load": load,
                    "spm": float(c["spm"]),
                    "position_unit": "in",
                    "load_unit": "lbf",
                }
            )
        )
    pd.concat(frames, ignore_index=True).to_parquet(path, index=False)


def write_unreadable(path: Path, rng: np.random.Generator) -> None:
    """Write a file of binary garbage, as an unreadable card.

    Parameters
    ----------
    path : Path
        The file.
    rng : numpy.random.Generator
        Source of the garbage.
    """
    path.write_bytes(b"\x00\x8f\xff" + rng.bytes(509))


def write_cards(
    fmt: str, folder: Path, stem: str, cards: Sequence[dict[str, Any]]
) -> list[Path]:
    """Write a well's cards (or one broken card) in one layout; return the file per card.

    Parameters
    ----------
    fmt : str
        The layout, from :data:`FIELD_FORMATS`.
    folder : Path
        The field's folder; the file goes to its sub-folder of the layout.
    stem : str
        File name without extension (the whitespace layout names each file by card id).
    cards : sequence of dict
        The well's cards: ``well_id``, ``card_id``, ``time`` (a UTC timestamp), ``spm``,
        ``position`` and ``load``.

    Returns
    -------
    list of Path
        The file each card was written to, in order.
    """
    if fmt == "whitespace":
        sub = folder / "whitespace" / cards[0]["well_id"]
        sub.mkdir(parents=True, exist_ok=True)
        paths = []
        for c in cards:
            p = sub / f"{c['card_id']}.txt"
            _write_whitespace(p, c)
            paths.append(p)
        return paths
    ext = {"csv": "csv", "scada": "txt", "json": "json", "parquet": "parquet"}[fmt]
    sub = folder / fmt
    sub.mkdir(parents=True, exist_ok=True)
    p = sub / f"{stem}.{ext}"
    {"csv": _write_csv, "scada": _write_scada, "json": _write_json,
     "parquet": _write_parquet}[fmt](p, cards)  # fmt: skip
    return [p] * len(cards)
