"""The results folder of a batch run: a Parquet dataset written one partition at a time.

Layout of ``RESULTS/``::

    _manifest.json         inputs (name, absolute path, size, modification time of every
                           file), options, pumpid's version, and whether the run is complete
    part-000000.parquet    one file per partition of cards, in the order of the inputs
    part-000001.parquet
    ...
    _summary.txt           the run's summary (written when a run ends)

``pandas.read_parquet(RESULTS)`` reads the parts as one table (names starting with ``_``
or ``.`` are not part of the dataset); :func:`read_results` also puts the rows in input
order and warns when the run is not complete.

Nothing is lost or mixed: a part is written to a hidden temporary file, flushed to disk
and renamed into place, so a part either exists whole or not at all, whatever stops the
process. A part records in its schema metadata the partition's index, its number of rows
and its first and last card ids; a resumed run checks them against the partition it
rebuilds from the inputs before skipping it. A folder whose manifest names other inputs
(files added, removed or changed), other options or another pumpid version is refused.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pumpid.models import Model
from pumpid.result.table import check_row
from pumpid.result.table import results_schema as table_schema

__all__ = [
    "BATCH_COLUMNS",
    "MANIFEST",
    "ResultsFolderError",
    "ResultsStore",
    "read_results",
    "results_schema",
    "storable_table",
]

#: The manifest's file name inside the results folder.
MANIFEST = "_manifest.json"
SUMMARY = "_summary.txt"
_KIND = "pumpid batch results"
_LAYOUT = 1
_META_KEY = b"pumpid.partition"
#: Columns a batch run adds to :meth:`pumpid.FitResult.to_row`'s: the input file's name, the
#: card's position in the run's input order, its partition, and the id of the earlier card
#: of the run it repeats exactly (same well, samples, time axis and units), if any.
BATCH_COLUMNS = ("file", "item", "partition", "duplicate_of")


class ResultsFolderError(ValueError):
    """A results folder that cannot be used for this run (other inputs or options, not a
    results folder, a run already there)."""


def results_schema(model: type[Model] | Sequence[type[Model]]) -> pa.Schema:
    """The Arrow schema of a run's results (:func:`pumpid.result.table.results_schema`, the
    one owner of the table's columns; :data:`BATCH_COLUMNS` are among its identity columns).

    Parameters
    ----------
    model : Model class or sequence of Model classes

    Returns
    -------
    pyarrow.Schema
    """
    return table_schema(model)


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def _differences(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    """What differs between two manifests, in words (inputs, options, version)."""
    out: list[str] = []
    if old.get("pumpid") != new.get("pumpid"):
        out.append(f"pumpid version {old.get('pumpid')} there, {new.get('pumpid')} now")
    if old.get("table") != new.get("table"):
        # Parts with other columns cannot be read as one table with this run's: the new
        # columns were dropped on reading, and the statuses of the two parts could differ.
        out.append("the run was written by an earlier pumpid (its results table has other "
                   "columns); write this run to a new folder")
    before = {f["path"]: f for f in old.get("files", [])}
    after = {f["path"]: f for f in new.get("files", [])}
    gone = [before[p]["name"] for p in before if p not in after]
    added = [after[p]["name"] for p in after if p not in before]
    changed = [after[p]["name"] for p in after if p in before
               and (after[p]["size"], after[p]["mtime_ns"])
               != (before[p]["size"], before[p]["mtime_ns"])]

    def some(names: list[str]) -> str:
        return ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")

    if gone:
        out.append(f"{len(gone)} input file(s) no longer given or gone: {some(gone)}")
    if added:
        out.append(f"{len(added)} input file(s) not in the run: {some(added)}")
    if changed:
        out.append(f"{len(changed)} input file(s) changed since (size or time): {some(changed)}")
    if not (gone or added or changed) and list(before) != list(after):
        out.append("the input files come in another order")
    for key in sorted(set(old.get("options", {})) | set(new.get("options", {}))):
        a, b = old.get("options", {}).get(key), new.get("options", {}).get(key)
        if a == b:
            continue
        unknown = (sorted(set(b) - set(a)) if isinstance(a, dict) and isinstance(b, dict)
                   else [])
        if unknown and all(a[k] == b[k] for k in a if k in b):
            # Not a choice the user made: a manifest from before these options existed (its
            # parts lack the columns this version writes, so the two are not mixed).
            out.append(f"option {key}: the run was written by an earlier pumpid (its "
                       f"manifest has no {', '.join(unknown)}); write this run to a new "
                       "folder")
        else:
            out.append(f"option {key}: {json.dumps(a)} there, {json.dumps(b)} now")
    return out


@dataclass(frozen=True)
class PartInfo:
    """What a written part says about itself."""

    index: int
    rows: int
    first: str
    last: str


class ResultsStore:
    """A run's results folder: the manifest, the parts written, and writing new ones.

    Use :meth:`create` for a new run and :meth:`resume` to continue one.
    """

    def __init__(self, folder: Path, manifest: dict[str, Any]) -> None:
        self.folder = folder
        self.manifest = manifest

    # ------------------------------------------------------------------ opening
    @staticmethod
    def check(folder: str | os.PathLike[str], manifest: Mapping[str, Any], *,
              resume: bool) -> None:
        """Refuse a folder :meth:`create` (``resume`` false) or :meth:`resume` would refuse,
        without writing anything.

        Raises
        ------
        ResultsFolderError
            With the reason (a run there already; other inputs, options or version; not a
            results folder).
        """
        out = Path(os.fspath(folder))
        has_run = (out / MANIFEST).exists()
        if has_run and resume:
            diff = _differences(_read_manifest(out), manifest)
            if diff:
                raise ResultsFolderError(
                    f"{out} holds a run of other inputs or options; it is not mixed with this "
                    "one:\n  - " + "\n  - ".join(diff))
            return
        if has_run:
            state = "a complete" if _read_manifest(out).get("complete") else "an unfinished"
            raise ResultsFolderError(
                f"{out} holds {state} batch run already: continue it with --resume (same "
                "inputs and options), or give another --out folder")
        if out.exists() and (not out.is_dir() or any(out.iterdir())):
            raise ResultsFolderError(
                f"{out} exists and is not an empty folder nor a pumpid results folder; give "
                "another --out folder")

    @classmethod
    def create(cls, folder: str | os.PathLike[str], manifest: Mapping[str, Any]) -> ResultsStore:
        """Start a new run in ``folder`` (which must not exist, or be empty).

        Raises
        ------
        ResultsFolderError
            If the folder holds a run already, or anything else.
        """
        out = Path(os.fspath(folder))
        cls.check(out, manifest, resume=False)
        out.mkdir(parents=True, exist_ok=True)
        data = {"kind": _KIND, "layout": _LAYOUT, **manifest, "created": _now(),
                "complete": False}
        store = cls(out, data)
        store._save()
        return store

    @classmethod
    def resume(cls, folder: str | os.PathLike[str], manifest: Mapping[str, Any]) -> ResultsStore:
        """Continue the run in ``folder``; a folder without a run starts a new one.

        Raises
        ------
        ResultsFolderError
            If the folder's run had other inputs, options or pumpid version (the message
            lists the differences), or it is not a results folder.
        """
        out = Path(os.fspath(folder))
        if not (out / MANIFEST).exists():
            return cls.create(out, manifest)
        cls.check(out, manifest, resume=True)
        old = _read_manifest(out)
        for stale in [*out.glob(".part-*.tmp-*"), *out.glob(f".{MANIFEST}.tmp-*")]:
            stale.unlink(missing_ok=True)  # being written when the run was stopped
        data = dict(old)
        data["resumed"] = [*old.get("resumed", []), _now()]
        store = cls(out, data)
        store._save()
        return store

    @staticmethod
    def files_of(folder: str | os.PathLike[str]) -> list[dict[str, Any]]:
        """The input files a results folder's manifest lists (for a resume without inputs)."""
        out = Path(os.fspath(folder))
        if not (out / MANIFEST).exists():
            raise ResultsFolderError(f"{out} holds no batch run to resume; give the inputs")
        return list(_read_manifest(out).get("files", []))

    @staticmethod
    def inputs_of(folder: str | os.PathLike[str]) -> list[str]:
        """The inputs a results folder's run was given.

        Parameters
        ----------
        folder : str or PathLike
            The results folder.

        Returns
        -------
        list of str
            Its files and folders, absolute; empty for a folder holding no run, or one
            written before they were recorded.
        """
        out = Path(os.fspath(folder))
        if not (out / MANIFEST).exists():
            return []
        return [str(p) for p in _read_manifest(out).get("input_paths", [])]

    @staticmethod
    def options_of(folder: str | os.PathLike[str]) -> dict[str, Any] | None:
        """The options of the run in ``folder`` (None when it holds none): what a resume
        takes for the options it is not given."""
        out = Path(os.fspath(folder))
        if not (out / MANIFEST).exists():
            return None
        return dict(_read_manifest(out).get("options", {}))

    def _save(self) -> None:
        text = json.dumps(self.manifest, indent=1, sort_keys=False)
        _write_atomic(self.folder / MANIFEST, text.encode("utf-8"))

    # ------------------------------------------------------------------ parts
    def part_path(self, index: int) -> Path:
        """The file of partition ``index``."""
        return self.folder / f"part-{index:06d}.parquet"

    def part_info(self, index: int) -> PartInfo | None:
        """What the written part ``index`` says about itself; None when it is not written."""
        path = self.part_path(index)
        if not path.exists():
            return None
        meta = pq.read_schema(path).metadata or {}
        raw = json.loads(meta[_META_KEY].decode("utf-8"))
        return PartInfo(index=int(raw["index"]), rows=int(raw["rows"]), first=str(raw["first"]),
                        last=str(raw["last"]))

    def read_part(self, index: int, columns: list[str] | None = None) -> pa.Table:
        """A written part (some columns only, if given)."""
        return pq.read_table(self.part_path(index), columns=columns)

    def write_part(self, index: int, rows: list[dict[str, Any]], schema: pa.Schema) -> pa.Table:
        """Write partition ``index`` atomically; return its table.

        A row that cannot be stored as it is (text that is not valid Unicode, a value its
        column cannot hold) does not cost the partition or the run: see :func:`storable_table`.
        """
        table = storable_table(rows, schema)
        info = {"index": index, "rows": len(rows),
                "first": rows[0]["card_id"] if rows else "",
                "last": rows[-1]["card_id"] if rows else ""}
        table = table.replace_schema_metadata(
            {**(table.schema.metadata or {}), _META_KEY: json.dumps(info).encode("utf-8")})
        path = self.part_path(index)
        tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
        try:
            with open(tmp, "wb") as fh:
                pq.write_table(table, fh, compression="zstd")
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)
        return table

    def written(self) -> list[int]:
        """Indices of the parts written so far."""
        out = []
        for p in self.folder.glob("part-*.parquet"):
            try:
                out.append(int(p.stem.split("-", 1)[1]))
            except ValueError:
                continue
        return sorted(out)

    # ------------------------------------------------------------------ end
    def finish(self, *, partitions: int, rows: int, summary: str) -> None:
        """Mark the run complete (every partition written) and keep its summary."""
        extra = [k for k in self.written() if k >= partitions]
        if extra:  # parts of a longer stream cannot belong to these inputs
            raise ResultsFolderError(
                f"{self.folder} holds parts beyond the run's {partitions} partitions "
                f"({', '.join(self.part_path(k).name for k in extra[:3])}); not mixed")
        self.write_summary(summary)
        self.manifest.update(complete=True, partitions=partitions, rows=rows, finished=_now())
        self._save()

    def write_summary(self, summary: str) -> None:
        """Keep the run's summary in the folder (``_summary.txt``)."""
        _write_atomic(self.folder / SUMMARY, (summary.rstrip() + "\n").encode("utf-8"))


