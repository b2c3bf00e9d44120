"""Display-safe text: the one helper every message about a file or card id goes through."""

from __future__ import annotations

__all__ = ["printable"]


def printable(text: object) -> str:
    r"""Return ``text`` with every non-printable character escaped, for messages and screens.

    Control characters, ANSI escape sequences, line breaks and other invisible or
    layout-changing characters are written as Python escapes (``\x1b``, ``\n``, ``\u200b``);
    everything printable, accented letters and other scripts included, is kept. Card ids and
    file names are stored raw; use this when showing them. Meant for display: the result is
    not meant to be turned back into the original.

    Parameters
    ----------
    text : object
        A string (anything else is converted with ``str``).

    Returns
    -------
    str

    Examples
    --------
    >>> printable("well\x1b[31m-7\n")
    'well\\x1b[31m-7\\n'
    """
    s = text if isinstance(text, str) else str(text)
    if s.isprintable():
        return s
    return "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in s)
