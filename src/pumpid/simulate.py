"""Simulation of a linear model driven by a sampled load.

Two integrators share one recursion ``x[k+1] = Phi_k x[k] + G0_k F[k] + G1_k F[k+1]``:

``exact``
    First-order-hold exact discretization: the load is taken piecewise linear between samples
    and Phi, G0, G1 come from one matrix exponential of an augmented matrix (MODEL-NOTES
    section 4). Exact for any step sizes, so non-uniform time stamps are handled exactly.
``euler``
    The paper's explicit Euler scheme ``x[k+1] = x[k] + dt (A x[k] + B F[k])``, kept to
    reproduce the paper's tables.

Parameter sensitivities are exact for either integrator: the model is augmented with the
sensitivity equations ``d/dt dx = A dx + dA x + dB F`` (a block lower-triangular system)
and the same discretization is applied to it, which yields the exact derivative of the
discrete recursion -- no finite differences.

No Python loop runs over the samples. On a uniform grid (the usual case, and every card)
:func:`observed` evaluates the recursion in the frequency domain (:mod:`pumpid.spectral`):
transfer-function polynomials of the discretized system and its sensitivity system in
``w = z - 1``, which keeps full precision when the poles crowd near ``z = 1`` (fine
sampling) where scipy.signal's polynomials in ``z`` would not, then one inverse FFT. Other
grids use :func:`propagate`, a log-depth parallel prefix ("scan") of the state recursion.
Both run a batch of parameter sets and cards at once, and agree to rounding.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from . import spectral
from .models import Model

__all__ = [
    "Grid",
    "InitialState",
    "check_signal",
    "make_grid",
    "observed",
    "propagate",
    "simulate",
    "simulate_sensitivities",
]

Integrator = Literal["exact", "euler"]
InitialState = str | Sequence[float] | Mapping[str, float] | NDArray[np.float64]
INITIAL_MODES = ("rest", "equilibrium", "periodic")
_UNIFORM_RTOL = 1e-9


@dataclass(frozen=True)
class Grid:
    """A validated time grid.

    Attributes
    ----------
    t : ndarray
        Sample times (s), strictly increasing.
    steps : ndarray
        ``diff(t)``.
    dt : float or None
        The common step when the grid is uniform (to a relative 1e-9), else None.
    """

    t: NDArray[np.float64]
    steps: NDArray[np.float64]
    dt: float | None

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    @property
    def uniform(self) -> bool:
        """True when all steps are equal to a relative 1e-9."""
        return self.dt is not None


def check_signal(name: str, values: ArrayLike, n: int | None = None) -> NDArray[np.float64]:
    """Return ``values`` as a finite 1-D float array or raise ValueError naming the problem."""
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: not an array of numbers ({exc})") from None
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        kind = "NaN" if np.isnan(arr[i]) else "inf"
        raise ValueError(
            f"{name}: {int(bad.sum())} non-finite value(s); first is {kind} at index {i}"
        )
    if n is not None and arr.size != n:
        raise ValueError(f"{name}: length {arr.size} does not match the time vector's length {n}")
    return arr


def make_grid(t: ArrayLike, min_samples: int = 2) -> Grid:
    """Validate a time vector (finite, 1-D, strictly increasing) and classify its spacing."""
    tt = check_signal("t", t)
    if tt.size < min_samples:
        raise ValueError(f"t: {tt.size} samples; at least {min_samples} are needed")
    steps = np.diff(tt)
    if (steps <= 0).any():
        i = int(np.flatnonzero(steps <= 0)[0])
        raise ValueError(
            f"t: time must be strictly increasing; t[{i + 1}] = {float(tt[i + 1])!r} s "
            f"follows t[{i}] = {float(tt[i])!r} s"
        )
    mean = (tt[-1] - tt[0]) / (tt.size - 1)
    uniform = bool(np.all(np.abs(steps - mean) <= _UNIFORM_RTOL * mean))
    return Grid(tt, steps, float(mean) if uniform else None)


# --------------------------------------------------------------------------- building blocks
def _augment(
    a: NDArray[np.float64], b: NDArray[np.float64], da: NDArray[np.float64], db: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """State + sensitivity system: X = [x, dx/dtheta_1, ..., dx/dtheta_p]."""
    n = a.shape[-1]
    p = da.shape[-3]
    size = n * (p + 1)
    batch = a.shape[:-2]
    big_a = np.zeros((*batch, size, size))
    big_b = np.zeros((*batch, size))
    big_b[..., :n] = b
    for i in range(p + 1):
        big_a[..., i * n:(i + 1) * n, i * n:(i + 1) * n] = a
    for i in range(p):
        big_a[..., (i + 1) * n:(i + 2) * n, :n] = da[..., i, :, :]
        big_b[..., (i + 1) * n:(i + 2) * n] = db[..., i, :]
    return big_a, big_b


def _discretize(
    a: NDArray[np.float64], b: NDArray[np.float64], h: ArrayLike, integrator: Integrator
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Phi, G0, G1 of one step of length h (h broadcasts against a's batch dimensions)."""
    phi, g0, g1, _ = _discretize_and_power(a, b, h, integrator, None)
    return phi, g0, g1


