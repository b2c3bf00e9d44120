"""Words for counts, shared by every command's and report's text (no heavy imports)."""

from __future__ import annotations

__all__ = ["plural"]


def plural(n: int, word: str, words: str | None = None) -> str:
    """``n`` with its noun agreeing: ``1 card``, ``0 cards``, ``3 cards``.

    Parameters
    ----------
    n : int
        The count.
    word : str
        The noun in the singular.
    words : str, optional
        The plural when it is not ``word + "s"`` (``"analyses"``).

    Returns
    -------
    str
    """
    return f"{n} {word if n == 1 else (words or word + 's')}"
