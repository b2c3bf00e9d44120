"""What every command shares: exit codes, user-facing errors, option parsing, safe text.

Exit codes (documented in the README and ``pumpid --help``):

==== ==========================================================================
0    every card was fitted (status ``converged`` or ``boundary``), outputs written
1    an internal error (a bug in pumpid): one line on stderr, no traceback
2    bad options or input: nothing could be fitted (the message names the file,
     line or field)
3    some cards were fitted and some were not (failed, invalid, unreadable)
4    an output file or folder could not be written (results still printed)
130  interrupted (Ctrl-C); the results finished so far are printed and written
141  standard output was closed early (e.g. piped into ``head``)
==== ==========================================================================
"""

from __future__ import annotations

import collections
import contextlib
import math
import os
import sys
import warnings
from collections.abc import Iterator, Sequence
from typing import Any, TextIO

from ..cards import Card, CardError, printable
from ..engine import compiled
from ..report.words import plural

__all__ = [
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_NOT_FITTED",
    "EXIT_OK",
    "EXIT_OUTPUT",
    "EXIT_PIPE",
    "EXIT_POOR_FIT",
    "EXIT_UNDETERMINED",
    "EXIT_USAGE",
    "CliError",
    "WarningCounter",
    "add_card_options",
    "add_fit_options",
    "batch_exit",
    "check_fit_options",
    "check_paths",
    "columns_option",
    "compile_notice",
    "err",
    "err_block",
    "exit_status",
    "fmt",
    "initial_state_option",
    "model_option",
    "parquet_cards",
    "parse_assignments",
    "plural",
    "rate_option",
]

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USAGE = 2
EXIT_NOT_FITTED = 3
EXIT_OUTPUT = 4
EXIT_POOR_FIT = 5
#: Every card fitted, but on some the data determine none of the model's parameters.
EXIT_UNDETERMINED = 6
EXIT_INTERRUPTED = 130
EXIT_PIPE = 141

# Pumping speeds (strokes per minute) a --spm or --period may state: generous bounds, far
# outside any pumping unit, that keep the rebuilt time axis inside floating point.
SPM_RANGE = (1e-6, 1e6)


class CliError(ValueError):
    """A user-facing error of the options: printed without a traceback, exit status 2."""


def err(message: str, stream: TextIO | None = None) -> None:
    """One line on standard error, prefixed ``pumpid:``, control characters escaped."""
    print(f"pumpid: {printable(message)}", file=stream or sys.stderr, flush=True)


def err_block(message: str, stream: TextIO | None = None) -> None:
    """A message of several lines on standard error: the first prefixed ``pumpid:``, the
    others as they are laid out; each line's control characters escaped."""
    first, *rest = message.split("\n")
    err(first, stream)
    for line in rest:
        print(printable(line), file=stream or sys.stderr, flush=True)


#: Options naming an output path, by their attribute and flag.
_PATH_OPTIONS = (("out", "--out"), ("output", "-o/--output"), ("csv", "--csv"))


def check_paths(args: Any) -> None:
    """Refuse an empty output path (``--out ''``): it names nothing, and a run would write
    nothing and say nothing of it (CliError)."""
    for attr, flag in _PATH_OPTIONS:
        value = getattr(args, attr, None)
        if isinstance(value, str) and not value.strip():
            raise CliError(f"{flag} {value!r}: an empty path; give the name of the "
                           f"{'file' if attr != 'out' else 'folder'} to write")


def compile_notice(stream: TextIO | None = None,
                   names: tuple[str, ...] = compiled.MAIN_JOB) -> bool:
    """Say on standard error, before a fit, that this build's compiled code is not cached yet:
    the first fit compiles it once (a silent wait of a minute looks like a hang). ``names``
    are the compiled functions the command calls (:data:`pumpid.engine.compiled.MAIN_JOB`,
    :data:`~pumpid.engine.compiled.PUMP_JOB` or both). True if said."""
    missing = compiled.uncached(names)
    if not missing:
        return False
    if any(name in compiled.MAIN_JOB for name in missing):
        low, high = compiled.COLD_SECONDS
        wait = f"about {low}-{high} s"
    else:
        low, high = compiled.PUMP_COLD_SECONDS
        wait = f"about {low}-{high} s"
    err(f"compiling the numerical core for this machine, once per installed version: {wait} "
        "on 2 cores (longer on a busy machine); later runs load it in a fraction of a second",
        stream)
    return True


