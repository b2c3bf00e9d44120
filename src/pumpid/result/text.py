"""Text pieces of a result's report that need no result: numbers, error tables, model choices."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["ADDITIVE", "error_table", "fmt", "fmt_error", "model_choice_text", "n_eff_words",
           "squared"]


def squared(unit: str, mark: str = "^2") -> str:
    """A unit squared: a compound one (``m^3/s``) bracketed first (``(m^3/s)^2``; the cost
    of a flow fit read "m^3/s^2")."""
    plain = unit.replace("_", "").isalnum()
    return f"{unit}{mark}" if plain else f"({unit}){mark}"


def fmt(value: float | None, digits: int = 6) -> str:
    """``value`` to ``digits`` significant digits, ``n/a`` for a missing or NaN one."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    return f"{value:.{digits}g}"


def fmt_error(value: float | None, digits: int = 4) -> str:
    """A standard error as text: ``n/a`` where there is none, also an infinite one (a value
    the data do not bound), as in every other text and HTML output; the tables keep
    ``inf`` (not bounded) apart from NaN (no error computed)."""
    if value is None or not math.isfinite(value):
        return "n/a"
    return f"{value:.{digits}g}"


#: Values whose zero is a convention (a position offset, the log of the scale): an error
#: relative to them means nothing, and the table printed one (an offset of -27.6 m "4.3 %").
ADDITIVE = ("offset", "D")


def error_table(names: Sequence[str], values: Mapping[str, float], units: Mapping[str, str],
                stderr: Mapping[str, Any], ci95: Mapping[str, Any]) -> list[str]:
    """Report lines of standard errors, relative errors and 95 % intervals of ``names``."""
    lines = [f"  {'value':<15}  {'std. error':<12}  {'rel.':<8}  {'95 % interval':<30}  unit"]
    for name in names:
        se = stderr.get(name)
        se = math.nan if se is None else float(se)
        v = values[name]
        rel = abs(se / v) if v and math.isfinite(se) else math.nan
        ci = ci95.get(name)
        ci_txt = f"[{ci[0]:.6g}, {ci[1]:.6g}]" if ci else "none"
        rel_txt = f"{100 * rel:.3g} %" if math.isfinite(rel) else "n/a"
        if name in ADDITIVE:
            rel_txt = "-"
        se_txt = fmt_error(se)
        lines.append(f"  {name:<15}  {se_txt:<12}  {rel_txt:<8}  {ci_txt:<30}  "
                     f"{units.get(name, '')}")
    return lines


def n_eff_words(choice: Mapping[str, Any]) -> str:
    """A model choice's effective sample size in words.

    Parameters
    ----------
    choice : mapping
        ``application["model_choice"]``: ``n_eff`` (what the criteria counted) and
        ``n_eff_data`` (the data's, when known).

    Returns
    -------
    str
        ``n_eff = X``, and what the criteria counted where that differs.
    """
    data = choice.get("n_eff_data", choice["n_eff"])
    data = choice["n_eff"] if data is None or not math.isfinite(data) else float(data)
    return (f"n_eff = {data:.1f}" if abs(data - choice["n_eff"]) < 0.05 else
            f"n_eff = {data:.1f}, counted as {choice['n_eff']:.1f} by the criteria, their "
            f"smallest usable size")


def model_choice_text(choice: Mapping[str, Any]) -> str:
    """A model choice's ranking (``application["model_choice"]``) as text."""
    crit = str(choice["criterion"]).upper()
    used = n_eff_words(choice)
    lines = [f"Model choice by {crit} on the effective sample size (n = {choice['n']}, "
             f"residual lag-1 autocorrelation {choice['rho']:.3f}, {used}); chosen: "
             f"{choice['chosen']}",
             f"  {'structure':<18}{'k':>3}{'R^2':>11}{'BIC':>12}{'AICc':>12}"
             f"{'delta':>9}{'weight':>8}  status"]
    for c in choice["candidates"]:
        lines.append(f"  {c['name']:<18}{c['k']:>3}{c['r2']:>11.6f}{c['bic']:>12.2f}"
                     f"{c['aicc']:>12.2f}{c['delta']:>9.2f}{c['weight']:>8.3f}  {c['status']}")
    for t in choice["nested_tests"]:
        lines.append(f"  likelihood ratio {t['big']} against {t['small']} ({t['limit']}): "
                     f"statistic {t['statistic']:.3g} on {t['dof']} dof, p = "
                     f"{t['p_value']:.3g}")
    return "\n".join(lines)