def _discretize_and_power(
    a: NDArray[np.float64], b: NDArray[np.float64], h: ArrayLike, integrator: Integrator,
    steps: int | None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
           NDArray[np.float64] | None]:
    """:func:`_discretize`, and ``Phi^steps`` when ``steps`` is given (uniform h).

    For the exact integrator both exponentials go to one ``expm`` call on a stack of two
    matrices: scipy scales each one separately, and the call's overhead is paid once.
    """
    n = a.shape[-1]
    hh = np.asarray(h, dtype=float)[..., None, None]
    if integrator == "euler":
        phi = np.eye(n) + a * hh
        g0 = b * hh[..., 0]
        power = None if steps is None else np.linalg.matrix_power(phi, steps)
        return phi, g0, np.zeros_like(g0), power
    batch = np.broadcast_shapes(a.shape[:-2], hh.shape[:-2])
    m = np.zeros((1 if steps is None else 2, *batch, n + 2, n + 2))
    m[0, ..., :n, :n] = a * hh
    m[0, ..., :n, n] = b * hh[..., 0]
    # The extra state is the load increment over the step (not its rate), so G1 is read off
    # directly instead of dividing by a possibly tiny h.
    m[0, ..., n, n + 1] = 1.0
    if steps is not None:
        m[1, ..., :n, :n] = a * (hh * steps)
    e = scipy.linalg.expm(m)
    phi = e[0, ..., :n, :n]
    g1 = e[0, ..., :n, n + 1]
    g0 = e[0, ..., :n, n] - g1
    return phi, g0, g1, None if steps is None else e[1, ..., :n, :n]


def _transition_power(
    a: NDArray[np.float64], h: float, steps: int, integrator: Integrator
) -> NDArray[np.float64]:
    """``Phi^steps`` for one uniform step h (as :func:`_discretize_and_power` would give it)."""
    if integrator == "euler":
        return np.linalg.matrix_power(np.eye(a.shape[-1]) + a * h, steps)
    return scipy.linalg.expm(a * (h * steps))


def _scan(
    phi: NDArray[np.float64], z: NDArray[np.float64], varying: bool, inplace: bool = False
) -> NDArray[np.float64]:
    """Solve X[0] = z[0], X[k] = Phi X[k-1] + z[k] by a log-depth parallel prefix.

    phi: (..., n, n) for a constant transition, or (..., K, n, n) with the transition into
    sample k at index k (index 0 unused) when ``varying``. z: (..., K, n). Works in place on a
    copy of z (or on z itself when ``inplace``).
    """
    x = z if inplace else np.array(z, dtype=float, copy=True)
    k_len = x.shape[-2]
    p = np.array(phi, dtype=float, copy=True)
    shift = 1
    while shift < k_len:
        if varying:
            # Transition from k-shift to k applied to the partial sum ending at k-shift.
            x[..., shift:, :] += np.einsum("...kij,...kj->...ki", p[..., shift:, :, :],
                                           x[..., :-shift, :])
            p[..., shift:, :, :] = p[..., shift:, :, :] @ p[..., :-shift, :, :]
        else:
            x[..., shift:, :] += x[..., :-shift, :] @ np.swapaxes(p, -1, -2)
            p = p @ p
        shift *= 2
    return x


