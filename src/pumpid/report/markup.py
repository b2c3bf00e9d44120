"""HTML markup of plain values: escaped text, numbers, tables, sections and lists.

Every piece of text is escaped here, because warnings, notes and reasons may quote file
contents; the pages built from these pieces contain no JavaScript.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["bullet_list", "escape", "interval", "number", "section", "table", "value_html"]


def escape(text: Any) -> str:
    """Escape any value's text for HTML element content and attribute values.

    Parameters
    ----------
    text : Any
        Any value; its ``str`` is escaped.

    Returns
    -------
    str
        The text with ``&``, ``<``, ``>`` and both quotes escaped.
    """
    return html.escape(str(text), quote=True)


def number(value: Any, digits: int = 6) -> str:
    """A number as text; None, NaN and infinities read "n/a" (they mean "not available").

    Parameters
    ----------
    value : Any
        A number (integers and booleans are written as they are); anything that is not
        one is shown as its text.
    digits : int, default 6
        Significant digits of a float.

    Returns
    -------
    str
    """
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int | np.integer):
        return str(int(value))
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not math.isfinite(x):
        return "n/a"
    return f"{x:.{digits}g}"


def interval(value: Any) -> str:
    """A confidence interval given as (low, high) or {"lower": .., "upper": ..}.

    Parameters
    ----------
    value : Any
        The interval; a mapping may also name its ends ``"low"`` and ``"high"``. Anything
        else is shown as a number.

    Returns
    -------
    str
        ``"[low, high]"``.
    """
    if isinstance(value, Mapping):
        lo, hi = value.get("lower", value.get("low")), value.get("upper", value.get("high"))
        if lo is not None or hi is not None:
            return f"[{number(lo)}, {number(hi)}]"
    elif isinstance(value, Sequence | np.ndarray) and not isinstance(value, str):
        if len(value) == 2:
            return f"[{number(value[0])}, {number(value[1])}]"
    return number(value)


def table(headers: Sequence[str], rows: Iterable[Sequence[str]], *, cls: str = "",
          num_cols: Iterable[int] = ()) -> str:
    """An HTML table of plain text.

    Parameters
    ----------
    headers : sequence of str
        Column headings (plain text, escaped here).
    rows : iterable of sequences of str
        The cells (plain text, escaped here).
    cls : str, optional
        The table's class attribute.
    num_cols : iterable of int
        Indices of the columns that hold numbers (right-aligned, monospace).

    Returns
    -------
    str
    """
    num = set(num_cols)
    attr = f' class="{escape(cls)}"' if cls else ""
    out = [f"<table{attr}>", "<thead><tr>"]
    out += [f"<th>{escape(h)}</th>" for h in headers]
    out.append("</tr></thead>")
    out.append("<tbody>")
    for row in rows:
        cells = "".join(
            f'<td class="num">{escape(c)}</td>' if i in num else f"<td>{escape(c)}</td>"
            for i, c in enumerate(row)
        )
        out.append(f"<tr>{cells}</tr>")
    out.append("</tbody></table>")
    return "\n".join(out)


def section(heading: str, body: str, *, sid: str = "") -> str:
    """A report section: its heading and its body.

    Parameters
    ----------
    heading : str
        Plain text, escaped here.
    body : str
        HTML, inserted as it is.
    sid : str, optional
        The section's id (for links to it).

    Returns
    -------
    str
    """
    attr = f' id="{escape(sid)}"' if sid else ""
    return f"<section{attr}>\n<h2>{escape(heading)}</h2>\n{body}\n</section>"


def bullet_list(items: Iterable[Any]) -> str:
    """A bulleted list of the items' text, each escaped.

    Parameters
    ----------
    items : iterable
        Anything; each item's ``str`` is shown in full.

    Returns
    -------
    str
    """
    return "<ul>\n" + "\n".join(f"<li>{escape(i)}</li>" for i in items) + "\n</ul>"


def value_html(value: Any, depth: int = 0) -> str:
    """Render a value of unknown shape from ``result.extra`` readably (escaped).

    Later analyses store their findings in ``extra`` in whatever structure suits them; this
    shows strings as paragraphs, mappings as two-column tables, lists as bullet lists and
    long numeric arrays as a short summary, so the report never breaks on a new key.

    Parameters
    ----------
    value : Any
        The value to show.
    depth : int, default 0
        Nesting level reached; from level 2 on a structure is shown as its shortened text.

    Returns
    -------
    str
    """
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, str):
        return f"<p>{escape(value)}</p>"
    if isinstance(value, Mapping):
        if depth >= 2:
            return f"<p>{escape(_short(value))}</p>"
        rows = []
        for k, v in value.items():
            if isinstance(v, Mapping | list | tuple | np.ndarray) and not _is_numeric_seq(v):
                cell = value_html(v, depth + 1)
            else:
                cell = escape(_scalar_text(v))
            rows.append(f"<tr><th>{escape(k)}</th><td>{cell}</td></tr>")
        return "<table>\n" + "\n".join(rows) + "\n</table>"
    if isinstance(value, list | tuple):
        if _is_numeric_seq(value):
            return f"<p>{escape(_scalar_text(value))}</p>"
        if depth >= 2:
            return f"<p>{escape(_short(value))}</p>"
        return "<ul>\n" + "\n".join(
            f"<li>{value_html(v, depth + 1) if isinstance(v, Mapping) else escape(_scalar_text(v))}"
            "</li>" for v in value
        ) + "\n</ul>"
    return f"<p>{escape(_scalar_text(value))}</p>"


def _is_numeric_seq(value: Any) -> bool:
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "biuf"
    return isinstance(value, list | tuple) and all(
        isinstance(v, int | float | np.number) and not isinstance(v, bool) for v in value
    )


def _scalar_text(value: Any) -> str:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple) and _is_numeric_seq(value):
        if len(value) > 12:
            head = ", ".join(number(v, 4) for v in value[:6])
            return f"{len(value)} values: {head}, ..."
        return "[" + ", ".join(number(v) for v in value) + "]"
    if isinstance(value, float | int | np.number) and not isinstance(value, bool):
        return number(value)
    return _short(value)


def _short(value: Any, limit: int = 300) -> str:
    """Text of a nested value of unknown shape, shortened at a word boundary if long.

    Only the catch-all rendering of deep structures uses this; findings, warnings, notes
    and reasons are always shown in full.
    """
    text = str(value)
    if len(text) <= limit:
        return text
    cut = text.rfind(" ", 0, limit)
    cut = cut if cut > limit // 2 else limit
    return f"{text[:cut].rstrip(' ,;:')} ... ({len(text) - cut} more characters)"
