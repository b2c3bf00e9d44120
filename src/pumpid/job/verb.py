"""One verb: :func:`fit` for a record's arrays, a card, or many records and cards.

The data decide the defaults: a :class:`~pumpid.cards.Card` gets
:meth:`FitOptions.for_cards` (a fitted position offset, the periodic steady state for one
stroke), arrays the plain :class:`FitOptions`; so a card gives the same answer whether it
comes alone, in a list, or as its arrays with ``FitOptions.for_cards(period=...)``. A
sequence is fitted as one batch (the same answers card by card, the work shared over
threads); a card that cannot be fitted is an ``invalid-input`` row, not an exception.

A model that brings its own simulator (:class:`pumpid.models.OwnModel`) goes through the
same verb and gets the same solver, statuses, diagnostics and result
(:mod:`pumpid.job.own`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..cards import Card
from ..engine.problem import CardData, build_problem, initial_state_label
from ..engine.solvers import LevenbergMarquardt, PaperNewton
from ..engine.threads import default_workers
from ..models import Model, OwnModel, model_class
from ..result import CardInfo, FitBatch, FitResult, Units
from .joint import StackedCards, joint_echo, joint_part, misfit_warning
from .options import FitOptions, job_options
from .own import fit_own
from .stages import run_batch

__all__ = ["card_info", "card_record", "card_units", "fit"]

Array = NDArray[np.float64]
Solver = LevenbergMarquardt | PaperNewton
Data = CardData | Card | Sequence[Any]


def card_units(card: Card) -> Units:
    """A card's units as a result records them (a placeholder where its file states none)."""
    return Units(load=card.load_unit or "load-unit",
                 position=card.position_unit or "position-unit")


def card_info(card: Card) -> CardInfo:
    """The card's identity and the notes of everything done to its data, for its result."""
    stamp = card.metadata.get("time", card.metadata.get("timestamp"))
    return CardInfo(id=card.card_id, well=card.well_id, source=card.source,
                    time_source=card.time_source, spm=card.spm, period=card.period,
                    notes=tuple(card.notes), time=None if stamp is None else str(stamp))


def card_record(card: Card, options: FitOptions) -> CardData:
    """The card as the engine's record under ``options``.

    Raises
    ------
    ValueError
        When the card cannot be fitted as asked (no time; a periodic start without the
        stroke period), naming the card.
    """
    if card.t is None:
        raise ValueError(
            f"card {card.card_id or card.source!r} has no time: give the pumping speed "
            "(spm=..., e.g. --spm 8.5) or the stroke period (period=... s)")
    t = np.asarray(card.t, dtype=float)
    period = card.period if card.periodic else None
    if card.periodic and period is None and card.dt is not None:
        period = card.n * card.dt
    if options.period is not None:
        period = float(options.period)
    state = options.initial_state_for(card.periodic)
    if state == "periodic" and period is None:
        raise ValueError(f"card {card.card_id!r}: initial_state='periodic' needs the stroke "
                         "period")
    return CardData(t, card.load, card.position, state,
                    period if state == "periodic" else None)


def _record(item: CardData, options: FitOptions) -> CardData:
    """A record under ``options``: its own initial state and period unless they say."""
    state = item.initial_state if options.initial_state is None else options.initial_state
    if options.initial_state is None and options.period is not None:
        # A period given makes the record periodic (FitOptions.period): one from rest, the
        # default of arrays; a record that states another start keeps it, and is told.
        if not (isinstance(state, str) and state in ("rest", "periodic")):
            raise ValueError(f"FitOptions.period={options.period!r}: the record's own "
                             f"initial_state {initial_state_label(state)!r} would not use "
                             "it; give initial_state='periodic' to fit it as a stroke")
        state = "periodic"
    period = item.period if options.period is None else options.period
    return CardData(item.t, item.load, item.data, state, period)


def _as_record(item: Card | CardData, options: FitOptions) -> CardData:
    """A card or a record as the engine's record under ``options`` (ValueError for a card
    that cannot be fitted as asked)."""
    return card_record(item, options) if isinstance(item, Card) else _record(item, options)


