"""Joint fits: one parameter set shared by several cards, each keeping its own offset.

Consecutive strokes of a steady well are the same system under slightly different loads. A
joint fit asks for the parameters all of them share (more data behind the same few numbers:
their errors shrink about as 1 / sqrt(number of cards) when the cards are alike, and the
directions one card leaves open can be closed by the others), each card keeping its own
position level (a card's zero is arbitrary).

It is an :class:`~pumpid.models.OwnModel` over the stacked cards, so it goes through the same
solver, boundary marks, errors that hold under correlated residuals, identifiability, gates
and :class:`~pumpid.result.FitResult` as any fit. Each card's position parameter is its
``level``: the position at the card's mean load (what a periodic card determines; the
offset at zero load trades off with the static stiffness), so the solver does not crawl
along that valley. The simulation and its exact sensitivities are the engine's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..engine.problem import CardData
from ..engine.simulate import simulate_sensitivities
from ..inference.derived import derived_of
from ..inference.echo import alias_of, echo_of
from ..models import Model, OwnModel, Parameter
from ..result import FitBatch, FitResult, Units

__all__ = ["APART", "StackedCards", "joint_echo", "joint_part", "misfit_warning"]

Array = NDArray[np.float64]
#: At most this many cards' own answers start the joint fit (with their median).
STARTS = 6
#: A card the joint fit leaves with an RMSE above this multiple of its own fit's does not
#: share the others' parameters. Consecutive strokes of one well come out at 1.00-1.01
#: (Sandia's two pairs, the bundled example), Sandia's four cards taken as one well (two
#: tests) at 2.7-5.1.
APART = 1.5


class StackedCards(OwnModel):
    """One lumped model's parameters shared by several records, a level per record.

    Parameters
    ----------
    cls : Model class
    records : sequence of CardData
        The records (each with its initial state and period), in order.
    observe : str
        The observed output.
    units : Units
        The records' units (shared).
    singles : FitBatch
        Each record's own fit (their answers start the joint fit).
    integrator : {"exact", "euler"}
        The forward model.
    """

    def __init__(self, cls: type[Model], records: Sequence[CardData], observe: str,
                 units: Units, singles: FitBatch, integrator: str = "exact") -> None:
        self.cls = cls
        self.integrator = integrator
        self.records = list(records)
        self.observe = observe
        self.singles = singles
        self.name = f"{cls.__name__} (joint, {len(self.records)} cards)"
        self.output, self.output_unit, self.input_unit = observe, units.position, units.load
        self.units = units
        states = {str(r.initial_state) for r in self.records}
        self.initial_state = states.pop() if len(states) == 1 else "per card"
        own = tuple(Parameter(p.name, p.unit_for(units.load, units.position),
                              lower=max(p.lower, 0.0), upper=p.upper, doc=p.doc)
                    for p in cls.param_info())
        levels = tuple(Parameter(f"level_{i + 1}", units.position, lower=-math.inf,
                                 doc=f"card {i + 1}'s position at its mean load")
                       for i in range(len(self.records)))
        self.parameters = own + levels
        self.n_model = len(own)

    def _load(self, record: CardData) -> Array:
        return np.asarray(record.load, dtype=float)

    def simulate(self, values: Array, data: Any, sensitivities: bool
                 ) -> tuple[Array, Array | None]:
        """Each record's centred response plus its level, end to end."""
        p = self.n_model
        model = self.cls.from_values(values[:p])
        preds, jacs = [], []
        for i, rec in enumerate(self.records):
            y, dy = simulate_sensitivities(model, rec.t, self._load(rec), observe=self.observe,
                                           initial_state=rec.initial_state, period=rec.period,
                                           integrator=self.integrator)  # type: ignore[arg-type]
            preds.append(y - y.mean() + values[p + i])
            if sensitivities:
                block = np.zeros((y.size, len(self.parameters)))
                block[:, :p] = dy - dy.mean(axis=0)
                block[:, p + i] = 1.0
                jacs.append(block)
        return np.concatenate(preds), (np.vstack(jacs) if sensitivities else None)

    def observed(self, data: Any) -> Array:
        """The records' measured outputs, end to end."""
        return np.concatenate([np.asarray(r.data, dtype=float) for r in self.records])

    def time(self, data: Any) -> Array:
        """The records placed end to end on one time axis (display only)."""
        out, shift = [], 0.0
        for rec in self.records:
            t = np.asarray(rec.t, dtype=float)
            out.append(t - t[0] + shift)
            step = float(t[-1] - t[0])
            shift += step + step / max(t.size - 1, 1)
        return np.concatenate(out)

    def driving(self, data: Any) -> Array:
        """The records' loads, end to end."""
        return np.concatenate([self._load(r) for r in self.records])

    def start(self, data: Any) -> Array:
        """Each card's own answer (at most :data:`STARTS`) and their median, with each card's
        level from the data."""
        own = np.array([[r.params[n] for n in self.cls.param_names()]
                        for r in self.singles.results if r is not None])
        picks = [*own[:STARTS], np.exp(np.median(np.log(own), axis=0))]
        levels = [float(np.mean(np.asarray(r.data, dtype=float))) for r in self.records]
        return np.array([np.concatenate([p, levels]) for p in picks])

    def derived(self, values: Array, numbers: Any, serial: bool,
                limits: Sequence[tuple[str, str]]) -> Mapping[str, Any]:
        """The lumped model's derived quantities (natural frequency, damping ratio, ...), the
        oscillating pair's marked where it echoes the cards' stroke frequency (before the
        gates, which name an echo that they list as determined)."""
        derived = derived_of(self.cls, values[: self.n_model], observe=self.observe,
                             scale=1.0, nums=numbers,
                             units=(self.units.load, self.units.position), serial=serial,
                             limits=[b for b in limits if b[0] in self.cls.param_names()])
        return self.echo(derived)[0]

    def echo(self, derived: Mapping[str, Any]) -> tuple[dict[str, Any], str | None]:
        """:func:`pumpid.inference.echo.alias_of` against the coarsest card's sampling, else
        :func:`pumpid.inference.echo.echo_of` against each card's stroke frequency: the
        quantities (the pair marked where its resonance lies beyond the samples or on a
        card's stroke frequency) and the finding in words (None when it is clear of both, an
        echo checked only where every card is one period)."""
        periods = [r.period for r in self.records
                   if isinstance(r.initial_state, str) and r.initial_state == "periodic"
                   and r.period is not None]
        # The coarsest card's samples show the least: a resonance beyond them is an alias
        # there (pumpid.inference.echo.alias_of).
        steps = [float(np.median(np.diff(np.asarray(r.t, dtype=float))))
                 for r in self.records if np.size(r.t) >= 2]
        aliased, alias = alias_of(derived, max(steps) if steps else None)
        if alias is not None:
            return aliased, alias
        if len(periods) != len(self.records):
            return dict(derived), None
        for period in dict.fromkeys(float(p) for p in periods):
            marked, words = echo_of(derived, period)
            if words is not None:
                return marked, words
        return dict(derived), None


