"""sktime ``.ts`` files with two dimensions (position and load), one series per line."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._common import Opts, Raw, meaningful, num, numbers
from ._errors import CardError

__all__ = ["read_ts"]


def read_ts(o: Opts, holder: list[str], column_keys: dict[str, str]) -> list[Raw | CardError]:
    """Read an sktime ``.ts`` file; ``holder`` holds the text and is emptied."""
    tags: dict[str, str] = {}
    lines = meaningful(holder.pop())
    for lineno, line in lines:
        s = line.strip()
        if not s.startswith("@"):
            raise o.error("expected an '@' tag or '#' comment before the '@data' line", line=lineno)
        parts = s[1:].split(None, 1)
        key = parts[0].lower() if parts else ""
        if key == "data":
            break
        tags[key] = parts[1].strip() if len(parts) > 1 else ""
    else:
        raise o.error("no '@data' line: not a complete sktime .ts file")
    if tags.get("timestamps", "false").lower().startswith("true"):
        raise o.error("time-stamped .ts files are not supported", field="@timeStamps")
    has_label = any(
        tags.get(t, "false").split()[:1] == ["true"] for t in ("classlabel", "targetlabel")
    )
    ndims: int | None = None
    if "dimensions" in tags:
        try:
            ndims = int(tags["dimensions"])
        except ValueError as exc:
            raise o.error(
                f"bad @dimensions value {tags['dimensions']!r}", field="@dimensions"
            ) from exc
    univariate = tags.get("univariate", "false").lower().startswith("true")
    dims = {"position": 0, "load": 1}
    given = {column_keys[k]: v for k, v in (o.columns or {}).items()}
    if given:
        for role, v in given.items():
            if role not in ("position", "load") or not isinstance(v, int):
                raise o.error(
                    "for .ts files columns= maps 'position' and 'load' to dimension numbers",
                    field="columns",
                )
            dims[role] = v
    if univariate or (ndims is not None and ndims < 2):
        raise o.error(
            "univariate series: a card needs two dimensions (position and load)",
            field="@univariate",
        )

    def series(k: int, lineno: int, line: str) -> Raw:
        parts = line.strip().split(":")
        label = None
        if has_label:
            if len(parts) < 2:
                raise o.error("expected dimensions and a class label separated by ':'", line=lineno)
            label = parts[-1].strip()
            parts = parts[:-1]
        if ndims is not None and len(parts) != ndims:
            raise o.error(
                f"expected {ndims} dimensions (from @dimensions), found {len(parts)}", line=lineno
            )
        for role, d in dims.items():
            if not 0 <= d < len(parts):
                raise o.error(
                    f"{role} is dimension {d} but the series has {len(parts)}",
                    line=lineno,
                    field=f"dim{d}",
                )

        def values(d: int, lineno: int = lineno, parts: list[str] = parts) -> np.ndarray:
            if "?" in parts[d]:
                for i, tok in enumerate(parts[d].split(",")):
                    if tok.strip() == "?":
                        raise o.error("missing value '?'", line=lineno, field=f"dim{d}[{i}]")
                    num(o, tok, line=lineno, field=f"dim{d}[{i}]")
            return numbers(o, parts[d], line=lineno, field=f"dim{d}")

        pos, load = values(dims["position"]), values(dims["load"])
        meta: dict[str, Any] = {"series_index": k}
        if label is not None:
            meta["label"] = label
        if "problemname" in tags:
            meta["problem_name"] = tags["problemname"]
        raw = Raw(
            position=pos,
            load=load,
            card_id=f"{o.stem}[{k}]",
            source=f"{o.name}, line {lineno}",
            line=lineno,
            pos_field=f"dim{dims['position']}",
            load_field=f"dim{dims['load']}",
            metadata=meta,
        )
        if (dims["position"], dims["load"]) == (0, 1) and not given:
            raw.notes.append("dimension 0 read as position and dimension 1 as load (default)")
        return raw

    out: list[Raw | CardError] = []
    for k, (lineno, line) in enumerate(lines):
        try:  # each series on its own: a broken one is an error in its place
            out.append(series(k, lineno, line))
        except CardError as exc:
            out.append(exc.for_card(f"{o.stem}[{k}]"))
    if not out:
        raise o.error("no series after '@data'")
    return out