def _items(data: Any) -> tuple[list[Any], bool]:
    """The data as a list of records/cards, and whether it was one (a single fit)."""
    if isinstance(data, Card | CardData):
        return [data], True
    if isinstance(data, list | tuple):
        if not data:
            raise ValueError("data: nothing to fit (an empty sequence)")
        if all(isinstance(x, Card | CardData) for x in data):
            return list(data), False
        if len(data) == 3 and not any(isinstance(x, Card | CardData) for x in data):
            t, loads, displacements = data
            if _many_rows(loads):
                return _arrays_records(t, loads, displacements), False
            return [CardData(t, loads, displacements, "rest", None)], True
        bad = next(i for i, x in enumerate(data) if not isinstance(x, Card | CardData))
        raise TypeError(
            f"data[{bad}] is a {type(data[bad]).__name__}: a sequence to fit holds Card or "
            "CardData items; a record's arrays are given as (t, load, displacement)")
    raise TypeError(
        f"data must be (t, load, displacement) arrays, a pumpid.cards.Card, a CardData, or "
        f"a sequence of cards/records; got {type(data).__name__}")


def _many_rows(values: Any) -> bool:
    if isinstance(values, list | tuple):
        return bool(values) and np.ndim(values[0]) == 1
    return np.ndim(values) == 2


def _arrays_records(t: ArrayLike, loads: ArrayLike, displacements: ArrayLike
                    ) -> list[CardData]:
    """One record per row of ``loads`` / ``displacements`` (``t`` shared or per row)."""
    f_all = _rows("loads", loads)
    d_all = _rows("displacements", displacements)
    if len(f_all) != len(d_all):
        raise ValueError(f"loads has {len(f_all)} cards but displacements has {len(d_all)}")
    n_cards = len(f_all)
    if isinstance(t, list | tuple) and t and np.ndim(t[0]) == 1:
        t_rows = [np.asarray(row, dtype=float) for row in t]
        if len(t_rows) != n_cards:
            raise ValueError(f"t: {len(t_rows)} time rows for {n_cards} cards")
    else:
        t_arr = np.asarray(t, dtype=float)
        if t_arr.ndim == 1:
            t_rows = [t_arr] * n_cards
        elif t_arr.ndim == 2 and t_arr.shape[0] == n_cards:
            t_rows = list(t_arr)
        else:
            raise ValueError(f"t: expected shape (N,) or ({n_cards}, N), got {t_arr.shape}")
    return [CardData(t_rows[i], f_all[i], d_all[i], "rest", None) for i in range(n_cards)]


def fit(
    model: str | Model | type[Model] | OwnModel,
    data: Data,
    *,
    options: FitOptions | None = None,
    solver: Solver | None = None,
    x0: Mapping[str, float] | Model | ArrayLike | None = None,
    units: Units | Sequence[Units] | None = None,
    workers: int | None = None,
) -> FitResult | FitBatch:
    """Identify a model's parameters from measured data: one record, one card, or many.

    Parameters
    ----------
    model : str, Model class, Model instance or OwnModel
        A class (or its name, ``"kelvin"``, ``"maxwell"``, ``"msd"``, ``"first-order"``)
        asks for the automatic start; an instance is the starting guess; an
        :class:`~pumpid.models.OwnModel` brings its own simulator and sensitivities.
    data : arrays, Card, CardData, or a sequence of Card / CardData
        ``(t, load, displacement)``: time (s, strictly increasing), the input and the
        measured output in the user's units (2-D ``load`` / ``displacement``, one card per
        row, fit many cards); a :class:`~pumpid.cards.Card`; a
        :class:`~pumpid.engine.problem.CardData` (a record with its own initial state and
        period); or a list of cards and records, fitted as one batch. For an own model,
        whatever its methods take: a ``list`` is many items, anything else one.
    options : FitOptions, optional
        What the fit means. Default: :meth:`FitOptions.for_cards` when the data hold a
        card, :class:`FitOptions` otherwise.
    solver : LevenbergMarquardt or PaperNewton, optional
        The solver and its settings (default ``LevenbergMarquardt()``; ``PaperNewton()`` is
        the paper's Newton-Raphson with central differences).
    x0 : mapping, Model or array, optional
        Starting values overriding the model instance's; for one record a mapping may also
        give ``C`` / ``D`` and ``offset``; for many, an array (cards, p) gives one start per
        card.
    units : Units or sequence of Units, optional
        The units of load and position (shared or one per record); a card brings its own.
    workers : int, optional
        Threads for many cards (default: every core this process may use; one record uses
        one). The answers do not depend on it.

    Returns
    -------
    FitResult or FitBatch
        A :class:`FitResult` for one record or card, a :class:`FitBatch` (one result per
        item, in order) for a sequence. A failed fit is a result with status ``failed`` and
        the reason, never an exception; in a batch an item that cannot be fitted is an
        ``invalid-input`` row.

    Raises
    ------
    ValueError, TypeError
        For bad options or (one record) bad data, with a message naming the problem.

    Examples
    --------
    >>> import pumpid
    >>> res = pumpid.fit(pumpid.Kelvin, (t, load, displacement))          # doctest: +SKIP
    >>> res = pumpid.fit("kelvin", card)                                   # doctest: +SKIP
    >>> batch = pumpid.fit(pumpid.Kelvin, cards, workers=2)                # doctest: +SKIP
    """
    if options is not None and not isinstance(options, FitOptions):
        raise TypeError(f"options must be a FitOptions, got {type(options).__name__}")
    if isinstance(model, type) and issubclass(model, OwnModel):
        raise TypeError(f"an own model is given as an instance, with what it needs: "
                        f"{model.__name__}(...), not the class {model.__name__}")
    if isinstance(model, OwnModel):
        # An own model's data are its own business: a list is many items, anything else one.
        own_items = list(data) if isinstance(data, list) else [data]
        if not own_items:
            raise ValueError("data: nothing to fit (an empty list)")
        return fit_own(model, own_items, single=not isinstance(data, list),
                       options=options or FitOptions(), solver=solver, x0=x0, workers=workers)
    items, single = _items(data)
    has_card = any(isinstance(x, Card) for x in items)
    if options is None:
        options = FitOptions.for_cards() if has_card else FitOptions()
    if isinstance(model, str):
        model = model_class(model)
    unit_rows = _unit_rows(items, units)
    if options.joint:
        return _fit_joint(model, items, single, options, solver, x0, unit_rows, workers)
    if single:
        return _fit_one(model, items[0], options, solver, x0, unit_rows[0])
    return _fit_many(model, items, options, solver, x0, unit_rows, workers)


