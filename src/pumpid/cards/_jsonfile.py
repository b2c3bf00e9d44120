"""JSON cards: one card object, a list of them, or ``{"cards": [...], <shared fields>}``;
a list may hold groups too, ``[{"well": "A", "cards": [...]}, ...]`` (each group's fields
shared by its cards)."""

from __future__ import annotations

import json
import re
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._common import Opts, Raw, file_unit, rate, time_factor
from ._errors import CardError
from ._stamps import looks_like_stamp
from ._text import interpret_name, normalize_name

__all__ = ["read_json"]

_SURROGATE = re.compile("[\ud800-\udfff]")
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")
# Marks a value the parser could not read (see _loads_marking); no JSON text starts so.
_MARK = "\x00pumpid-unparsable\x00"
_STOP = frozenset(',[]{}:"\r\n')
# A file with more unparsable values than this is refused as a whole (each costs a parse).
_MAX_MARKED = 100
_JSON_ROLE_EXTRA = {
    "units": "units", "position_unit": "position_unit", "load_unit": "load_unit",
    "time_unit": "time_unit", "t_unit": "time_unit", "name": "card",
}  # fmt: skip


def _json_numbers(o: Opts, value: Any, where: str, time: bool = False) -> NDArray[np.float64]:
    if not isinstance(value, list):
        raise o.error(f"expected a list of numbers, got {type(value).__name__}", field=where)
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int | float):
            shown = repr(v) if len(repr(v)) <= 40 else repr(v)[:37] + "..."
            stamp = time and isinstance(v, str) and looks_like_stamp(v)
            raise o.error(f"expected a number, got {shown}" + (
                ": a JSON card's time is in seconds (date/time stamps are read in tables "
                "only)" if stamp else ""), field=f"{where}[{i}]")
        try:
            out.append(float(v))
        except OverflowError as exc:
            raise o.error("number out of range", field=f"{where}[{i}]") from exc
    return np.array(out, dtype=float)