# What Arrow raises for a value its column cannot hold (UnicodeEncodeError is a ValueError).
_CONVERSION_ERRORS = (pa.ArrowException, ValueError, TypeError, OverflowError)


def _escaped(value: Any) -> Any:
    """Text with what UTF-8 cannot encode (lone surrogates) written as escapes."""
    if isinstance(value, str):
        return value.encode("utf-8", "backslashreplace").decode("utf-8")
    return value


def _conversion_error(row: dict[str, Any], schema: pa.Schema) -> str | None:
    """Why Arrow cannot hold ``row`` under ``schema`` (None if it can)."""
    try:
        pa.Table.from_pylist([row], schema=schema)
    except _CONVERSION_ERRORS as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


def storable_table(rows: list[dict[str, Any]], schema: pa.Schema) -> pa.Table:
    """The Arrow table of a partition's rows, every row kept whatever its values.

    Rows are converted together; when that fails, each is converted on its own, so the
    rows that can be stored are stored as they are. A row that cannot is stored with its
    text escaped (``\\ud800`` for a lone surrogate) and a warning saying so; if it still
    cannot, it becomes a ``failed`` row keeping only its identifying columns (text escaped),
    with the conversion error as its reason. One bad value so never ends the partition,
    nor the run that would write the partitions after it.

    Parameters
    ----------
    rows : list of dict
        The partition's rows (keys: the schema's column names).
    schema : pyarrow.Schema
        The run's schema (:func:`results_schema`).

    Returns
    -------
    pyarrow.Table
        One row per input row, in order.

    Raises
    ------
    ValueError
        For a row key that is not a column of ``schema`` (Arrow would drop it silently).
    """
    for row in rows:
        # Arrow would drop a stray key without a word: a column the table does not own.
        check_row(row, schema.names)
    try:
        return pa.Table.from_pylist(rows, schema=schema)
    except _CONVERSION_ERRORS:
        pass
    fixed = []
    for row in rows:
        error = _conversion_error(row, schema)
        if error is None:
            fixed.append(row)
            continue
        escaped = {k: _escaped(v) for k, v in row.items()}
        note = f"text that is not valid Unicode stored escaped ({_escaped(error)})"
        escaped["warnings"] = " | ".join(w for w in (escaped.get("warnings"), note) if w)
        error = _conversion_error(escaped, schema)
        if error is None:
            fixed.append(escaped)
            continue
        keep = ("well_id", "card_id", "time", "source", "file", "item", "partition", "model",
                "observe")
        bare: dict[str, Any] = dict.fromkeys(schema.names)
        bare.update({k: escaped.get(k) for k in keep})
        bare.update(status="failed", warnings="",
                    reason=f"its result could not be stored ({_escaped(error)})")
        if _conversion_error(bare, schema) is not None:
            bare.update(time=None, item=None, partition=None)
        fixed.append(bare)
    return pa.Table.from_pylist(fixed, schema=schema)