def fmt(value: Any, digits: int = 4) -> str:
    """A number for the terminal: ``n/a`` for None, NaN and infinities."""
    if value is None or isinstance(value, bool):
        return "n/a" if value is None else str(value)
    try:
        x = float(value)
    except (TypeError, ValueError):
        return printable(value)
    if not math.isfinite(x):
        return "n/a"
    return f"{x:.{digits}g}"


def parse_assignments(items: Sequence[str] | None, what: str) -> dict[str, float]:
    """``NAME=VALUE[,NAME=VALUE...]`` options (repeatable) as a dictionary of finite numbers."""
    out: dict[str, float] = {}
    for item in items or []:
        for part in item.split(","):
            if not part.strip():
                continue
            if "=" not in part:
                raise CliError(f"{what}: expected name=value, got {printable(part)!r}")
            name, value = part.split("=", 1)
            try:
                number = float(value)
            except ValueError:
                raise CliError(f"{what}: {printable(name.strip())} = {printable(value)!r} is "
                               "not a number") from None
            if not math.isfinite(number):
                raise CliError(f"{what}: {printable(name.strip())} = {printable(value)} is not "
                               "a finite number")
            out[name.strip()] = number
    return out


def initial_state_option(text: str | None) -> Any:
    """``--initial-state``: a named state, or the state vector as comma-separated numbers."""
    if text is None:
        return None
    if text in ("rest", "equilibrium", "periodic"):
        return text
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise CliError(
            f"--initial-state: {printable(text)!r} is neither rest, equilibrium, periodic nor "
            "a list of numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise CliError(f"--initial-state: {printable(text)} has a value that is not finite")
    return values


def add_fit_options(p: Any, models: Sequence[str]) -> None:
    """The fitting options, one set for ``pumpid fit`` and ``pumpid batch``.

    Every default is None ("not given"): ``pumpid fit`` fills in the defaults the help
    states, ``pumpid batch --resume`` keeps the run's own.

    Parameters
    ----------
    p : argparse.ArgumentParser or argument group
    models : sequence of str
        The model names (``auto`` is added).
    """
    p.add_argument("--model", choices=[*models, "auto"],
                   help="model to fit (default kelvin); auto: fit mass-spring-dashpot, "
                        "Kelvin observing u and u2 and Maxwell, choose by BIC on the "
                        "residuals' effective sample size")
    p.add_argument("--method", choices=["lm", "newton-fd"],
                   help="lm (default: exact sensitivities) or newton-fd (the paper's method)")
    p.add_argument("--integrator", choices=["exact", "euler"], help="default exact")
    p.add_argument("--residual", choices=["linear", "log"], help="default linear")
    p.add_argument("--observe", help="observed state (Kelvin: u2, the paper's, or u, the mass "
                                     "where the polished-rod load acts; default the model's)")
    p.add_argument("--scale", help="output scale C: a number (default 1) or 'free'")
    p.add_argument("--initial-state",
                   help="rest, equilibrium, periodic, or the state as numbers (default: "
                        "periodic for a single-stroke card, else rest)")
    p.add_argument("--offset", choices=["auto", "yes", "no"],
                   help="fit a position offset (default auto: yes for single-stroke cards)")
    p.add_argument("--x0", action="append", metavar="NAME=VALUE[,...]",
                   help="starting guess shared by every card (default: automatic start)")
    p.add_argument("--max-nfev", type=int, metavar="N",
                   help="model evaluations allowed each solve of a card (lm; at least 2: "
                        "a fit runs several, its start's, the main one, moves to a limit, "
                        "and nfev counts them all)")
    p.add_argument("--min-r2", type=float, metavar="R2",
                   help="quality gate: a fit with R^2 below this has status poor-fit and "
                        "the run exits with 5 (default 0.95)")


def add_card_options(p: Any) -> None:
    """The card-reading options, one set for every command that reads cards from files.

    Parameters
    ----------
    p : argparse.ArgumentParser or argument group
    """
    p.add_argument("--spm", type=float, help="strokes per minute (cards without time)")
    p.add_argument("--period", type=float, help="stroke period in s (cards without time)")
    p.add_argument("--format", help="force a format: csv, scada, json, whitespace, ts")
    p.add_argument("--encoding", help="text encoding of the files (default: detected)")
    p.add_argument("--card", action="append", metavar="ID",
                   help="only this card id (give it again for more cards; with "
                        "--split-strokes a stroke's id RECORD#k too)")
    p.add_argument("--well-id", metavar="ID",
                   help="the well of every card of the files (over the files' own; for "
                        "files of one well without a well column)")
    p.add_argument("--split-strokes", action="store_true",
                   help="split multi-stroke time records at position minima; each stroke "
                        "is a card, one period (ids CARD#0, CARD#1, ...)")
    p.add_argument("--columns", metavar="ROLE=COL[,...]",
                   help="column roles, e.g. position=1,load=0 (names or 0-based indices; "
                        "roles t, position, load, card, well, spm, period; t=- reads no "
                        "time column)")
    p.add_argument("--t-col", help="time column (name, or index for tables without header): "
                        "seconds, or ISO 8601 date/time stamps such as 2024-05-01 10:00:00.25")
    p.add_argument("--load-col", help="load column")
    p.add_argument("--position-col", "--displacement-col", dest="position_col",
                   help="position/displacement column")
    p.add_argument("--load-unit", help="load unit of the files: lbf, klbf, N, kN, kgf")
    p.add_argument("--position-unit", help="position unit of the files: in, ft, m")


def model_option(cls: Any, values: dict[str, float], flag: str, lead: str, *,
                 extras: Sequence[str] = ()) -> Any:
    """The model that ``NAME=VALUE`` assignments give (every parameter, nothing unknown but
    ``extras``), or a CliError naming the option, what is missing and what is unknown.

    Parameters
    ----------
    cls : type of Model
    values : dict of str to float
        From :func:`parse_assignments`.
    flag : str
        The option, for the message (``--x0``).
    lead : str
        What the option must give, said first when something is missing or unknown.
    extras : sequence of str
        Names the option may give besides the model's parameters.

    Returns
    -------
    Model
    """
    names = cls.param_names()
    missing = [n for n in names if n not in values]
    unknown = [n for n in values if n not in names and n not in extras]
    if missing or unknown:
        raise CliError(f"{flag}: {lead}"
                       + (f" (missing {', '.join(missing)})" if missing else "")
                       + (f" (unknown {', '.join(printable(u) for u in unknown)})"
                          if unknown else ""))
    try:
        return cls(**{n: values[n] for n in names})
    except (TypeError, ValueError) as exc:
        raise CliError(f"{flag}: {exc}") from None


def check_fit_options(cls: Any, *, observe: str | None = None, scale: str | None = None,
                      min_r2: float | None = None, max_nfev: int | None = None,
                      x0: Sequence[str] | None = None, x0_extras: Sequence[str] = (),
                      initial_state: str | None = None) -> dict[str, Any]:
    """The fitting options of ``pumpid fit`` and ``pumpid batch``, checked the same way.

    Every option that no card could be fitted with is refused here, before any card is
    read, so that a run does not end with every card ``failed`` for a reason of the options.

    Parameters
    ----------
    cls : type of Model
        The model to fit (its outputs and parameter names).
    observe, scale, min_r2, max_nfev, x0, initial_state
        The options as given (None: not given). ``x0`` is the repeatable ``NAME=VALUE,...``.
    x0_extras : sequence of str
        Names ``--x0`` may give besides the model's parameters.

    Returns
    -------
    dict
        The options given, as values: ``observe`` (str), ``scale`` (float or ``"free"``),
        ``min_r2`` (float), ``max_nfev`` (int), ``x0`` (dict of float: every parameter,
        and extras), ``initial_state`` (a name or a list of float).

    Raises
    ------
    CliError
        Naming the option and what it takes.
    """
    out: dict[str, Any] = {}
    if observe is not None:
        if observe not in cls.outputs:
            raise CliError(f"--observe {printable(observe)!r}: {cls.__name__} can observe "
                           f"{', '.join(cls.outputs)}")
        out["observe"] = observe
    if scale is not None:
        if scale == "free":
            out["scale"] = "free"
        else:
            try:
                number = float(scale)
            except ValueError:
                raise CliError(f"--scale: {printable(scale)!r} is neither a number nor "
                               "'free'") from None
            if not (0 < number < math.inf):
                raise CliError(f"--scale {printable(scale)}: the output scale must be a "
                               "positive number")
            out["scale"] = number
    if min_r2 is not None:
        if not (min_r2 <= 1):  # NaN too
            raise CliError(f"--min-r2 {min_r2}: R^2 is a number at most 1")
        out["min_r2"] = min_r2
    if max_nfev is not None:
        if max_nfev < 2:
            raise CliError(f"--max-nfev {max_nfev}: give a whole number of model "
                           "evaluations of at least 2 (a solve's start and one step)")
        out["max_nfev"] = max_nfev
    if x0:
        values = parse_assignments(x0, "--x0")
        model_option(cls, values, "--x0", f"give all of {', '.join(cls.param_names())}",
                     extras=x0_extras)
        out["x0"] = values
    if initial_state is not None:
        out["initial_state"] = initial_state_option(initial_state)
    return out


def columns_option(spec: str | None, **single: str | None) -> dict[str, Any] | None:
    """Column roles from ``--columns ROLE=COL,...`` and the single ``--t-col``-style options.

    A column is a header name or a 0-based index (digits); ``-`` gives the role no column
    (``t=-``: a column of date/time stamps is not read as time, the stroke rate is given).
    """
    cols: dict[str, Any] = {}
    for part in (spec or "").split(","):
        if not part.strip():
            continue
        role, sep, col = part.partition("=")
        if not sep or not role.strip() or not col.strip():
            raise CliError(f"--columns: expected role=column (e.g. position=1,load=0), got "
                           f"{printable(part)!r}")
        cols[role.strip()] = col.strip()
    for role, col in single.items():
        if col is not None:
            cols[role] = col
    needed = [k for k, v in cols.items() if v == "-" and k in ("position", "load")]
    if needed:
        raise CliError(f"--columns: {needed[0]} needs a column ('-' reads none: for t, card, "
                       "well, spm or period)")
    out = {k: None if v == "-" else int(v) if v.isdigit() else v for k, v in cols.items()}
    return out or None


def rate_option(spm: float | None, period: float | None) -> None:
    """Refuse a stated pumping speed or period that no record can have (CliError)."""
    lo, hi = SPM_RANGE
    if spm is not None and not (math.isfinite(spm) and lo <= spm <= hi):
        raise CliError(f"--spm {spm:g} strokes/min is not a pumping speed (give a number "
                       f"between {lo:g} and {hi:g})")
    if period is not None and not (math.isfinite(period) and 60.0 / hi <= period <= 60.0 / lo):
        raise CliError(f"--period {period:g} s is not a stroke period (give a number between "
                       f"{60.0 / hi:g} and {60.0 / lo:g} s)")


def exit_status(counts: collections.Counter[str] | dict[str, int]) -> int:
    """The exit status of a run that fitted cards, from its cards per status.

    0 every card fitted (converged or boundary); 5 every card fitted, some poorly; 6 every
    card fitted, some leaving every parameter undetermined (and none poorly); 2 no card
    could even be tried (every one invalid, or none at all): the input is the problem; 3
    otherwise (some failed or invalid).
    """
    total = sum(counts.values())
    fitted = counts.get("converged", 0) + counts.get("boundary", 0)
    poor, undetermined = counts.get("poor-fit", 0), counts.get("undetermined", 0)
    if total and fitted == total:
        return EXIT_OK
    if total and fitted + poor + undetermined == total:
        return EXIT_POOR_FIT if poor else EXIT_UNDETERMINED
    # Nothing even tried: a poor or undetermined fit beside invalid cards was fitted (it
    # read "2, nothing fitted").
    if fitted + poor + undetermined == 0 and counts.get("failed", 0) == 0:
        return EXIT_USAGE
    return EXIT_NOT_FITTED


def batch_exit(lumped: collections.Counter[str] | dict[str, int],
               pumps: collections.Counter[str] | dict[str, int] | None = None) -> int:
    """The exit status of a batch run: its lumped fits' (:func:`exit_status`), or worse
    where the pumps asked for (``--well-file``) were not all identified, each status ranked
    as a card's: some not identified (failed or invalid) is 3 even when every lumped fit
    is fine (it was 0, "complete", with no pump computed)."""
    code = exit_status(lumped)
    if not pumps or code == EXIT_USAGE:
        return code
    pump = exit_status(pumps)
    pump = EXIT_NOT_FITTED if pump == EXIT_USAGE else pump
    rank = {EXIT_OK: 0, EXIT_UNDETERMINED: 1, EXIT_POOR_FIT: 2, EXIT_NOT_FITTED: 3}
    return max(code, pump, key=lambda c: rank.get(c, 3))


class WarningCounter:
    """Python warnings raised while a command runs, counted instead of printed.

    numpy's floating-point ``RuntimeWarning`` s (and matplotlib's) mean nothing to a user
    and are not errors: each card's status and warnings say whether its fit is usable. They
    are kept off the terminal and counted; ``--verbose`` prints the count.
    """

    _LIMIT = 50

    def __init__(self) -> None:
        self.counts: collections.Counter[str] = collections.Counter()

    @contextlib.contextmanager
    def active(self) -> Iterator[WarningCounter]:
        """Count every warning raised inside the block."""
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            warnings.showwarning = self._show  # type: ignore[assignment]
            yield self

    def _show(self, message: Warning | str, category: type[Warning], *args: Any,
              **kwargs: Any) -> None:
        key = f"{category.__name__}: {str(message).splitlines()[0][:120] if message else ''}"
        if key in self.counts or len(self.counts) < self._LIMIT:
            self.counts[key] += 1

    def summary(self) -> str | None:
        """One line saying what was counted, or None when nothing was."""
        if not self.counts:
            return None
        total = sum(self.counts.values())
        top = ", ".join(f"{k} ({n}x)" for k, n in self.counts.most_common(3))
        were = "was" if total == 1 else "were"
        return (f"note: {plural(total, 'numerical warning')} {were} raised and not shown "
                f"({top}); each "
                "card's status and warnings say whether its fit is usable")


def parquet_cards(path: str, *, position_unit: str | None, load_unit: str | None,
                  spm: float | None, period: float | None, well_id: str | None
                  ) -> tuple[list[Card], list[CardError]] | None:
    """The cards of a Parquet card file, as ``pumpid batch`` reads them, each bad card an
    error in its place; None for a file that is not Parquet.

    ``pumpid fit`` and ``pumpid downhole`` read them too, so that a card a batch run found
    odd can be looked at on its own (the text readers had called the file's bytes an
    encoding problem).

    Parameters
    ----------
    path : str
    position_unit, load_unit : str or None
        Units of every card (over the file's unit columns).
    spm, period : float or None
        The stroke rate or period of every card without time (over the file's spm column).
    well_id : str or None
        The well of every card (over the file's).

    Returns
    -------
    (cards, errors) or None
    """
    from ..fleet.dataset import iter_parquet_cards
    from ..fleet.inputs import is_parquet

    # Sniffed only in a regular file: opening a named pipe to read its first bytes waits
    # for a writer (the text readers refuse such a file by what it is).
    if not (os.path.isfile(path) and is_parquet(path)):
        return None
    cards: list[Card] = []
    errors: list[CardError] = []
    for got in iter_parquet_cards(path, position_unit=position_unit, load_unit=load_unit,
                                  spm=spm, period=period):
        if isinstance(got, CardError):
            errors.append(got)
        else:
            cards.append(got if well_id is None else got.replace(well_id=well_id))
    return cards, errors