def _initial_state_vector(
    model_cls: type[Model], initial_state: InitialState
) -> NDArray[np.float64] | None:
    """A given initial state as an array, or None for the named modes."""
    if isinstance(initial_state, str):
        if initial_state not in INITIAL_MODES:
            raise ValueError(
                f"initial_state: unknown mode {initial_state!r}; use one of {INITIAL_MODES} "
                f"or give the state {model_cls.states} as numbers"
            )
        return None
    n = model_cls.n_states()
    if isinstance(initial_state, Mapping):
        unknown = set(initial_state) - set(model_cls.states)
        if unknown:
            raise ValueError(
                f"initial_state: {sorted(unknown)} are not states of {model_cls.__name__} "
                f"{model_cls.states}"
            )
        x0 = np.zeros(n)
        for name, value in initial_state.items():
            x0[model_cls.states.index(name)] = float(value)
    else:
        x0 = np.asarray(initial_state, dtype=float).ravel()
        if x0.size != n:
            raise ValueError(
                f"initial_state: {model_cls.__name__} has {n} states {model_cls.states}, "
                f"got {x0.size} values"
            )
    if not np.all(np.isfinite(x0)):
        raise ValueError("initial_state: values must be finite")
    return x0


def propagate(
    model_cls: type[Model],
    theta: ArrayLike,
    grid: Grid,
    load: ArrayLike,
    *,
    initial_state: InitialState = "rest",
    integrator: Integrator = "exact",
    sensitivities: bool = True,
    period: float | None = None,
    _mapped: bool = False,
) -> NDArray[np.float64]:
    """Run the model (and optionally its sensitivity system) over a grid.

    This is the engine behind :func:`simulate` and the fitters. ``theta`` may hold a batch of
    parameter vectors (..., p) and ``load`` a matching batch (..., N) of loads on the shared
    grid.

    Returns
    -------
    ndarray, shape (..., N, n * (p + 1)) or (..., N, n)
        The states ``x`` followed (if ``sensitivities``) by ``dx/dtheta_i`` for each parameter.
    """
    if integrator not in ("exact", "euler"):
        raise ValueError(f"integrator must be 'exact' or 'euler', got {integrator!r}")
    th = np.asarray(theta, dtype=float)
    f = np.asarray(load, dtype=float)
    dg = None
    if model_cls.transforms_input and not _mapped:
        f, dg = model_cls.input_map(th, f)
    a, b, da, db = model_cls.system_batch(th)
    if sensitivities and dg is not None:
        # Hammerstein model: dx/dtheta_i also responds to B dg/dtheta_i. By linearity that
        # part is the plain model's response to the input dg_i, with the same initial-state
        # rule (rest, equilibrium or periodic; zero for a given state).
        base = propagate(model_cls, th, grid, f, initial_state=initial_state,
                         integrator=integrator, sensitivities=True, period=period,
                         _mapped=True)
        n = model_cls.n_states()
        state0 = initial_state if isinstance(initial_state, str) else "rest"
        for i in range(da.shape[-3]):
            dgi = dg[..., i, :]
            if np.any(dgi):
                extra = propagate(model_cls, th, grid, dgi, initial_state=state0,
                                  integrator=integrator, sensitivities=False, period=period,
                                  _mapped=True)
                base[..., n * (i + 1):n * (i + 2)] += extra
        return base
    if sensitivities:
        a, b = _augment(a, b, da, db)
    size = a.shape[-1]
    batch = np.broadcast_shapes(a.shape[:-2], f.shape[:-1])
    x0_given = _initial_state_vector(model_cls, initial_state)
    mode = initial_state if x0_given is None else "given"

    n_steps = grid.n - 1
    z = np.zeros((*batch, n_steps + 1, size))
    if grid.uniform:
        phi, g0, g1 = _discretize(a, b, grid.dt, integrator)
        # z[k] = G0 F[k-1] + G1 F[k] as one (N, 2) @ (2, n) product per batch member.
        pair = np.stack([f[..., :-1], f[..., 1:]], axis=-1)
        z[..., 1:, :] = pair @ np.stack([g0, g1], axis=-2)
        varying = False
    else:
        phi, g0, g1 = _discretize(a[..., None, :, :], b[..., None, :], grid.steps, integrator)
        z[..., 1:, :] = g0 * f[..., :-1, None] + g1 * f[..., 1:, None]
        varying = True
        # Prepend an unused transition for sample 0 so index k is the transition into k.
        phi = np.concatenate([np.broadcast_to(np.eye(size), (*phi.shape[:-3], 1, size, size)),
                              phi], axis=-3)

    if mode == "given":
        z[..., 0, : model_cls.n_states()] = x0_given
    elif mode == "equilibrium":
        # Static equilibrium of the (augmented) system under the first load sample: its
        # sensitivity block is exactly the derivative of the equilibrium.
        z[..., 0, :] = -np.linalg.solve(a, (b * f[..., 0:1])[..., None])[..., 0]
    x = _scan(phi, z, varying, inplace=True)

    if mode == "periodic":
        x = _periodic_correction(x, a, b, f, grid, phi, integrator, varying, period)
    return x