def _unit_rows(items: Sequence[Any], units: Units | Sequence[Units] | None) -> list[Units]:
    if units is not None and not isinstance(units, Units):
        # A string is a sequence too: units="lbf" read as 3 entries for 1 record.
        rows = [] if isinstance(units, str | bytes) else list(units)
        if not rows or not all(isinstance(u, Units) for u in rows):
            raise TypeError(f"units must be a pumpid.Units (or a list of one per record), "
                            f"got {units!r}")
        if len(rows) != len(items):
            raise ValueError(f"units: {len(rows)} entries for {len(items)} records")
        return rows
    return [units if units is not None else
            (card_units(x) if isinstance(x, Card) else Units()) for x in items]


def _fit_one(model: Model | type[Model], item: Any, options: FitOptions,
             solver: Solver | None, x0: Any, units: Units) -> FitResult:
    record = _as_record(item, options)
    cls, theta0, extras = _start_theta(model, x0)
    warnings: list[str] = []
    problem = build_problem(cls, [record], observe=options.observe,
                            integrator=options.integrator, residual=options.residual,
                            scale=options.scale, offset=options.offset,
                            fixed=dict(options.fixed), warnings=warnings)
    guess = c_start = off_start = None
    if theta0 is not None:
        theta0 = np.array(theta0, dtype=float)
        if problem.gauge_fixed and ("C" in extras or "D" in extras):
            # Keep the user's start on the same curve: move it onto the gauge C = 1.
            c = extras.pop("C", None) or math.exp(extras.pop("D", 0.0))
            theta0 = theta0 / c
        for i, value in problem.fixed:
            theta0[i] = value
        guess = theta0[None]
        if "C" in extras or "D" in extras:
            c_start = np.array([extras.get("C", math.exp(extras.get("D", 0.0)))])
        if "offset" in extras:
            off_start = np.array([extras["offset"]])
    batch = run_batch(problem, guess=guess, c_start=c_start, offset_start=off_start,
                      options=job_options(options, solver, workers=1, history=True),
                      units=units, warnings=warnings)
    res = batch.result(0)
    return res.with_parts(card=card_info(item)) if isinstance(item, Card) else res