def joint_part(model: StackedCards, result: FitResult, ids: Sequence[str]) -> dict[str, Any]:
    """The per-card part of a joint fit: each card's offset (at zero load; whether it is
    determined), level, R^2, RMSE and its own fit's parameters."""
    p = model.n_model
    values = np.array([result.params[n] for n in model.param_names()])
    # A card's offset at zero load is its level less the mean load over the static
    # stiffness: determined only where that stiffness is.
    stiff = result.derived.get("static_stiffness")
    offset_determined = stiff is None or bool(stiff.determined)
    cards = []
    at = 0
    fitted = np.asarray(result.fitted)
    for i, rec in enumerate(model.records):
        d = np.asarray(rec.data, dtype=float)
        part = slice(at, at + d.size)
        at += d.size
        res = fitted[part] - d
        sst = float(np.sum((d - d.mean()) ** 2))
        mean_response = math.nan
        if np.all(np.isfinite(values[:p])):
            y, _ = simulate_sensitivities(model.cls.from_values(values[:p]), rec.t,
                                          model._load(rec), observe=model.observe,
                                          initial_state=rec.initial_state, period=rec.period,
                                          integrator=model.integrator)  # type: ignore[arg-type]
            mean_response = float(y.mean())
        single = model.singles.results[i]
        cards.append({
            "card": ids[i], "level": float(values[p + i]),
            "offset": float(values[p + i]) - mean_response,
            "offset_determined": offset_determined,
            "r2": 1.0 - float(res @ res) / sst if sst > 0 else math.nan,
            "rmse": math.sqrt(float(res @ res) / d.size),
            "rmse_alone": math.nan if single is None else float(single.rmse),
            # Both at rounding level (exact cards) are alike, whatever their ratio.
            "apart": single is not None and math.sqrt(float(res @ res) / d.size) > max(
                APART * float(single.rmse), 1e-9 * float(np.ptp(d))),
            "single": {} if single is None else dict(single.params)})
    return {"model": model.cls.__name__, "observe": model.observe, "cards": cards}


def misfit_warning(part: Mapping[str, Any], unit: str) -> str:
    """A warning naming the cards the joint fit describes :data:`APART` times worse than
    their own fits (``""`` when there are none): they do not share one parameter set."""
    apart = [(c["card"], c["rmse"], c["rmse_alone"]) for c in part["cards"] if c["apart"]]
    if not apart:
        return ""
    said = ", ".join(f"{card} (RMSE {joint:.4g} {unit} jointly, {alone:.4g} {unit} alone)"
                     for card, joint, alone in apart)
    return (f"{len(apart)} of {len(part['cards'])} cards fit jointly more than {APART:g}x "
            f"worse than alone: {said}. The cards do not share one parameter set (another "
            "well, or the well changed between them): fit them apart")


def joint_echo(model: StackedCards, result: FitResult) -> FitResult:
    """``result`` with the warning and the list of quantities that are not the well's, where
    its resonance sits on a card's stroke frequency (:meth:`StackedCards.echo`; a joint fit
    of one well's strokes echoes their pumping speed as each card's fit does).

    Parameters
    ----------
    model : StackedCards
        The joint model the result was fitted with.
    result : FitResult
        Its result, the quantities already marked by :meth:`StackedCards.derived`.

    Returns
    -------
    FitResult
        The result, with the finding in its warnings and ``determined["not_well_property"]``
        where there is one; else ``result`` itself.
    """
    if not result.derived:
        return result
    derived, echo = model.echo(result.derived)
    if echo is None:
        return result
    determined = {**result.determined,
                  "not_well_property": [n for n, d in derived.items() if not d.well_property]}
    return result.with_parts(derived=derived, warnings=(*result.warnings, echo),
                             determined=determined)
