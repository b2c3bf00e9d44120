"""Text cells of CSV files that a spreadsheet cannot take for a formula.

A spreadsheet opening a CSV file evaluates a cell that starts with ``=``, ``+``, ``-`` or
``@`` as a formula (a tab or carriage return in front is skipped by some), so a card id such
as ``=HYPERLINK("http://...")`` in a results table would run when the file is opened.
Every CSV file pumpid writes for people to open passes its text cells through
:func:`neutralise`: such a cell gets a single quote in front (``'=HYPERLINK(...)``), which
spreadsheets show as text and do not evaluate. Two kinds of cell are left as they are,
because no spreadsheet reads them as a formula and changing them would change the data: a
plain number written as text (``-5``, ``+1.5e3``) and a lone ``-`` or ``+`` (the unit of
a dimensionless quantity is ``-``). Parquet and JSON outputs keep the raw text.

Rows end in CR LF (RFC 4180). Besides being what spreadsheets expect, this makes Python's
``csv`` writer (and pandas') quote a cell holding a lone carriage return, which with the
default line end it writes bare, so that a reader splits the row in two there.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

__all__ = ["FORMULA_STARTS", "LINE_END", "neutralise", "neutralise_frame", "neutralise_row",
           "to_csv"]

#: First characters that make a spreadsheet cell a formula (or hide one after them).
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
#: The line end of every CSV file for spreadsheets (``lineterminator=`` of the writers).
LINE_END = "\r\n"
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


def neutralise(value: Any) -> Any:
    """A cell for a CSV file: text a spreadsheet would evaluate gets a ``'`` in front.

    Parameters
    ----------
    value : object
        The cell; anything but a string is returned as it is.

    Returns
    -------
    object
    """
    if not isinstance(value, str) or not value.startswith(FORMULA_STARTS):
        return value
    if value in ("-", "+") or _NUMBER.fullmatch(value):
        return value
    return "'" + value


def neutralise_row(row: Mapping[str, Any]) -> dict[str, Any]:
    """A row for :class:`csv.DictWriter` with :func:`neutralise` applied to every cell.

    Parameters
    ----------
    row : mapping of column name to cell

    Returns
    -------
    dict
    """
    return {k: neutralise(v) for k, v in row.items()}


def neutralise_frame(frame: Any) -> Any:
    """A copy of a pandas DataFrame with :func:`neutralise` applied to its text columns.

    Numeric, boolean and time columns are not touched (a spreadsheet reads them as values).

    Parameters
    ----------
    frame : pandas.DataFrame

    Returns
    -------
    pandas.DataFrame
    """
    out = frame.copy()
    for col in out.columns:
        kind = out[col].dtype.kind
        if kind in "OSU" or str(out[col].dtype).startswith("string"):
            out[col] = out[col].map(neutralise, na_action="ignore")
    # Column names are cells too.
    out.columns = [neutralise(c) for c in out.columns]
    return out


def to_csv(frame: Any, target: Any, **options: Any) -> None:
    """Write a pandas DataFrame as a CSV file for spreadsheets.

    Text cells neutralised (:func:`neutralise_frame`), rows ending in CR LF, no index.

    Parameters
    ----------
    frame : pandas.DataFrame
    target : path or text file object
        What :meth:`pandas.DataFrame.to_csv` writes to.
    **options
        Further options of :meth:`pandas.DataFrame.to_csv` (``header``, ``date_format``).
    """
    neutralise_frame(frame).to_csv(target, index=False, lineterminator=LINE_END, **options)