def _fit_many(model: Model | type[Model], items: Sequence[Any], options: FitOptions,
              solver: Solver | None, x0: Any, units: list[Units],
              workers: int | None) -> FitBatch:
    cls, shared = _batch_model(model)
    n_cards = len(items)
    records: list[CardData] = []
    reasons: list[str] = []
    for item in items:
        if isinstance(item, Card):
            try:
                records.append(card_record(item, options))
                reasons.append("")
            except ValueError as exc:
                # A placeholder the engine will not fit: the row keeps the reason.
                records.append(CardData(np.arange(10.0), np.ones(10), np.ones(10)))
                reasons.append(str(exc))
        else:
            records.append(_as_record(item, options))
            reasons.append("")
    warnings: list[str] = []
    problem = build_problem(cls, records, observe=options.observe,
                            integrator=options.integrator, residual=options.residual,
                            scale=options.scale, offset=options.offset,
                            fixed=dict(options.fixed), strict=False, warnings=warnings,
                            invalid=reasons)
    guess = _batch_guess(cls, shared, x0, n_cards)
    if guess is not None:
        for i, value in problem.fixed:
            guess[:, i] = value
    batch = run_batch(problem, guess=guess,
                      options=job_options(options, solver, history=False,
                                          workers=default_workers() if workers is None
                                          else workers),
                      units=units, warnings=warnings)
    results = tuple(r.with_parts(card=card_info(x)) if r is not None and isinstance(x, Card)
                    else r for r, x in zip(batch.results, items, strict=True))
    return FitBatch(model_name=batch.model_name, param_names=batch.param_names,
                    results=results, invalid=batch.invalid)


def _fit_joint(model: Model | type[Model], items: Sequence[Any], single: bool,
               options: FitOptions, solver: Solver | None, x0: Any, units: list[Units],
               workers: int | None) -> FitResult:
    """One parameter set for every item (:mod:`pumpid.job.joint`), started from each item's
    own fit."""
    if single or len(items) < 2:
        raise ValueError("a joint fit needs a sequence of at least two cards or records")
    wells = sorted({x.well_id for x in items if isinstance(x, Card) and x.well_id is not None})
    if len(wells) > 1:
        # One parameter set is one rod string: cards of two wells fitted jointly give a poor
        # fit of neither well, with errors that describe no system.
        raise ValueError(f"joint fit: the cards come from {len(wells)} wells "
                         f"({', '.join(repr(w) for w in wells[:5])}"
                         f"{', ...' if len(wells) > 5 else ''}); a joint fit describes one "
                         "well's strokes: fit each well's cards on their own")
    if len({(u.load, u.position) for u in units}) > 1:
        raise ValueError(f"joint fit: the cards are in different units "
                         f"{sorted({(u.load, u.position) for u in units})}; convert them first "
                         "(Card.to_units)")
    if (options.fixed or options.scale != 1.0 or options.offset is not True
            or options.residual != "linear"):
        raise ValueError("joint fit: needs the fixed scale C = 1, the linear residual, a "
                         "fitted offset (FitOptions.for_cards) and no fixed parameters")
    if isinstance(solver, PaperNewton):
        raise TypeError("a joint fit is solved with LevenbergMarquardt")
    alone = options.replace(joint=False)
    singles = _fit_many(model, items, alone, solver, x0, units, workers)
    ids = [str(x.card_id) if isinstance(x, Card) else f"record {i + 1}"
           for i, x in enumerate(items)]
    bad = [ids[i] for i, r in enumerate(singles.results)
           if r is None or not np.all(np.isfinite(list(r.params.values())))]
    if bad:
        raise ValueError(f"joint fit: {', '.join(bad)} could not be fitted alone; leave them "
                         "out")
    records = [_as_record(x, alone) for x in items]
    first = singles.results[0]
    assert first is not None
    cls = type(model) if isinstance(model, Model) else model
    stacked = StackedCards(cls, records, first.observe, units[0], singles,
                           integrator=options.integrator)
    own = FitOptions(multistart=True if options.multistart is not False else "auto",
                     min_r2=options.min_r2, boundaries=options.boundaries)
    res = fit_own(stacked, [records], single=True, options=own, solver=solver, x0=None)
    assert isinstance(res, FitResult)
    res = joint_echo(stacked, res)
    part = joint_part(stacked, res, ids)
    apart = misfit_warning(part, units[0].position)
    return res.with_parts(application={"joint": part},
                          warnings=(*res.warnings, apart) if apart else res.warnings)


