"""What ``pumpid downhole`` shows of one card: its diagnostic pump card and its pump identified
from the surface card, together.

:class:`DownholeCard` joins a :class:`~pumpid.rods.DownholeResult` (the diagnostic pump card)
and a :class:`~pumpid.pump.PumpFit` (the rod string and valve pump fitted to the surface
card) into the command's JSON element, its text lines, its table row and its figure. The
pump quantities shown are the identified ones, each with its standard error, when the
identification is usable (status ``converged`` or ``boundary``); otherwise they are the
diagnostic card's, without errors, and the card says why. The diagnostic pump card shown is
the one at the damping the identification chose (or the default rule's, said so).
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray

from ..cards import printable
from ..rods import DAMPING_UNIT, DownholeResult
from ..rods.figure import draw_cards
from ..rods.report import quantity_mark
from .identify import SHOWN, PumpFit

__all__ = ["USABLE", "DownholeCard", "draw_identified", "format_error"]

Array = NDArray[np.float64]

#: Statuses of an identification whose values are shown (as for every other fit).
USABLE = ("converged", "boundary")
#: Quantities measured on the diagnostic card only (the identification has no load lines).
_DIAGNOSTIC_ONLY = ("upper_load_line", "lower_load_line")


def _num(value: Any) -> float | None:
    if value is None or isinstance(value, bool):
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def format_error(value: float | None, stderr: float | None, unit: str) -> str:
    """``value +- error unit`` for the terminal and the report (``n/a`` when missing; no
    unit for a fraction, which is said by the name)."""
    if value is None:
        return "n/a"
    text = f"{value:.4g}"
    if stderr is not None:
        text += f" +- {stderr:.2g}"
    return text + ("" if unit in ("fraction", "") else f" {unit}")


@dataclass(frozen=True, eq=False)
class DownholeCard:
    """One card's diagnostic pump card and identified pump, as ``pumpid downhole`` shows them.

    Build it with :meth:`of`.

    Attributes
    ----------
    downhole : DownholeResult
        The diagnostic pump card shown: at the identified damping when the identification is
        usable, else at the default rule's (or the given) damping, its rule saying which.
    fit : PumpFit or None
        The identification (None when it was not run).
    skipped : str
        Why the identification was not run ("" when it was).
    """

    downhole: DownholeResult
    fit: PumpFit | None = None
    skipped: str = ""

    @classmethod
    def of(cls, diagnostic: DownholeResult, fit: PumpFit | None,
           skipped: str = "") -> DownholeCard:
        """Join a card's diagnostic result and its identification.

        Parameters
        ----------
        diagnostic : DownholeResult
            The card's diagnostic result at the default (or given) damping: shown when the
            identification brought no diagnostic card of its own.
        fit : PumpFit or None
            The identification, or None when not run.
        skipped : str
            Why the identification was not run (said in the card's notes).
        """
        if fit is not None and fit.downhole is not None and fit.downhole.ok:
            return cls(downhole=fit.downhole, fit=fit)
        down = diagnostic
        if fit is not None and diagnostic.ok:
            rule = (f"default rule: nu = {diagnostic.damping:g} (the pump was not identified: "
                    f"{fit.status})" if diagnostic.damping_rule != "given"
                    else diagnostic.damping_rule)
            down = dataclasses.replace(diagnostic, damping_rule=rule)
        if skipped and diagnostic.ok:
            down = dataclasses.replace(down, notes=(*down.notes, skipped))
        return cls(downhole=down, fit=fit, skipped=skipped)

    # ------------------------------------------------------------------ what it says
    @property
    def fitted(self) -> bool:
        """The system model was fitted (whatever its status)."""
        return self.fit is not None and self.fit.ok

    @property
    def identified(self) -> bool:
        """The identification is usable: its values are the ones shown."""
        return self.fitted and self.fit is not None and self.fit.status in USABLE

    @property
    def outcome(self) -> str:
        """The card's status for the exit status: the diagnostic's when it was not computed,
        else the identification's (``converged`` when it was not run)."""
        if not self.downhole.ok:
            return self.downhole.status
        if self.fit is None:
            return "converged"
        return self.fit.status

    def pump(self) -> dict[str, dict[str, Any]]:
        """Each pump quantity as ``{"value", "stderr", "unit"}``: identified with its error
        and ``determined`` (:meth:`PumpFit.quantities`) when usable, else the diagnostic
        card's with ``stderr`` None. The load lines are always the diagnostic card's (the
        identification fits the fluid load itself)."""
        diag = self.downhole.quantities()
        out = {name: {"value": _num(q["value"]), "stderr": None, "unit": q["unit"]}
               for name, q in diag.items()}
        if self.identified and self.fit is not None:
            for name, q in self.fit.quantities().items():
                out[name] = dict(q)
        return out

    def damping(self) -> dict[str, Any]:
        """The damping of the diagnostic card shown, ``{"value", "stderr", "unit", "rule"}``:
        the error only when the identification chose it."""
        se = None
        if self.identified and self.fit is not None:
            se = self.fit.damping()["stderr"]
        return {"value": _num(self.downhole.damping), "stderr": se, "unit": DAMPING_UNIT,
                "rule": self.downhole.damping_rule}

    def r2(self) -> float | None:
        """R^2 of the surface-load fit (None when not fitted)."""
        return _num(self.fit.fit.r2) if self.fitted and self.fit and self.fit.fit else None

    def residual_autocorrelation(self) -> float | None:
        """Lag-1 autocorrelation of the surface-load fit's residuals (None when not fitted)."""
        if not self.fitted or self.fit is None or self.fit.fit is None:
            return None
        u = self.fit.fit.uncertainty
        if u is None or u.whiteness is None:
            return None
        return _num(u.whiteness.get("lag1_autocorrelation"))

    def file_order(self, values: Array) -> list[float]:
        """Values in the model's time order, put in the order of the card file's samples."""
        values = np.asarray(values, dtype=float)
        if self.fit is not None and self.fit.model is not None and self.fit.model.surface.reversed:
            values = values[::-1]
        return [float(v) for v in values]

    def identification(self) -> dict[str, Any] | None:
        """The identification's own report (None when not run): status, reason, the
        identified quantities and parameters with errors, the agreement with the diagnostic
        card, the energy balance, identifiability in words, warnings, notes, and the fitted
        surface load and pump card at the card's samples."""
        if self.fit is None:
            return None
        d = self.fit.to_dict()
        out: dict[str, Any] = {"status": self.fit.status, "reason": self.fit.reason,
                               "used": self.identified}
        if not self.fitted:
            return out
        assert self.fit.fit is not None
        out.update({k: d.get(k) for k in ("pump", "parameters", "rmse", "full_pump",
                                          "evaluations", "agreement", "consistency",
                                          "energy", "identifiability", "warnings",
                                          "notes")})
        # The parameter table states the model's unit ("1"); the damping is said one way.
        out["fitted_damping"] = {**d["parameters"]["damping"], "unit": DAMPING_UNIT}
        pump = self.fit.pump_card()
        card = self.downhole.card
        out["surface_fit"] = {"load": self.file_order(np.asarray(self.fit.fit.fitted)),
                              "unit": card.load_unit}
        if pump is not None:
            out["pump_card"] = {"position": self.file_order(pump[0]),
                                "load": self.file_order(pump[1]),
                                "units": {"position": card.position_unit,
                                          "load": card.load_unit},
                                "convention": "effective"}
        return out

    def to_dict(self) -> dict[str, Any]:
        """The JSON element of ``pumpid downhole --json``: the diagnostic's keys (``status``,
        ``reason``, ``card``, ``downhole``, ``notes``; the diagnostic card's own quantities
        in ``downhole.pump``), ``pump`` with errors, ``damping``, ``r2``,
        ``residual_autocorrelation`` and ``identification``."""
        out = self.downhole.to_dict()
        if out.get("downhole") is not None:
            out["downhole"]["pump"] = out["pump"]
            out["pump"] = self.pump()
            out["damping"] = self.damping()
        else:
            out["damping"] = None
        out["r2"] = self.r2()
        out["residual_autocorrelation"] = self.residual_autocorrelation()
        out["identification"] = self.identification()
        return out

    def to_row(self) -> dict[str, Any]:
        """A flat dict for the run's table: the diagnostic's columns, then the identification's
        status, R^2, residual autocorrelation, damping and each quantity's error."""
        row = self.downhole.to_row()
        row["identification_status"] = self.fit.status if self.fit is not None else None
        row["r2"] = self.r2()
        row["residual_autocorrelation"] = self.residual_autocorrelation()
        damping = self.damping()
        row["downhole_damping_stderr"] = damping["stderr"]
        row["downhole_damping_rule"] = damping["rule"]
        if self.downhole.ok:
            for name, q in self.pump().items():
                row[f"pump_{name}"] = q["value"]
                row[f"pump_{name}_stderr"] = q["stderr"]
        return row

    def text(self) -> list[str]:
        """The card's lines for the terminal: status, each quantity as value +- error unit,
        the damping and its rule, R^2."""
        card, down = self.downhole.card, self.downhole
        head = f"{printable(card.card_id)} [{printable(card.source)}]: {down.status}"
        if not down.ok:
            return [f"{head}: {printable(down.reason)}"]
        well = down.well.well_id if down.well is not None else "?"
        # The stroke's time, which every displacement and rate rests on: a time column in
        # milliseconds read as seconds gave a displacement a thousand times too small,
        # with the period only in the JSON.
        stroke = ""
        if card.period is not None:
            timed = {"file": "the file's time", "spm": "the stroke rate",
                     "period": "the stroke period given", "dt": "the sample interval given"
                     }.get(card.time_source, "the card")
            stroke = (f", stroke {card.period:.4g} s = {60.0 / card.period:.4g} "
                      f"strokes/min from {timed}")
        head += f" (well {printable(well)}{', reversed' if down.reversed else ''}{stroke})"
        if self.fit is None:
            head += "; diagnostic pump card"
        elif self.identified:
            head += (f"; pump identified: {self.fit.status}, R^2 {self.r2():.4f}, residual "
                     f"lag-1 autocorrelation {_fmt(self.residual_autocorrelation())}")
        else:
            fit = f", R^2 {self.r2():.4f}" if self.r2() is not None else ""
            if self.residual_autocorrelation() is not None:
                fit += (", residual lag-1 autocorrelation "
                        f"{_fmt(self.residual_autocorrelation())}")
            # The reason on a line of its own: inside the head's parentheses it nested
            # them four deep.
            # The values below are the diagnostic card's: "determined derived quantities:
            # gross_stroke, ..." in the fit's reason read as if they were shown.
            head += (f"; pump not identified ({self.fit.status}{fit}); diagnostic pump card"
                     f"\n  why not identified: {printable(self.fit.reason)}; the quantities "
                     "below are the diagnostic pump card's")
        q = self.pump()
        parts = [f"{name.replace('_', ' ')} "
                 + format_error(q[name]["value"], q[name]["stderr"], q[name]["unit"])
                 + _undetermined(q[name])
                 for name in SHOWN if name in q and q[name]["value"] is not None]
        damping = self.damping()
        nu = format_error(damping["value"], damping["stderr"], "")
        rule = printable(damping["rule"])
        # Most rules state the value (and its error) already: not said twice.
        lines = [head, "  " + ", ".join(parts),
                 f"  damping: {rule}" if "nu = " in rule else f"  damping nu = {nu} ({rule})"]
        if self.identified and self.fit is not None and not math.isnan(self.fit.agreement):
            lines.append(f"  fitted and diagnostic pump cards differ by RMS "
                         f"{100 * self.fit.agreement:.2f} % of the load range"
                         + _solvers(self.fit.consistency))
        elif (self.identified and self.downhole is not None and self.downhole.ok
              and self.downhole.convention != "effective"):
            # Every other mode prints the comparison: its absence needs its reason.
            lines.append("  fitted and diagnostic pump cards not compared: the diagnostic "
                         f"card is in {self.downhole.convention} loads, the fitted one in "
                         "effective loads")
        return lines


def _undetermined(q: dict[str, Any]) -> str:
    """What a quantity's value is when the fit does not determine it, as the report says."""
    mark = quantity_mark(q)
    return f" {mark}" if mark else ""


def _solvers(consistency: float | None) -> str:
    """The words on the two solvers' own disagreement, after the measured card's."""
    if consistency is None or not math.isfinite(consistency):
        return ""
    return (f" (the fitted pump card and the diagnostic of the fitted surface load: "
            f"{100 * consistency:.2f} %, the two solvers' own difference; the rest is the "
            "surface residual carried down)")


def _fmt(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2f}"


def draw_identified(card: DownholeCard, path: str | os.PathLike[str] | BinaryIO) -> None:
    """Draw the card's figure and save it as PNG.

    With a fitted identification: the measured and fitted surface loads against position,
    the residual over the stroke, the diagnostic pump card (at the damping shown) and the
    identified pump card with the diagnostic one behind it. Without: the surface card beside
    the diagnostic pump card (:func:`pumpid.rods.figure.draw_cards`).

    Parameters
    ----------
    card : DownholeCard
        A card whose diagnostic was computed.
    path : str, path-like or binary file
        Where to write the PNG.
    """
    fit = card.fit
    down = card.downhole
    if (fit is None or not fit.ok or fit.fit is None or fit.model is None or not down.ok
            or down.pump_position is None or down.pump_load is None):
        draw_cards(down, path)
        return
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    c = down.card
    pu, lu = c.position_unit, c.load_unit
    surface = fit.model.surface
    position = surface.position / surface.position_factor  # time order, as the fit's loads
    measured, fitted = np.asarray(fit.fit.data), np.asarray(fit.fit.fitted)
    fig = Figure(figsize=(11, 8.4), dpi=100)
    (a, b), (d, e) = fig.subplots(2, 2)
    loop = np.r_[np.arange(position.size), 0]
    a.plot(position[loop], measured[loop], color="black", lw=1.2, label="measured")
    a.plot(position[loop], fitted[loop], color="tab:orange", lw=1.2, ls="--",
           label=f"fitted (R^2 {fit.fit.r2:.4f})")
    a.set_title("surface card: measured and fitted polished-rod load")
    a.set_xlabel(f"polished-rod position ({pu})")
    a.set_ylabel(f"load ({lu})")
    a.legend(loc="best", fontsize=8)
    phase = np.arange(measured.size) / measured.size
    residual = fitted - measured  # the sign every pumpid figure uses (fit's too)
    b.axhline(0.0, color="gray", lw=0.7)
    b.plot(phase, residual, color="tab:purple", lw=1.0)
    rho = card.residual_autocorrelation()
    b.set_title(f"residual: RMS {fit.fit.rmse:.3g} {lu}, lag-1 autocorr. {_fmt(rho)}")
    b.set_xlabel("time in the stroke (fraction of the period, from the first sample)")
    b.set_ylabel(f"fitted - measured load ({lu})")
    q = down.quantities()
    diag_pos, diag_load = np.asarray(down.pump_position), np.asarray(down.pump_load)
    d.plot(np.r_[diag_pos, diag_pos[0]], np.r_[diag_load, diag_load[0]], color="tab:blue")
    for name in _DIAGNOSTIC_ONLY:
        if q[name]["value"] is not None:
            d.axhline(q[name]["value"], color="gray", lw=0.7, ls="--")
    d.set_title(f"diagnostic pump card (damping nu {down.damping:.3g}, {down.method})")
    pump = fit.pump_card()
    if down.convention == "effective":
        e.plot(np.r_[diag_pos, diag_pos[0]], np.r_[diag_load, diag_load[0]], color="tab:blue",
               lw=0.8, alpha=0.4, label="diagnostic")
    if pump is not None:  # None: no march reaches a periodic stroke at the fitted values
        pos, load = pump
        e.plot(np.r_[pos, pos[0]], np.r_[load, load[0]], color="tab:green", lw=1.4,
               label="identified")
    shown = card.pump()
    fill, gross = shown["fillage"], shown["gross_stroke"]
    if card.identified and fill["value"] is not None and gross["value"] is not None:
        e.axvline(fill["value"] * gross["value"], color="tab:red", lw=0.7)
    e.set_title(f"identified pump card ({fit.status})" if pump is not None else
                f"identified pump card ({fit.status}): not drawn, no periodic stroke of "
                "the march at the fitted values")
    e.legend(loc="best", fontsize=8)
    # The identified card is in effective loads whatever the run's convention (it was
    # drawn on a "true pump load" axis).
    for ax, convention in ((d, down.convention), (e, "effective")):
        ax.set_xlabel(f"plunger position from its lowest point ({pu})")
        ax.set_ylabel(f"{convention} pump load ({lu})")
    for ax in (a, b, d, e):
        ax.grid(alpha=0.3)
    fl = shown["fluid_load"]
    fig.suptitle(f"card {c.card_id}: fluid load {format_error(fl['value'], fl['stderr'], lu)}, "
                 f"fillage {format_error(fill['value'], fill['stderr'], 'fraction')}, damping "
                 f"nu {format_error(card.damping()['value'], card.damping()['stderr'], '')}",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path)