def _json_rate(o: Opts, value: Any, where: str, what: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise o.error(f"{what} must be a number, got {type(value).__name__}", field=where)
    try:
        return rate(o, float(value), line=None, field=where, what=what)
    except OverflowError as exc:
        raise o.error(f"{what} out of range", field=where) from exc


def _json_str(o: Opts, value: Any, where: str) -> str:
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise o.error(f"expected a string, got {type(value).__name__}", field=where)
    return str(value)


def _escape_surrogates(doc: Any) -> tuple[Any, int]:
    """``doc`` with lone surrogates in its strings (keys and values) written escaped.

    JSON's ``\\ud800`` escape decodes to a lone surrogate, which no UTF-8 writer (CSV,
    Parquet, HTML) accepts; escaping at read time keeps every later write valid. The walk
    uses its own stack: a document deep enough to matter was already refused by the parser.
    """
    count = 0

    def fix(text: str) -> str:
        nonlocal count
        if _SURROGATE.search(text) is None:
            return text
        count += 1
        return text.encode("utf-8", "backslashreplace").decode("utf-8")

    def fixed(value: Any) -> Any:
        if isinstance(value, str):
            return fix(value)
        if isinstance(value, dict):
            return {fix(k): v for k, v in value.items()}
        return value

    root = [fixed(doc)]
    stack: list[Any] = [root]
    while stack:
        node = stack.pop()
        keys = range(len(node)) if isinstance(node, list) else list(node)
        for k in keys:
            v = fixed(node[k])
            node[k] = v
            if isinstance(v, list | dict):
                stack.append(v)
    return root[0], count


def _loads_marking(text: str) -> tuple[Any, int]:
    """``json.loads``, with each bare unparsable value (``nan``, ``1.2.3``, ``abc`` where a
    value belongs) replaced by a marked string naming its line and text, so that it spoils
    only the card it is in; the number of such values. Structural errors are raised.

    The json module stops at the first error and cannot resume, hence this loop.
    """
    marked = 0
    while True:
        try:
            return json.loads(text), marked
        except json.JSONDecodeError as exc:
            fixed = None if marked >= _MAX_MARKED else _mark_value(text, exc.pos)
            if fixed is None:
                raise
            text = fixed
            marked += 1


def _mark_value(text: str, pos: int) -> str | None:
    start = end = pos
    while start > 0 and text[start - 1] not in _STOP:
        start -= 1
    while end < len(text) and text[end] not in _STOP:
        end += 1
    # A value may hold spaces ("J. Doe"); the spaces around it are not part of it.
    while start < end and text[start].isspace():
        start += 1
    while end > start and text[end - 1].isspace():
        end -= 1
    token = text[start:end]
    if not token:
        return None
    try:
        json.loads(token)
        return None  # a valid value: the error is in the structure around it
    except ValueError:
        pass
    before = start - 1
    while before >= 0 and text[before].isspace():
        before -= 1
    after = end
    while after < len(text) and text[after].isspace():
        after += 1
    # Only a value: after '[', ',' or ':', and not a key (followed by ':').
    if before < 0 or text[before] not in "[,:" or text[after:after + 1] == ":":
        return None
    line = text.count("\n", 0, start) + 1
    return text[:start] + json.dumps(f"{_MARK}{line}\x00{token}") + text[end:]


def _raise_marked(o: Opts, value: Any, where: str) -> None:
    """Raise a CardError for the first marked (unparsable) value in ``value``, if any."""
    stack: list[tuple[Any, str]] = [(value, where)]
    while stack:
        node, path = stack.pop()
        if isinstance(node, str):
            if node.startswith(_MARK):
                line, _, token = node[len(_MARK):].partition("\x00")
                shown = token if len(token) <= 40 else token[:37] + "..."
                raise o.error(f"unparsable value {shown!r}", line=int(line),
                              field=path or None)
            continue
        if isinstance(node, dict):
            children = [(v, f"{path}.{k}" if path else str(k)) for k, v in node.items()]
        elif isinstance(node, list):
            children = [(v, f"{path}[{i}]") for i, v in enumerate(node)]
        else:
            continue
        stack.extend(reversed(children))


def read_json(o: Opts, holder: list[str]) -> list[Raw | CardError]:
    """Read a JSON document; ``holder`` holds the text and is emptied.

    Each card object is read on its own: a broken one is a :class:`CardError` in its place
    (with its id), and the other cards are still read.
    """
    text = holder.pop()
    needs_escape = _SURROGATE_ESCAPE.search(text) is not None
    try:
        doc, repaired = _loads_marking(text)
    except json.JSONDecodeError as exc:
        raise o.error(f"invalid JSON: {exc.msg} (column {exc.colno})", line=exc.lineno) from exc
    except RecursionError as exc:
        raise o.error("invalid JSON: nested deeper than the parser can follow (a card file "
                      "needs a few levels)") from exc
    except ValueError as exc:
        raise o.error(f"invalid JSON: {exc}") from exc
    del text
    escaped = 0
    if needs_escape:
        doc, escaped = _escape_surrogates(doc)
    shared: dict[str, Any] = {}
    prefix = "cards"
    if repaired and not isinstance(doc, list | dict):
        _raise_marked(o, doc, "")
    if isinstance(doc, list):
        items: Any = doc
        prefix = ""
    elif isinstance(doc, dict):
        lists = [k for k in doc if isinstance(k, str) and (k.lower() == "cards" or (
            k.lower() == "wells" and isinstance(doc[k], list)
            and any(_cards_key(w) is not None for w in doc[k])))]
        if len(lists) > 1:
            raise o.error(f"the document has both {lists[0]!r} and {lists[1]!r}: give one list "
                          "of cards or of wells (a well's own cards go in its object)",
                          field=lists[1])
        cards_key = lists[0] if lists else None
        if cards_key is not None:
            items = doc[cards_key]
            if not isinstance(items, list):
                raise o.error(f"{cards_key!r} must be a list of card or well objects",
                              field=cards_key)
            prefix = cards_key
            shared = {k: v for k, v in doc.items() if k != cards_key}
            if repaired:  # a bad value outside the cards is the whole file's
                _raise_marked(o, shared, "")
        else:
            items, prefix = [doc], ""
    else:
        raise o.error(f"top level must be an object or a list, got {type(doc).__name__}")
    if not items:
        raise o.error("no cards in the JSON document", field=prefix or None)
    entries = _entries(o, items, prefix, shared, len(items) > 1 or isinstance(doc, list))
    out: list[Raw | CardError] = []
    for where, item, obj, origin, listed_id in entries:
        default_id = o.stem if len(entries) == 1 else listed_id
        card_id, well_id = _ids(obj, default_id)
        try:  # each card on its own: a broken one is an error in its place
            if isinstance(item, CardError):
                raise item
            if not isinstance(item, dict):
                raise o.error(
                    f"a card must be an object, got {type(item).__name__}", field=where or None
                )
            if repaired:  # each value named where it is written (the card's, its group's)
                for path in dict.fromkeys(origin.values()):
                    _raise_marked(o, {k: v for k, v in obj.items()
                                      if origin.get(k, where) == path}, path)
            out.append(_json_card(o, obj, where, default_id, origin))
        except CardError as exc:
            out.append(exc.for_card(card_id, well_id))
    if escaped:
        for raw in out:
            if isinstance(raw, Raw):
                raw.notes.append(
                    f"{escaped} text value(s) of the file held a lone surrogate escape (such as "
                    "\\ud800), which is not text: written escaped (as \\ud800) so that every "
                    "output can hold it"
                )
    return out


def _cards_key(item: Any) -> str | None:
    """The key of a group's list of cards (``"cards"`` in any case), None for a card."""
    if not isinstance(item, dict):
        return None
    return next((k for k in item if isinstance(k, str) and k.lower() == "cards"), None)


def _role(key: str) -> str:
    """What a field names, so that two spellings of one field (``Well``, ``well_id``) are
    one: its role, else its normalised name."""
    norm = normalize_name(key)
    return _JSON_ROLE_EXTRA.get(norm) or interpret_name(key)[0] or norm


def _over(outer: dict[str, Any], inner: dict[str, Any]) -> dict[str, Any]:
    """``inner``'s fields over ``outer``'s, however each spells a field: a group's ``Well``
    was beaten by the document's ``well`` (the first spelling read wins in a card). Objects
    (``units``) merge, the inner entries winning; a recording ``time`` (text) and a card's
    ``t`` (numbers) are two fields."""
    mine = {_role(k): k for k in inner}
    merged = dict(inner)
    kept: dict[str, Any] = {}
    for key, value in outer.items():
        own = mine.get(_role(key))
        if own is None or isinstance(value, list) != isinstance(inner[own], list):
            kept[key] = value
        elif isinstance(value, dict) and isinstance(inner[own], dict):
            merged[own] = {**value, **inner[own]}
    return {**kept, **merged}


Entry = tuple[str, Any, dict[str, Any], dict[str, str], str]


def _layered(outer: dict[str, Any], outer_at: dict[str, str], inner: dict[str, Any],
             path: str) -> tuple[dict[str, Any], dict[str, str]]:
    """``inner``'s fields over ``outer``'s (:func:`_over`), and where each is written:
    ``path`` for ``inner``'s, ``outer_at``'s place for the others."""
    obj = _over(outer, inner)
    return obj, {f: path if f in inner else outer_at[f] for f in obj}


def _entries(o: Opts, items: list[Any], prefix: str, shared: dict[str, Any], indexed: bool
             ) -> list[Entry]:
    """The cards of a document's list, each as (where, its object, the object with the
    fields it shares, where each of those fields is, a default id). An item holding
    ``"cards"`` is a group (a well's cards with the fields they share, ``[{"well": "A",
    "cards": [...]}, ...]``); its cards take its fields over the document's, and their own
    over both."""
    out: list[Entry] = []
    document = dict.fromkeys(shared, "")
    for k, item in enumerate(items):
        where = f"{prefix}[{k}]" if (prefix or indexed) else ""
        key = _cards_key(item)
        if key is None:
            obj, origin = _layered(shared, document, item if isinstance(item, dict) else {},
                                   where)
            out.append((where, item, obj, origin, f"{o.stem}[{k}]"))
            continue
        group, group_origin = _layered(shared, document,
                                       {f: v for f, v in item.items() if f != key}, where)
        cards = item[key]
        if not isinstance(cards, list) or not cards:
            problem = o.error(f"a group's {key!r} must be a non-empty list of card objects",
                              field=f"{where}.{key}" if where else key)
            out.append((where, problem, group, group_origin, f"{o.stem}[{k}]"))
            continue
        for j, card in enumerate(cards):
            inner = f"{where}.{key}[{j}]" if where else f"{key}[{j}]"
            if _cards_key(card) is not None:
                card = o.error("groups do not nest: a group's cards are card objects",
                               field=f"{inner}.{_cards_key(card)}")
            obj, origin = _layered(group, group_origin, card if isinstance(card, dict) else {},
                                   inner)
            out.append((inner, card, obj, origin, f"{o.stem}[{k}][{j}]"))
    return out


def _ids(obj: dict[str, Any], default: str) -> tuple[str, str | None]:
    """A card's id and well as its object states them (for naming a broken card)."""
    card_id, well_id = default, None
    for key, value in obj.items():
        role = _role(key)
        if isinstance(value, str) and value.startswith(_MARK):
            continue
        if role == "card" and isinstance(value, str | int) and not isinstance(value, bool):
            card_id = str(value)
        elif role == "well" and isinstance(value, str) and well_id is None:
            well_id = value
    return card_id, well_id


def _json_card(o: Opts, obj: dict[str, Any], where: str, default_id: str,
               origin: dict[str, str]) -> Raw:
    def at(key: str) -> str:
        # A field a group or the document gives is named where it is written.
        path = origin.get(key.split(".", 1)[0], where)
        return f"{path}.{key}" if path else key

    found: dict[str, tuple[str, Any, str | None]] = {}
    meta: dict[str, Any] = {}
    notes: list[str] = []
    for key, value in obj.items():
        norm = normalize_name(key)
        role: str | None = _JSON_ROLE_EXTRA.get(norm)
        unit = None
        if role is None:
            role, _base, unit = interpret_name(key)
        if role == "t" and isinstance(value, str):
            role = None  # "time": "2024-05-01T10:00:00Z" says when, not a time axis
        if role is None or role in found:
            meta[key] = value
            continue
        found[role] = (key, value, unit)
    for role in ("position", "load"):
        if role not in found:
            raise o.error(f"missing {role!r} array", field=where or None)
    units_obj: dict[str, Any] = {}
    if "units" in found:
        ukey, uval, _ = found["units"]
        if not isinstance(uval, dict):
            raise o.error('\'units\' must be an object like {"position": "in"}', field=at(ukey))
        for uk, uv in uval.items():
            nk = normalize_name(uk)
            nk = {"time": "t", "pos": "position", "force": "load"}.get(nk, nk)
            if nk not in ("position", "load", "t"):
                notes.append(f"unit for {uk!r} in 'units' not used")
                continue
            units_obj[nk] = (_json_str(o, uv, at(f"{ukey}.{uk}")), at(f"{ukey}.{uk}"))
    for role, kind in (("position_unit", "position"), ("load_unit", "load"), ("time_unit", "t")):
        if role in found and found[role][1] is not None:
            units_obj.setdefault(
                kind, (_json_str(o, found[role][1], at(found[role][0])), at(found[role][0]))
            )
    for role in ("position", "load", "t"):
        if role in found and found[role][2] is not None:
            units_obj.setdefault(role, (found[role][2], at(found[role][0])))

    pkey, lkey = found["position"][0], found["load"][0]
    pos = _json_numbers(o, found["position"][1], at(pkey))
    load = _json_numbers(o, found["load"][1], at(lkey))
    t = t_field = None
    t_factor = 1.0
    if "t" in found and found["t"][1] is not None:
        t_field = at(found["t"][0])
        t = _json_numbers(o, found["t"][1], t_field, time=True)
        if "t" in units_obj:
            t_factor = time_factor(o, units_obj["t"][0], line=None, field=units_obj["t"][1])
    if "card" in found:
        card_id = _json_str(o, found["card"][1], at(found["card"][0]))
    else:
        card_id = default_id
    well_id = None
    if "well" in found and found["well"][1] is not None:
        well_id = _json_str(o, found["well"][1], at(found["well"][0]))
    spm = period = None
    rate_where = ""
    if "spm" in found:
        spm = _json_rate(o, found["spm"][1], at(found["spm"][0]), "spm")
        rate_where = f"key {found['spm'][0]!r}"
    if "period" in found:
        period = _json_rate(o, found["period"][1], at(found["period"][0]), "period")
        if spm is not None and period is not None:
            meta[found["period"][0]] = period
            period = None
        elif period is not None:
            rate_where = f"key {found['period'][0]!r}"
    if "closure" in found:
        meta[found["closure"][0]] = found["closure"][1]
    pu = units_obj.get("position")
    lu = units_obj.get("load")
    return Raw(
        position=pos,
        load=load,
        t=t,
        t_field=t_field or "t",
        t_factor=t_factor,
        card_id=card_id,
        source=f"{o.name}, {where or 'top level'}",
        pos_field=at(pkey),
        load_field=at(lkey),
        pos_unit=None if pu is None else file_unit(o, "position", pu[0], line=None, field=pu[1]),
        pos_unit_where="" if pu is None else f"JSON {pu[1]!r}",
        load_unit=None if lu is None else file_unit(o, "load", lu[0], line=None, field=lu[1]),
        load_unit_where="" if lu is None else f"JSON {lu[1]!r}",
        well_id=well_id,
        spm=spm,
        period=period,
        rate_where=rate_where,
        notes=notes,
        metadata=meta,
    )
