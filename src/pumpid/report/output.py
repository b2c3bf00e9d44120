"""Safe output: file names from card ids, atomic writes, output folders replaced whole.

Everything pumpid writes to disk goes through this module, so that three promises hold for
every command:

* **Nothing is written outside the output folder.** A name made from a card id
  (:func:`safe_name`) is one path component of portable characters, never ``.``, ``..``, a
  hidden name or a device name; :class:`UniqueNames` makes the names of one run distinct
  (also on file systems that ignore case), so two cards never share a folder.
* **No partial file under a final name.** A file is written to a temporary file in its own
  folder and renamed over the final name (:func:`atomic_write`); a card's folder is filled
  in a hidden staging folder inside the output folder and renamed into place whole
  (:meth:`OutputFolder.commit_folder`). A process killed mid-run leaves complete files and
  folders, and at most hidden ``.pumpid-*`` leftovers that the next run into the same
  folder removes (and says so).
* **A rerun says what it replaces.** Replacing a card folder, or files of an earlier run
  written directly into the output folder, is reported; files an earlier run wrote there
  (listed in the folder's hidden manifest) that this run does not write are removed, so an
  old ``prediction.png`` never sits beside a new card's report.

Problems with the output location raise :class:`OutputError`, whose message names the path
and the reason; the command line turns it into exit status 4.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shutil
import tempfile
import unicodedata
from collections.abc import Iterable, Iterator
from pathlib import Path

from ..cards import printable

__all__ = [
    "MANIFEST",
    "OutputError",
    "OutputFolder",
    "UniqueNames",
    "atomic_write",
    "safe_name",
]

#: Hidden file in an output folder listing the files the last run wrote directly into it.
MANIFEST = ".pumpid-manifest.json"
# Prefix of every temporary name (staging folders, temporary files, folders moved aside).
_TMP = ".pumpid-"
_MAX_NAME = 80
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
# Names Windows reserves for devices, with or without an extension.
_DEVICES = {"con", "prn", "aux", "nul", *(f"com{i}" for i in range(10)),
            *(f"lpt{i}" for i in range(10))}


class OutputError(Exception):
    """An output file or folder cannot be written; the message names the path and why."""


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# Read once: mkstemp and mkdtemp create private files and folders (0600, 0700); what is
# put in place gets the modes the user's umask gives ordinary files and folders.
_MASK = _umask()
FILE_MODE = 0o666 & ~_MASK
DIR_MODE = 0o777 & ~_MASK


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def _where(path: os.PathLike[str] | str) -> str:
    return printable(os.fspath(path))


# --------------------------------------------------------------------------- names
def safe_name(text: object, *, max_length: int = _MAX_NAME) -> str:
    """A portable, harmless file name made from any text (a card id, a well id).

    Letters and digits (accents removed), ``-``, ``_`` and ``.`` are kept; every other run
    of characters (path separators, control characters, ``?``, spaces, ...) becomes one
    ``_``. Leading and trailing dots, spaces and underscores are removed, so the name is
    never ``.``, ``..`` or hidden; a name without a letter or digit is ``"card"``, a
    Windows device name (``CON``, ``NUL``, ``COM1``, ...) gets a leading ``_``, and the
    length is capped. Different texts can give the same name: :class:`UniqueNames` keeps a
    run's names apart.

    Parameters
    ----------
    text : object
        Converted with ``str``.
    max_length : int
        Longest name returned (at least 8).

    Returns
    -------
    str
    """
    s = unicodedata.normalize("NFKD", str(text))
    s = "".join(ch for ch in s if not unicodedata.combining(ch))
    s = _UNSAFE.sub("_", s).strip(". _")
    if not any(ch.isalnum() for ch in s):
        return "card"
    if s.split(".")[0].lower() in _DEVICES:
        s = "_" + s
    return s[: max(int(max_length), 8)].rstrip(". ") or "card"


class UniqueNames:
    """Distinct file names for the ids of one run, also where case is ignored.

    The first id to claim a name gets it as :func:`safe_name` makes it; a later id whose
    name is taken (``a/b`` after ``a?b``, ``Well`` after ``well``) gets a suffix from a hash
    of the id, and a repeated id a counter. ``reserved`` names (files the run writes itself)
    are never given to an id.
    """

    def __init__(self, reserved: Iterable[str] = ()) -> None:
        self._taken: set[str] = {r.casefold() for r in reserved}

    def claim(self, text: object) -> str:
        """The name for ``text`` (a new, distinct name on every call)."""
        base = safe_name(text)
        name = base
        if name.casefold() in self._taken:
            digest = hashlib.sha256(str(text).encode("utf-8", "surrogatepass")).hexdigest()
            name = safe_name(f"{base[: _MAX_NAME - 9]}-{digest[:8]}")
            count = 2
            while name.casefold() in self._taken:
                name = safe_name(f"{base[: _MAX_NAME - 9 - 6]}-{digest[:8]}-{count}")
                count += 1
        self._taken.add(name.casefold())
        return name


# --------------------------------------------------------------------------- files
def atomic_write(path: str | os.PathLike[str], data: bytes | str) -> Path:
    """Write a file so that it is either complete or absent under its name.

    The data go to a temporary file in the same folder, which is flushed to disk and then
    renamed over ``path`` (an atomic replacement on POSIX and Windows). An existing file of
    that name is replaced; a symbolic link of that name is replaced by the file (its target
    is not written). Text is written as UTF-8.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its folder must exist.
    data : bytes or str

    Returns
    -------
    Path

    Raises
    ------
    OutputError
        When the folder is missing or not writable, ``path`` is a folder, or the disk is
        full; nothing is left behind.
    """
    target = Path(path)
    raw = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    if target.is_dir() and not target.is_symlink():
        raise OutputError(f"{_where(target)}: is a folder; give a file name")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f"{_TMP}{target.name[:40]}.", suffix=".tmp",
                                   dir=target.parent)
    except OSError as exc:
        raise OutputError(f"{_where(target)}: cannot write here ({_reason(exc)})") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, FILE_MODE)
        os.replace(tmp, target)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise OutputError(f"{_where(target)}: cannot write ({_reason(exc)})") from None
        raise
    return target


def _remove(path: Path) -> None:
    """Remove a file, a symbolic link or a folder tree (links are never followed)."""
    if path.is_symlink() or not path.is_dir():
        path.unlink(missing_ok=True)
    else:
        shutil.rmtree(path)


# --------------------------------------------------------------------------- folders
class OutputFolder:
    """An output folder (``--out``): staged, atomic writes of files and card folders.

    Parameters
    ----------
    path : str or os.PathLike
        The folder; created (with its parents) by :meth:`prepare`.

    Notes
    -----
    Usage: :meth:`prepare` once (it proves the folder writable before any work is done);
    then, for each unit of output, write its files into :meth:`staging` and commit them
    with :meth:`commit_folder` (a card's own folder) or :meth:`commit_files` (files
    directly in the output folder). Each method returns what it replaced or removed, in
    words, for the caller to show.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        # Staging folders of this run not yet committed or removed. A Ctrl-C can land
        # between a folder's creation and the code that would remove it (inside mkdtemp,
        # say); :meth:`discard_staged` removes what such an interruption left.
        self._staged: set[Path] = set()

    # ------------------------------------------------------------------ setup
    def prepare(self) -> list[str]:
        """Create the folder if needed, check that it can be written, clear leftovers.

        Returns
        -------
        list of str
            What was cleaned up (hidden leftovers of an interrupted earlier run).

        Raises
        ------
        OutputError
            When the path names an existing file, a parent is not a folder, or the folder
            cannot be created or written.
        """
        where = _where(self.path)
        if self.path.exists() and not self.path.is_dir():
            raise OutputError(f"{where}: exists and is not a folder; give a folder name for "
                              "the outputs")
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"{where}: cannot create the output folder "
                              f"({_reason(exc)})") from None
        try:
            probe = tempfile.mkdtemp(prefix=f"{_TMP}probe-", dir=self.path)
            os.rmdir(probe)
        except OSError as exc:
            raise OutputError(f"{where}: cannot write into the output folder "
                              f"({_reason(exc)})") from None
        leftovers = [p for p in self.path.iterdir() if p.name.startswith(_TMP)
                     and p.name != MANIFEST]
        for p in leftovers:
            with contextlib.suppress(OSError):
                _remove(p)
        if leftovers:
            return [f"removed {len(leftovers)} unfinished output(s) of an interrupted earlier "
                    f"run from {where}"]
        return []

    # ------------------------------------------------------------------ staging
    @contextlib.contextmanager
    def staging(self) -> Iterator[Path]:
        """A new hidden folder inside the output folder to write one unit of output into.

        It is removed on leaving the block unless it was committed (renamed away).
        """
        stage = self.path / f"{_TMP}partial-{os.urandom(6).hex()}"
        self._staged.add(stage)
        try:
            os.mkdir(stage, DIR_MODE)
        except OSError as exc:
            self._staged.discard(stage)
            raise OutputError(f"{_where(self.path)}: cannot write into the output folder "
                              f"({_reason(exc)})") from None
        try:
            yield stage
        finally:
            if stage.exists():
                with contextlib.suppress(OSError):
                    _remove(stage)
            if not stage.exists():
                self._staged.discard(stage)

    def discard_staged(self) -> None:
        """Remove this run's staging folders that an interruption left behind."""
        for stage in list(self._staged):
            with contextlib.suppress(OSError):
                if stage.exists():
                    _remove(stage)
            if not stage.exists():
                self._staged.discard(stage)

    def commit_folder(self, stage: Path, name: str) -> list[str]:
        """Put a staged folder in place as ``<output folder>/<name>``, replacing any old one.

        ``name`` must come from :func:`safe_name` / :class:`UniqueNames` (one component).

        Returns
        -------
        list of str
            ``["replaced NAME/ from an earlier run"]`` when there was one, else empty.

        Raises
        ------
        OutputError
            When the rename fails.
        """
        if name != safe_name(name) or os.sep in name or (os.altsep and os.altsep in name):
            raise ValueError(f"not a safe folder name: {name!r}")
        target = self.path / name
        said: list[str] = []
        try:
            if os.path.lexists(target):
                aside = Path(tempfile.mkdtemp(prefix=f"{_TMP}old-", dir=self.path))
                os.rename(target, aside / name)
                os.rename(stage, target)
                _remove(aside)
                said.append(f"replaced {printable(name)}/ from an earlier run")
            else:
                os.rename(stage, target)
        except OSError as exc:
            raise OutputError(f"{_where(target)}: cannot write ({_reason(exc)})") from None
        return said

    def commit_files(self, stage: Path) -> list[str]:
        """Move a staged folder's files into the output folder itself, one atomic rename each.

        Files that an earlier run wrote there (the folder's manifest) and this one did not
        are removed; files pumpid did not write are never touched.

        Returns
        -------
        list of str
            What was replaced and what was removed, in words.

        Raises
        ------
        OutputError
            When a file cannot be moved into place.
        """
        names = sorted(p.name for p in stage.iterdir())
        old = self._manifest()
        replaced = [n for n in names if (self.path / n).exists()]
        for n in names:
            if (self.path / n).is_dir() and not (self.path / n).is_symlink():
                raise OutputError(f"{_where(self.path / n)}: is a folder; pumpid writes a file "
                                  "of that name here")
            try:
                os.replace(stage / n, self.path / n)
            except OSError as exc:
                raise OutputError(f"{_where(self.path / n)}: cannot write "
                                  f"({_reason(exc)})") from None
        stale = [n for n in old if n not in names and safe_name(n) == n
                 and (self.path / n).is_file()]
        for n in stale:
            with contextlib.suppress(OSError):
                (self.path / n).unlink()
        atomic_write(self.path / MANIFEST,
                     json.dumps({"written_by": "pumpid", "files": names}, indent=1) + "\n")
        said = []
        if replaced:
            said.append(f"replaced {', '.join(replaced)} from an earlier run in "
                        f"{_where(self.path)}")
        if stale:
            said.append(f"removed {', '.join(stale)} (written there by an earlier run, not by "
                        "this one)")
        return said

    def _manifest(self) -> list[str]:
        try:
            doc = json.loads((self.path / MANIFEST).read_text(encoding="utf-8"))
            files = doc.get("files", []) if isinstance(doc, dict) else []
            return [f for f in files if isinstance(f, str)]
        except (OSError, ValueError):
            return []