def _read_manifest(folder: Path) -> dict[str, Any]:
    try:
        data = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ResultsFolderError(f"{folder / MANIFEST}: not readable ({exc})") from exc
    if not isinstance(data, dict) or data.get("kind") != _KIND:
        raise ResultsFolderError(f"{folder / MANIFEST} is not a pumpid batch manifest")
    return data


def to_frame(table: pa.Table) -> pd.DataFrame:
    """A results table as pandas, whole numbers kept whole where some are missing."""
    return table.to_pandas(types_mapper={pa.int64(): pd.Int64Dtype()}.get)


def read_results(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read the results of ``pumpid batch`` back as one table, in input order.

    Parameters
    ----------
    path : str or path
        The results folder (or one Parquet file of it).

    Returns
    -------
    pandas.DataFrame
        One row per input card (see :func:`results_schema` for the columns); ``time`` is
        ``datetime64[ns, UTC]``; whole-number columns that can be missing (``n_samples``,
        ``nfev``: not known for a file that could not be read) are pandas' ``Int64``.

    Warns
    -----
    UserWarning
        When the folder's run is not complete (some partitions are missing: resume it with
        ``pumpid batch --resume``).
    """
    p = Path(os.fspath(path))
    frame = to_frame(pq.read_table(p))
    if p.is_dir() and (p / MANIFEST).exists():
        manifest = _read_manifest(p)
        if not manifest.get("complete"):
            warnings.warn(f"{p}: the batch run is not complete ({len(list(p.glob('part-*')))} "
                          "partitions written); continue it with pumpid batch --resume",
                          UserWarning, stacklevel=2)
    if "item" in frame.columns:
        frame = frame.sort_values("item", kind="stable")
    return frame.reset_index(drop=True)