def _periodic_correction(
    x_rest: NDArray[np.float64],
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    f: NDArray[np.float64],
    grid: Grid,
    phi: NDArray[np.float64],
    integrator: Integrator,
    varying: bool,
    period: float | None,
) -> NDArray[np.float64]:
    """Periodic steady state: the samples cover one period T, and F(T) = F(t0).

    The state after one period from rest is X_T; the periodic initial state solves
    (I - Phi_T) X0 = X_T with Phi_T the transition over one period (exact: expm(A T)).
    """
    span = grid.t[-1] - grid.t[0]
    if period is None:
        if not grid.uniform:
            raise ValueError(
                "initial_state='periodic' on a non-uniform grid needs period= (the stroke "
                "period in s): the closing step cannot be inferred"
            )
        period = span + grid.dt
    if not period > span:
        raise ValueError(
            f"period = {period:g} s must exceed the record's span {span:g} s (the samples "
            "cover one period, without a repeated closing point)"
        )
    h_close = period - span
    phi_c, g0_c, g1_c = _discretize(a, b, h_close, integrator)
    last = x_rest[..., -1, :]
    x_t = (phi_c @ last[..., None])[..., 0] + g0_c * f[..., -1:] + g1_c * f[..., 0:1]
    size = a.shape[-1]
    if integrator == "exact":
        phi_t = scipy.linalg.expm(a * period)
    elif not varying:
        n_steps = grid.n - 1
        phi_t = phi_c @ np.linalg.matrix_power(phi, n_steps)
    else:
        # Product of the per-step transitions (index 0 is the unused identity).
        phi_t = phi_c.copy()
        for k in range(grid.n - 1, 0, -1):
            phi_t = phi_t @ phi[..., k, :, :]
    x0 = np.linalg.solve(np.eye(size) - phi_t, x_t[..., None])[..., 0]
    z = np.zeros_like(x_rest)
    z[..., 0, :] = x0
    homogeneous = _scan(phi, z, varying)
    return x_rest + homogeneous


def _spectral_applies(
    grid: Grid, model_cls: type[Model], initial_state: InitialState, period: float | None
) -> bool:
    """The frequency-domain route covers uniform grids, linear inputs and a periodic state
    whose period is the samples' span plus one step (the usual stroke)."""
    if not grid.uniform or model_cls.transforms_input:
        return False
    if isinstance(initial_state, str) and initial_state == "periodic" and period is not None:
        expected = grid.t[-1] - grid.t[0] + grid.dt
        return bool(abs(period - expected) <= 1e-12 * expected)
    return True


def observed(
    model_cls: type[Model],
    theta: ArrayLike,
    grid: Grid,
    load: ArrayLike,
    rows: list[int] | NDArray[np.intp],
    *,
    initial_state: InitialState = "rest",
    integrator: Integrator = "exact",
    sensitivities: bool = True,
    period: float | None = None,
    scan: bool = False,
) -> NDArray[np.float64]:
    """Selected columns (``rows`` of the state or augmented state) over the grid, (..., N, r).

    On a uniform grid the recursion is evaluated in the frequency domain
    (:mod:`pumpid.spectral`): the transfer functions of the discretized system and its
    sensitivity system on a DFT grid, one inverse FFT back to time, no pass over the samples.
    Non-uniform grids, input maps and a periodic state with an unusual period go through
    :func:`propagate`'s scan, and so does every call with ``scan=True``. The two routes agree
    to rounding for parameters within a factor of about 1000 of their natural scales (tested);
    far beyond, the polynomial route loses digits (a nearly undamped resonance, or time
    constants millions of times apart), so callers that know the natural scales send such
    parameter sets to the scan (:class:`pumpid.problem.Problem` does).
    """
    th = np.asarray(theta, dtype=float)
    f = np.asarray(load, dtype=float)
    rows = np.asarray(rows, dtype=np.intp)
    if integrator not in ("exact", "euler"):
        raise ValueError(f"integrator must be 'exact' or 'euler', got {integrator!r}")
    if scan or not _spectral_applies(grid, model_cls, initial_state, period):
        x = propagate(model_cls, th, grid, f, initial_state=initial_state,
                      integrator=integrator, sensitivities=sensitivities, period=period)
        return x[..., rows]
    if rows.size == 0:
        raise ValueError("rows: at least one state or sensitivity row is needed")
    n = model_cls.n_states()
    block, state = np.divmod(rows, n)
    if not sensitivities and np.any(block > 0):
        raise ValueError("rows beyond the states need sensitivities=True")
    params = np.unique(block[block > 0]) - 1
    states = np.unique(state)
    out = observed_blocks(model_cls, th, grid, f, states, params, initial_state=initial_state,
                          integrator=integrator)
    # out: (..., blocks, states, N); map each requested row to its block and state.
    block_pos = np.zeros(block.max() + 1, dtype=np.intp)
    block_pos[params + 1] = np.arange(1, params.size + 1)
    pos = block_pos[block]
    if states.size == 1 and np.array_equal(pos, np.arange(pos.size)):
        return np.moveaxis(out[..., 0, :], -2, -1)  # the usual rows: a view, no copy
    return np.moveaxis(out[..., pos, np.searchsorted(states, state), :], -2, -1)


