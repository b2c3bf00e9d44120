"""Reference methods the benchmark compares pumpid against (written for the benchmark).

Both run the model through scipy.integrate.solve_ivp (an adaptive Runge-Kutta solver) with the
load interpolated linearly between samples -- the same continuous model that pumpid's exact
first-order-hold discretization solves, so the answers are comparable.

* :func:`lm_fd_fit`: scipy.optimize.least_squares(method="lm") with its default
  finite-difference Jacobian: the "obvious scipy" way.
* :func:`lsq_lsim_fit`: what a careful scipy user writes by hand: least_squares(method="lm")
  in log-parameters with the exact sensitivity Jacobian, the model and its sensitivities
  simulated together as one augmented linear system by scipy.signal.lsim (first-order hold,
  the same discretization pumpid uses).
* :func:`newton_fd_fit`: the paper's inverse-optimization method: Newton-Raphson on the
  gradient of E = 0.5 ||y(theta) - d||^2 with first and second derivatives of the model
  output (including the mixed ones) by central differences at 0.1 % of each parameter,
  i.e. 1 + 2p + 2p(p-1) simulations per iteration, and the stop test ||dtheta||/||theta0||.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.integrate
import scipy.optimize
import scipy.signal
from numpy.typing import NDArray

from pumpid import Model

Array = NDArray[np.float64]


@dataclass
class BaselineRun:
    """Outcome of one baseline fit."""

    theta: Array
    simulations: int
    iterations: int
    ok: bool


def ivp_output(model: Model, t: Array, load: Array, k_obs: int, rtol: float = 1e-8,
               atol: float = 1e-10) -> Array:
    """Observed state at the sample times, from rest, by solve_ivp (RK45, rtol 1e-8)."""
    a, b = model.matrices()

    def rhs(time: float, x: Array) -> Array:
        return a @ x + b * np.interp(time, t, load)

    sol = scipy.integrate.solve_ivp(rhs, (t[0], t[-1]), np.zeros(a.shape[0]), method="RK45",
                                    t_eval=t, rtol=rtol, atol=atol)
    if not sol.success:
        return np.full(t.size, np.nan)
    return sol.y[k_obs]


def _simulator(cls: type[Model], t: Array, load: Array, k_obs: int
               ) -> tuple[Callable[[Array], Array], list[int]]:
    calls = [0]

    def run(theta: Array) -> Array:
        calls[0] += 1
        try:
            model = cls.from_values(theta)
        except ValueError:
            return np.full(t.size, np.nan)
        return ivp_output(model, t, load, k_obs)

    return run, calls


def lm_fd_fit(cls: type[Model], t: Array, load: Array, data: Array, theta0: Array,
              k_obs: int) -> BaselineRun:
    """least_squares(method='lm'), finite-difference Jacobian, over solve_ivp.

    The forward-difference step is 1e-5 relative: scipy's default (~1.5e-8) is below the
    solver's own error (rtol 1e-8), which makes the Jacobian noise and the fit stop early.
    """
    run, calls = _simulator(cls, t, load, k_obs)
    penalty = 1e3 * float(np.ptp(data))

    def residual(theta: Array) -> Array:
        r = run(theta) - data
        return r if np.all(np.isfinite(r)) else np.full(data.size, penalty)

    sol = scipy.optimize.least_squares(residual, theta0, method="lm", x_scale="jac",
                                       diff_step=1e-5, xtol=1e-10, ftol=1e-10, gtol=1e-10)
    return BaselineRun(sol.x, calls[0], int(sol.nfev), bool(sol.status > 0))


def newton_fd_fit(cls: type[Model], t: Array, load: Array, data: Array, theta0: Array,
                  k_obs: int, rel_step: float = 1e-3, eps0: float = 1e-6,
                  max_iter: int = 20) -> BaselineRun:
    """The paper's Newton-Raphson with central-difference first and second derivatives.

    ``eps0`` is 1e-6, not pumpid's 1e-10: over an adaptive solver (rtol 1e-8) the
    finite-difference Hessian is too noisy for the step to ever fall below 1e-10 (measured:
    50 iterations, 1650 simulations, no stop).
    """
    run, calls = _simulator(cls, t, load, k_obs)
    theta = np.array(theta0, dtype=float)
    p = theta.size
    norm0 = float(np.linalg.norm(theta0))
    for it in range(1, max_iter + 1):
        h = rel_step * np.abs(theta)
        base = run(theta)
        plus = [run(theta + h[i] * np.eye(p)[i]) for i in range(p)]
        minus = [run(theta - h[i] * np.eye(p)[i]) for i in range(p)]
        d1 = np.column_stack([(plus[i] - minus[i]) / (2 * h[i]) for i in range(p)])
        d2 = np.empty((t.size, p, p))
        for i in range(p):
            d2[:, i, i] = (plus[i] - 2 * base + minus[i]) / h[i] ** 2
            for j in range(i + 1, p):
                ei, ej = h[i] * np.eye(p)[i], h[j] * np.eye(p)[j]
                mixed = (run(theta + ei + ej) + run(theta - ei - ej) - run(theta - ei + ej)
                         - run(theta + ei - ej)) / (4 * h[i] * h[j])
                d2[:, i, j] = d2[:, j, i] = mixed
        r = base - data
        grad = d1.T @ r
        hess = d1.T @ d1 + np.einsum("n,nij->ij", r, d2)
        if not (np.all(np.isfinite(grad)) and np.all(np.isfinite(hess))):
            return BaselineRun(theta, calls[0], it, False)
        step = np.linalg.solve(hess, -grad)
        theta = theta + step
        if np.any(theta <= 0):
            return BaselineRun(theta, calls[0], it, False)
        if np.linalg.norm(step) / norm0 <= eps0:
            return BaselineRun(theta, calls[0], it, True)
    return BaselineRun(theta, calls[0], max_iter, False)


def lsq_lsim_fit(cls: type[Model], t: Array, load: Array, data: Array, theta0: Array,
                 k_obs: int) -> BaselineRun:
    """least_squares(method='lm') with the exact Jacobian, both from one scipy.signal.lsim run.

    The states x and their sensitivities s_i = dx/dtheta_i obey
    x' = A x + B g, s_i' = A s_i + (dA/dtheta_i) x + (dB/dtheta_i) g: one linear system of
    n (p + 1) states, simulated once per parameter vector. Log-parameters keep the
    parameters positive and the steps scale-free.
    """
    p = theta0.size
    calls = [0]
    memo: dict[bytes, tuple[Array, Array]] = {}

    def run(z: Array) -> tuple[Array, Array]:
        key = z.tobytes()
        if key not in memo:
            memo.clear()
            calls[0] += 1
            theta = np.exp(z)
            try:
                model = cls.from_values(theta)
            except ValueError:
                memo[key] = (np.full(t.size, np.nan), np.full((t.size, p), np.nan))
                return memo[key]
            a, b = model.matrices()
            da, db = model.matrix_derivatives()
            n = a.shape[0]
            big = np.zeros((n * (p + 1), n * (p + 1)))
            rhs = np.zeros(n * (p + 1))
            big[:n, :n] = a
            rhs[:n] = b
            for i in range(p):
                rows = slice(n * (i + 1), n * (i + 2))
                big[rows, rows] = a
                big[rows, :n] = da[i]
                rhs[rows] = db[i]
            out = np.zeros((p + 1, n * (p + 1)))
            out[0, k_obs] = 1.0
            for i in range(p):
                out[i + 1, n * (i + 1) + k_obs] = theta[i]  # d/dlog(theta) = theta d/dtheta
            _, y, _ = scipy.signal.lsim((big, rhs[:, None], out, np.zeros((p + 1, 1))),
                                        load, t)
            memo[key] = (y[:, 0], y[:, 1:])
        return memo[key]

    def residual(z: Array) -> Array:
        y = run(z)[0]
        r = y - data
        return r if np.all(np.isfinite(r)) else np.full(data.size, 1e3 * float(np.ptp(data)))

    def jacobian(z: Array) -> Array:
        jac = run(z)[1]
        return jac if np.all(np.isfinite(jac)) else np.zeros_like(jac)

    sol = scipy.optimize.least_squares(residual, np.log(theta0), jac=jacobian, method="lm",
                                       xtol=1e-10, ftol=1e-10, gtol=1e-10)
    return BaselineRun(np.exp(sol.x), calls[0], int(sol.nfev), bool(sol.status > 0))