def _batch_guess(cls: type[Model], shared: Array | None, x0: Any, n_cards: int
                 ) -> Array | None:
    """Each card's starting parameters (None: the automatic start per card)."""
    p = len(cls.param_names())
    if x0 is None:
        return None if shared is None else np.tile(shared, (n_cards, 1))
    if isinstance(x0, Mapping | Model):
        _cls, theta, extras = _start_theta(cls if shared is None else cls.from_values(shared),
                                           x0)
        if extras:
            raise ValueError(f"x0: {sorted(extras)} start a single fit only (many cards "
                             "start their scale and offset from least squares)")
        return np.tile(theta, (n_cards, 1))
    arr = _x0_array(x0)
    if arr.ndim == 1:
        arr = np.broadcast_to(arr, (n_cards, arr.size))
    if arr.shape != (n_cards, p):
        raise ValueError(f"x0: expected shape ({n_cards}, {p}) or ({p},), got {arr.shape}")
    if not (np.isfinite(arr).all() and (arr > 0).all()):
        raise ValueError("x0: starting parameters must be positive and finite")
    return np.array(arr)


def _x0_number(value: Any, name: str) -> float:
    """One starting value as a float; a ValueError naming x0 and the entry otherwise."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"x0: {name} = {value!r} is not a number") from None


def _x0_array(x0: Any) -> Array:
    """The starting values as a float array; a ValueError naming x0 otherwise."""
    try:
        return np.asarray(x0, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"x0: {x0!r} is not a number, a sequence of numbers, a mapping of "
                         "parameter names to numbers nor a model") from None


def _start_theta(model: Model | type[Model], x0: Mapping[str, float] | Model | ArrayLike | None
                 ) -> tuple[type[Model], Array | None, dict[str, float]]:
    """Model class, starting parameters (None: automatic) and extra start values (C, offset)."""
    extras: dict[str, float] = {}
    if isinstance(model, Model):
        cls: type[Model] = type(model)
        theta: Array | None = model.values
    elif isinstance(model, type) and issubclass(model, Model):
        cls, theta = model, None
    else:
        raise TypeError(
            "model must be a model instance (a starting guess, e.g. Kelvin(k0=4, m=1, c1=0.2, "
            f"k1=4)) or a model class (automatic start), got {model!r}")
    if x0 is None:
        return cls, theta, extras
    if isinstance(x0, Model):
        if type(x0) is not cls:
            raise TypeError(f"x0 is a {type(x0).__name__}, the model a {cls.__name__}")
        return cls, x0.values, extras
    if isinstance(x0, Mapping):
        names = cls.param_names()
        unknown = set(x0) - set(names) - {"C", "D", "offset"}
        if unknown:
            raise ValueError(f"x0: unknown names {sorted(unknown)}; parameters are {names}")
        values = []
        for i, name in enumerate(names):
            if name in x0:
                values.append(_x0_number(x0[name], name))
            elif theta is not None:
                values.append(float(theta[i]))
            else:
                raise ValueError(f"x0: missing {name!r} (give all of {names} or a model)")
        for key in ("C", "D", "offset"):
            if key in x0:
                extras[key] = _x0_number(x0[key], key)
        # Checked as the other forms are: a start of -100 became 1.0 without a word.
        try:
            return cls, cls.from_values(np.array(values)).values, extras
        except ValueError as exc:
            raise ValueError(f"x0: {exc}") from None
    arr = _x0_array(x0).ravel()
    return cls, cls.from_values(arr).values, extras

def _batch_model(model: Model | type[Model]) -> tuple[type[Model], Array | None]:
    """The model class and the shared starting guess (None: automatic start per card)."""
    if isinstance(model, Model):
        return type(model), model.values
    if isinstance(model, type) and issubclass(model, Model):
        return model, None
    raise TypeError(
        "model must be a model instance (a shared starting guess, e.g. Kelvin(k0=4, m=1, "
        f"c1=0.2, k1=4)) or a model class (automatic start per card), got {model!r}")


def _rows(name: str, values: ArrayLike) -> list[Array]:
    if isinstance(values, list | tuple) and values and np.ndim(values[0]) == 1:
        return [np.asarray(v) for v in values]
    arr = np.asarray(values)
    if arr.ndim == 1:
        return [arr]
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected one card per row (cards, N), got shape {arr.shape}")
    return list(arr)