def observed_blocks(
    model_cls: type[Model],
    theta: NDArray[np.float64],
    grid: Grid,
    load: NDArray[np.float64],
    states: NDArray[np.intp],
    params: NDArray[np.intp],
    *,
    initial_state: InitialState = "rest",
    integrator: Integrator = "exact",
) -> NDArray[np.float64]:
    """Observed states and their sensitivities by frequency domain, time last.

    The engine behind :func:`observed` where :func:`_spectral_applies` holds (the caller
    checks). ``states`` are state indices, ``params`` parameter indices (may be empty).

    Returns
    -------
    ndarray, shape (..., 1 + len(params), len(states), N)
        Block 0 holds the states, block 1 + i their derivatives in ``params[i]``.
    """
    n = model_cls.n_states()
    a, b, da, db = model_cls.system_batch(theta)
    if integrator == "euler" and _euler_marginal(a, grid.dt):
        return _blocks_by_scan(model_cls, theta, grid, load, states, params, initial_state)
    a, b = _augment(a, b, da[..., params, :, :], db[..., params, :])
    x0_given = _initial_state_vector(model_cls, initial_state)
    mode = initial_state if x0_given is None else "given"
    periodic = mode == "periodic"
    short = None if periodic else spectral.short_length(grid.n)
    phi, g0, g1, phi_l = _discretize_and_power(a, b, grid.dt, integrator, short)
    f = load
    v = x_eq = None
    if mode == "equilibrium":
        # The equilibrium under F[0] is a fixed point of the recursion (exact and Euler), so
        # the response is that constant plus the response from rest to F - F[0]: the
        # oscillating part is then computed from a small input, at full relative precision.
        x_eq = -np.linalg.solve(a, (b * f[..., 0:1])[..., None])[..., 0]
        f = f - f[..., 0:1]
    if mode != "periodic":
        v = np.zeros(b.shape)
        if mode == "given":
            v[..., :n] = x0_given
        v = v - g1 * f[..., 0:1]
    if periodic:
        out = spectral.response(phi, g0, g1, f, n, states, periodic=True)
    elif spectral.has_decayed(phi_l, n):
        out = spectral.decayed_response(phi, g0, g1, f, n, states, v, phi_l)
    else:
        # Slowly decaying: the circular convolution on the long grid, which needs Phi^N.
        phi_n = phi_l if short == grid.n else _transition_power(a, grid.dt, grid.n, integrator)
        out = spectral.response(phi, g0, g1, f, n, states, periodic=False, v=v, phi_n=phi_n)
    if x_eq is not None:
        blocks = x_eq.reshape(*x_eq.shape[:-1], -1, n)[..., states]
        out += blocks[..., None]
    return out


#: Explicit Euler steps whose transition has an eigenvalue this close to the unit circle go to
#: the scan: such a pole can sit on (or next to) a DFT frequency of the spectral route.
_EULER_MARGIN = 1e-4


def _euler_marginal(a: NDArray[np.float64], h: float) -> bool:
    """True when some system's Euler transition ``I + A h`` is marginally stable."""
    phi = np.eye(a.shape[-1]) + a * h
    finite = np.isfinite(phi).all(axis=(-2, -1))
    if not finite.any():
        return False  # non-finite systems give non-finite outputs either way
    lam = np.abs(np.linalg.eigvals(phi[finite]))
    return bool(np.any(np.abs(lam - 1.0) < _EULER_MARGIN))


