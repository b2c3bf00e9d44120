"""The surface card beside the pump card, as a PNG (matplotlib, no display needed)."""

from __future__ import annotations

import os
from typing import BinaryIO

from .diagnose import DownholeResult

__all__ = ["draw_cards"]


def draw_cards(result: DownholeResult, path: str | os.PathLike[str] | BinaryIO) -> None:
    """Draw the surface card and the pump card side by side and save the figure.

    Parameters
    ----------
    result : DownholeResult
        A computed result (``result.ok``).
    path : str, path-like or binary file
        Where to write the PNG.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    if result.position is None or result.load is None or result.pump is None:
        raise ValueError("the card was not computed: nothing to draw")
    card = result.card
    pu, lu = card.position_unit, card.load_unit
    fig = Figure(figsize=(10, 4.2), dpi=100)
    left, right = fig.subplots(1, 2, sharey=False)
    left.plot([*card.position, card.position[0]], [*card.load, card.load[0]], color="black")
    left.set_title("surface card (polished rod)")
    pos, load = result.position[-1], result.load[-1]
    right.plot([*pos, pos[0]], [*load, load[0]], color="tab:blue")
    q = result.quantities()
    for name in ("upper_load_line", "lower_load_line"):
        right.axhline(q[name]["value"], color="gray", lw=0.7, ls="--")
    # Positions are shown from the plunger's lowest point: the transfer point sits at
    # fillage times the gross stroke (none without a fluid load: no fillage then).
    fillage = q["fillage"]["value"]
    if fillage is not None:
        right.axvline(fillage * q["gross_stroke"]["value"], color="tab:red", lw=0.7)
    right.set_title(f"pump card ({result.convention} load, {result.method}, "
                    f"damping {result.damping:g})")
    for ax in (left, right):
        ax.set_xlabel(f"position ({pu})")
        ax.set_ylabel(f"load ({lu})")
        ax.grid(alpha=0.3)
    said = "no fillage (no fluid load)" if fillage is None else f"fillage {fillage:.2f}"
    fig.suptitle(f"card {card.card_id}: {said}, fluid load "
                 f"{q['fluid_load']['value']:.4g} {lu}, gross stroke "
                 f"{q['gross_stroke']['value']:.4g} {pu}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