def _blocks_by_scan(
    model_cls: type[Model], theta: ArrayLike, grid: Grid, load: NDArray[np.float64],
    states: NDArray[np.intp], params: NDArray[np.intp], initial_state: InitialState,
) -> NDArray[np.float64]:
    """:func:`observed_blocks`' layout computed by the state scan (Euler steps)."""
    x = propagate(model_cls, theta, grid, load, initial_state=initial_state,
                  integrator="euler", sensitivities=params.size > 0)
    n = model_cls.n_states()
    base = np.concatenate([[0], (np.asarray(params) + 1) * n])
    cols = base[:, None] + np.asarray(states)[None, :]  # (blocks, states)
    return np.moveaxis(x[..., cols], -3, -1)


def _prepare(
    model: Model, t: ArrayLike, load: ArrayLike
) -> tuple[Grid, NDArray[np.float64]]:
    if not isinstance(model, Model):
        raise TypeError(
            f"model must be a model instance such as Kelvin(k0=4, m=1, c1=0.2, k1=4), "
            f"got {model!r}"
        )
    grid = make_grid(t)
    f = check_signal("load", load, grid.n)
    return grid, f


def simulate(
    model: Model,
    t: ArrayLike,
    load: ArrayLike,
    *,
    observe: str | None = None,
    initial_state: InitialState = "rest",
    integrator: Integrator = "exact",
    scale: float = 1.0,
    period: float | None = None,
    all_states: bool = False,
) -> NDArray[np.float64]:
    """Simulate the model's response to a sampled load.

    Parameters
    ----------
    model : Model
        A model instance, e.g. ``Kelvin(k0=4, m=1, c1=0.2, k1=4)``.
    t : array_like, shape (N,)
        Sample times in seconds, strictly increasing (non-uniform steps are handled exactly by
        the ``exact`` integrator).
    load : array_like, shape (N,)
        The input at those times (load for the mechanical models; a rate for
        :class:`~pumpid.models.FirstOrder`), taken piecewise linear between samples.
    observe : str, optional
        The observed state (default: the model's ``default_output``, ``u2`` for Kelvin).
    initial_state : {"rest", "equilibrium", "periodic"} or sequence or mapping
        ``rest`` (zero state), ``equilibrium`` (static equilibrium under the first load
        sample), ``periodic`` (periodic steady state: the samples cover one period), or the
        state itself as numbers in the order of ``model.states`` or as ``{state: value}``.
    integrator : {"exact", "euler"}
        ``exact`` first-order-hold discretization, or the paper's explicit Euler scheme.
    scale : float
        The paper's output scale factor C (the output is multiplied by it).
    period : float, optional
        Period in s for ``initial_state="periodic"``; default: span + one step.
    all_states : bool
        Return every state (N, n) instead of the observed one.

    Returns
    -------
    ndarray
        The observed displacement ``scale * y(t)`` of shape (N,), or all states (N, n).
    """
    grid, f = _prepare(model, t, load)
    if all_states:
        x = propagate(type(model), model.values, grid, f, initial_state=initial_state,
                      integrator=integrator, sensitivities=False, period=period)
        return scale * x
    y = observed(type(model), model.values, grid, f, [model.output_index(observe)],
                 initial_state=initial_state, integrator=integrator, sensitivities=False,
                 period=period)
    return scale * y[:, 0]


def simulate_sensitivities(
    model: Model,
    t: ArrayLike,
    load: ArrayLike,
    *,
    observe: str | None = None,
    initial_state: InitialState = "rest",
    integrator: Integrator = "exact",
    period: float | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Observed output and its exact parameter sensitivities.

    Returns
    -------
    y : ndarray, shape (N,)
    dy : ndarray, shape (N, p)
        ``dy[:, i] = dy/dtheta_i`` in the model's canonical parameter order.
    """
    grid, f = _prepare(model, t, load)
    n = model.n_states()
    k = model.output_index(observe)
    p = len(model.param_names())
    y = observed(type(model), model.values, grid, f, [k] + [n * (i + 1) + k for i in range(p)],
                 initial_state=initial_state, integrator=integrator, sensitivities=True,
                 period=period)
    return y[:, 0], y[:, 1:]
