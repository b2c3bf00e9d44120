"""Sampled responses of a discretized linear system, evaluated in the frequency domain.

On a uniform grid the one-step recursion ``x[k] = Phi x[k-1] + G0 F[k-1] + G1 F[k]`` is a
linear time-invariant filter, so its response is a convolution and its discrete Fourier
transform is a rational function of ``z = exp(2 pi i l / L)``:

* periodic steady state over the N samples (the samples cover one period):
  ``X(z) = (zI - Phi)^-1 (G0 + z G1) F(z)`` on the N-point grid, exactly;
* any other initial state ``X0`` whose free response has decayed over the record
  (:func:`has_decayed`): the periodic solution on a grid of ``L >= N`` samples plus the free
  response from its mismatch with ``X0`` (:func:`decayed_response`), exact on the N samples;
* the other starts: the first N samples of a circular convolution of length ``L >= 2N``
  with the *truncated* kernels ``Phi^m G`` (m < N), whose transforms are
  ``z (zI - Phi)^-1 (I - z^-N Phi^N) G``; the free response is the kernel of
  ``v = X0 - G1 F[0]``. Only ``Phi^N`` (or ``Phi^L``) is needed, not the N powers.

The sensitivity system (states and their parameter derivatives) is block lower-triangular:
``Phi`` on the diagonal and the derivatives ``dPhi_i`` in the first block column. With
``R = (zI - Phi)^-1`` its transfer functions are ``c R q0`` for the states and
``c R dPhi_i R q0 + c R q_i`` for the sensitivities. Writing ``R = adj(wI - Psi) / det(wI - Psi)``
with ``w = z - 1`` and ``Psi = Phi - I`` turns every one of them into a ratio of polynomials
in ``w`` of degree at most ``2n`` (n = the model's handful of states), whose coefficients cost
O(n^3 p) per parameter set; the L/2 + 1 frequencies then cost one small matrix product and a
few elementwise operations, and one inverse real FFT returns to time.

Why by hand: no library evaluates the transfer functions of a *batch* of small state-space
systems and their parameter derivatives on a DFT grid (``scipy.signal`` works one system at a
time and without derivatives). Why ``w = z - 1``: ``Phi`` has its eigenvalues near 1 when the
step is short, and the polynomials in ``z`` would then cancel catastrophically at low
frequencies; in ``w`` the roots are ``exp(s dt) - 1`` (about ``s dt``) and the low frequencies
are evaluated at full precision.
"""

from __future__ import annotations

import functools
import threading

import numpy as np
import scipy.fft
from numpy.typing import NDArray

Array = NDArray[np.float64]
Complex = NDArray[np.complex128]


def charpoly_adjugate(psi: Array) -> tuple[Array, Array]:
    """Characteristic polynomial and adjugate of ``wI - psi`` as polynomials in ``w``.

    Faddeev-LeVerrier recursion, batched over the leading dimensions; it is exact algebra
    and well conditioned for the n <= 4 states of pumpid's models.

    Parameters
    ----------
    psi : ndarray, shape (..., n, n)

    Returns
    -------
    den : ndarray, shape (..., n + 1)
        ``det(wI - psi) = sum_j den[..., j] w^j`` (ascending powers; ``den[..., n] = 1``).
    adj : ndarray, shape (..., n, n, n)
        ``adj(wI - psi) = sum_j adj[..., j, :, :] w^j``.
    """
    n = psi.shape[-1]
    batch = psi.shape[:-2]
    den = np.empty((*batch, n + 1))
    den[..., n] = 1.0
    adj = np.empty((*batch, n, n, n))
    eye = np.eye(n)
    adj[..., n - 1, :, :] = eye
    bk = eye
    # M_1 = I, c_(n-k) = -tr(psi M_k) / k, M_(k+1) = psi M_k + c_(n-k) I: one product per k.
    for k in range(1, n + 1):
        prod = psi @ bk
        coef = -np.trace(prod, axis1=-2, axis2=-1) / k
        den[..., n - k] = coef
        if k < n:
            bk = prod + coef[..., None, None] * eye
            adj[..., n - k - 1, :, :] = bk
    return den, adj


@functools.lru_cache(maxsize=8)
def _power_sums(n: int) -> Array:
    """0/1 matrix (n*n, 2n - 1) adding coefficient (j, l) of a product to power j + l."""
    out = np.zeros((n * n, 2 * n - 1))
    for j in range(n):
        for k in range(n):
            out[j * n + k, j + k] = 1.0
    out.flags.writeable = False
    return out


def _times_poly(den: Array, n_out: int) -> Array:
    """Matrix (..., n, n_out) multiplying a degree n - 1 polynomial (row) by ``den``."""
    n = den.shape[-1] - 1
    mat = np.zeros((*den.shape[:-1], n, n_out))
    for j in range(n):
        mat[..., j, j:j + n + 1] = den
    return mat


def numerators(
    den: Array, adj: Array, dphi: Array, q: Array, states: NDArray[np.intp]
) -> Array:
    """Numerators over ``den^2`` of the observed states and sensitivities for forcing q.

    Parameters
    ----------
    den, adj : from :func:`charpoly_adjugate` (shapes (..., n + 1) and (..., n, n, n))
    dphi : ndarray, shape (..., P, n, n)
        The derivative blocks of the transition matrix (P may be 0).
    q : ndarray, shape (..., T, (P + 1) n)
        Augmented forcing vectors (state block, then one block per derivative).
    states : array of int, shape (r,)
        Observed state indices.

    Returns
    -------
    ndarray, shape (..., T, P + 1, r, 2n)
        Block 0: ``den e_x adj(w) q0`` (the state's transfer function times ``den^2``);
        block i: ``e_x adj dPhi_i adj q0 + den e_x adj q_i`` (the sensitivity's).
    """
    n = den.shape[-1] - 1
    n_par = dphi.shape[-3]
    rows = adj[..., :, states, :]  # (..., j, r, n): e_x adj, coefficient of w^j
    q0 = q[..., :n]
    # Everything over den^2: the direct terms e_x adj q (block 0 and the q_i) times den.
    qs = q.reshape(*q.shape[:-1], n_par + 1, n)
    direct = np.einsum("...jrx,...tix->...tirj", rows, qs)  # degree n - 1
    # Times den (degree n): one product with den's multiplication matrix.
    out = direct @ _times_poly(den, 2 * n)[..., None, None, :, :]  # degree 2n - 1
    if n_par:
        adj_q0 = np.einsum("...lxy,...ty->...tlx", adj, q0)  # (..., T, l, n)
        # dPhi_i adj q0 as (..., T, P, l, n): rows of adj_q0 times dPhi_i^T.
        moved = adj_q0[..., :, None, :, :] @ np.swapaxes(dphi, -1, -2)[..., None, :, :, :]
        both = np.einsum("...jrx,...tilx->...tirjl", rows, moved)  # powers j + l
        flat = both.reshape(*both.shape[:-2], n * n)
        out[..., 1:, :, : 2 * n - 1] += flat @ _power_sums(n)
    return out


@functools.lru_cache(maxsize=32)
def _grid(length: int, n_samples: int, degree: int) -> tuple[Array, Complex]:
    """Powers ``w^j`` (j <= degree) of ``w = z - 1`` on the rfft bins of a length-``length``
    DFT and ``z^-N``; cached because a fit evaluates the same grid many times.

    ``w`` is formed as ``(cos - 1) + i sin = -2 sin^2(a/2) + i sin(a)``, without the
    cancellation of ``z - 1`` at low frequencies.
    """
    angle = 2.0 * np.pi * np.arange(length // 2 + 1) / length
    w = -2.0 * np.sin(angle / 2) ** 2 + 1j * np.sin(angle)
    powers = np.empty((degree + 1, angle.size), dtype=complex)
    powers[0] = 1.0
    for j in range(1, degree + 1):
        powers[j] = powers[j - 1] * w
    shift = np.exp(-1j * angle * n_samples)
    # Real view with re/im interleaved along the frequencies: real coefficients times these
    # powers is then one real matrix product whose result is viewed back as complex
    # (numpy does not dispatch real @ complex to BLAS).
    powers = np.ascontiguousarray(powers).view(float)
    for arr in (powers, shift):
        arr.flags.writeable = False
    return powers, shift


_SPECTRUM_CACHE: dict[tuple[int, bytes], Complex] = {}


def _spectrum(load: Array, length: int) -> Complex:
    """rfft of the load, remembered for the last load: a fit simulates one record many times.

    Keyed on the samples themselves (not the array's identity), so a changed load is never
    served a stale spectrum; only single records are cached.
    """
    if load.ndim != 1:
        return scipy.fft.rfft(load, length)
    key = (length, load.tobytes())
    hit = _SPECTRUM_CACHE.get(key)
    if hit is None:
        hit = scipy.fft.rfft(load, length)
        hit.flags.writeable = False
        _SPECTRUM_CACHE.clear()
        _SPECTRUM_CACHE[key] = hit
    return hit


def _times_z(coef: Array) -> Array:
    """The polynomial (in w) times z = 1 + w: one degree more."""
    out = np.zeros((*coef.shape[:-1], coef.shape[-1] + 1))
    out[..., :-1] = coef
    out[..., 1:] += coef
    return out


def _evaluate(coef: Array, powers: Array, out: Array | None = None) -> Complex:
    """Polynomials (..., d) at the points whose powers are ``powers`` (d' >= d rows, as the
    interleaved real view of :func:`_grid`): complex values (..., K), optionally written
    into ``out`` (a real (M, 2K) buffer)."""
    d = coef.shape[-1]
    flat = coef.reshape(-1, d)
    values = np.matmul(flat, powers[:d], out=out).view(complex)
    return values.reshape(*coef.shape[:-1], powers.shape[1] // 2)


_WORK = threading.local()
#: Largest workspace kept between calls (bytes): single records reuse theirs, big batches
#: allocate per call (their cost is shared by many cards).
_WORK_MAX = 8 * 2**20


def _workspace(rows: int, cols: int) -> Array | None:
    """A per-thread scratch array (rows, cols), reused across calls of the same shape."""
    if rows * cols * 8 > _WORK_MAX:
        return None
    arrays = getattr(_WORK, "arrays", None)
    if arrays is None:
        arrays = _WORK.arrays = {}
    buf = arrays.get((rows, cols))
    if buf is None:
        if len(arrays) >= 8:
            arrays.clear()
        buf = arrays[(rows, cols)] = np.empty((rows, cols))
    return buf


#: Largest ``|Phi^L|`` (max row sum of the state block; L = :func:`short_length` of the record)
#: for which a non-periodic response is computed by :func:`decayed_response`.
DECAYED = 0.1


def short_length(n_samples: int) -> int:
    """Grid length L >= N of :func:`decayed_response`: the next fast FFT length."""
    return scipy.fft.next_fast_len(n_samples, real=True)


def has_decayed(phi_l: Array, n: int, limit: float = DECAYED) -> bool:
    """True when the free response has decayed enough over L steps for
    :func:`decayed_response`: ``|Phi^L|`` (max row sum of the state block, every system of
    the batch) at most ``limit``, which bounds its rounding amplification
    ``|(I - Phi^L)^-1|`` by ``1 / (1 - limit)``."""
    return bool(np.max(np.sum(np.abs(phi_l[..., :n, :n]), axis=-1), initial=0.0) <= limit)


def response(
    phi: Array,
    g0: Array,
    g1: Array,
    load: Array,
    n: int,
    states: NDArray[np.intp],
    *,
    periodic: bool,
    v: Array | None = None,
    phi_n: Array | None = None,
) -> Array:
    """Observed rows of the (augmented) recursion over N samples, by frequency domain.

    Parameters
    ----------
    phi, g0, g1 : ndarray, shapes (..., S, S), (..., S), (..., S)
        One step of the augmented system, S = (P + 1) n: ``Phi`` and the ``dPhi_i`` in the
        first block column (the structure :func:`pumpid.simulate._augment` builds).
    load : ndarray, shape (..., N)
        Samples of the input (broadcast against the system's batch).
    n : int
        Number of model states.
    states : array of int
        Observed state indices (the same in every block).
    periodic : bool
        Periodic steady state over the N samples (period N steps). Otherwise ``v`` (the
        augmented initial state minus ``G1 F[0]``) and ``phi_n`` (``Phi^N``) are required.

    Returns
    -------
    ndarray, shape (..., P + 1, r, N)
        Block b, state ``states[j]`` at every sample (time last, contiguous).
    """
    n_samples = load.shape[-1]
    size = phi.shape[-1]
    n_par = size // n - 1
    dphi = phi[..., n:, :n].reshape(*phi.shape[:-2], n_par, n, n)
    psi = phi[..., :n, :n] - np.eye(n)
    den, adj = charpoly_adjugate(psi)
    if periodic:
        length = n_samples
        vectors = np.stack([g0, g1], axis=-2)
    else:
        if v is None or phi_n is None:
            raise ValueError("a non-periodic response needs v and phi_n")
        length = scipy.fft.next_fast_len(2 * n_samples, real=True)
        vectors = np.stack(np.broadcast_arrays(g0, g1, v), axis=-2)  # v carries the load's batch
        vectors = np.concatenate([vectors, vectors @ np.swapaxes(phi_n, -1, -2)], axis=-2)
    powers, shift = _grid(length, n_samples, 2 * n + 1)
    spectrum = _spectrum(load, length)  # (..., K)
    # Forcing vectors and their spectra: G0 F + z G1 F (+ z v), and for a non-periodic start
    # the same through Phi^N times -z^-N. The factor z is folded into the numerators (z = 1 + w).
    num = np.moveaxis(numerators(den, adj, dphi, vectors, states), -4, 0)  # (T, ..., P+1, r, d)
    # Group the vectors by spectrum in coefficient space (z = 1 + w raises the degree by one):
    # G0 + z G1 goes with F, z v is free, and the same through Phi^N goes with -z^-N.
    groups = [_forced(num[0], num[1])]
    if not periodic:
        groups.append(_times_z(num[2]))
        groups.append(_forced(num[3], num[4]))
        groups.append(_times_z(num[5]))
    coef = np.stack(groups)
    values = _evaluate(coef, powers, _workspace(coef.size // coef.shape[-1], powers.shape[1]))
    spec = spectrum[..., None, None, :]  # (G, ..., P+1, r, K) times this
    if np.broadcast_shapes(values.shape[1:], spec.shape) == values.shape[1:]:
        # In place, in the workspace: a fit's evaluations then allocate little besides the
        # returned signals (fresh large temporaries cost page faults on every call).
        out = values[0]
        out *= spec
        if not periodic:
            out += values[1]
            tail = values[2]
            tail *= spec
            tail += values[3]
            tail *= shift
            out -= tail
    else:
        out = values[0] * spec
        if not periodic:
            out = out + values[1] - shift * (values[2] * spec + values[3])
    return _to_time(out, den, powers, length, n_samples)


def _forced(num_g0: Array, num_g1: Array) -> Array:
    """Numerator of ``G0 + z G1`` (the forcing that goes with F) from those of G0 and G1."""
    out = _times_z(num_g1)
    out[..., :-1] += num_g0
    return out


def _to_time(out: Array, den: Array, powers: Array, length: int, n_samples: int) -> Array:
    """Divide the numerators' values by ``den^2`` and return to the first N samples in time."""
    d_w = _evaluate(den, powers)  # (..., K)
    out *= (1.0 / (d_w * d_w))[..., None, None, :]  # one K-long division, then products
    return scipy.fft.irfft(out, length, axis=-1)[..., :n_samples]


@functools.lru_cache(maxsize=8)
def _half_weights(length: int) -> Array:
    """Weights of the rfft bins in a sum over all ``length`` DFT bins of a real signal's
    spectrum (the bins above the Nyquist one are the conjugates of those below)."""
    weights = np.full(length // 2 + 1, 2.0)
    weights[0] = 1.0
    if length % 2 == 0:
        weights[-1] = 1.0
    weights.flags.writeable = False
    return weights


def decayed_response(
    phi: Array, g0: Array, g1: Array, load: Array, n: int, states: NDArray[np.intp],
    v: Array, phi_l: Array,
) -> Array:
    """:func:`response` from a given start, on a grid of only L >= N samples.

    The first N samples of any solution differ from the L-periodic solution ``p`` (for the
    load padded to L samples) by a free response: ``x[k] = p[k] + Phi^k e`` with
    ``e = x[0] - p[0]``, since both obey the same recursion over the N - 1 steps inside the
    record. On the L-point grid ``sum_k Phi^k e z^-k`` (k < L) is ``z (zI - Phi)^-1 w`` with
    ``w = (I - Phi^L) e``, so the whole response is one periodic-style evaluation with the
    extra forcing ``z w``: half the grid of :func:`response`'s circular convolution. ``p[0]``
    is the mean of p's spectrum over the grid, a sum that needs the numerators' moments only.
    Computing e through p[0] amplifies rounding by ``|(I - Phi^L)^-1|``: use it where
    :func:`has_decayed` holds.

    Parameters
    ----------
    phi, g0, g1, load, n, states, v
        As for :func:`response`.
    phi_l : ndarray, shape (..., S, S)
        ``Phi^L`` with ``L = short_length(N)``.
    """
    size = phi.shape[-1]
    dphi = phi[..., n:, :n].reshape(*phi.shape[:-2], size // n - 1, n, n)
    den, adj = charpoly_adjugate(phi[..., :n, :n] - np.eye(n))
    n_samples = load.shape[-1]
    length = short_length(n_samples)
    powers, _ = _grid(length, n_samples, 2 * n + 1)
    spectrum = _spectrum(load, length)  # the load padded with zeros to L samples
    d_w = _evaluate(den, powers)  # (..., K)
    # p[0] for every state and sensitivity: (1/L) sum over all bins of num(w) F / den^2; the
    # polynomial in w is summed through its moments sum_k w_k^j F_k / den_k^2 (real parts).
    every = numerators(den, adj, dphi, np.stack([g0, g1], axis=-2), np.arange(n))
    forced = _forced(every[..., 0, :, :, :], every[..., 1, :, :, :])  # (..., P+1, n, d)
    g = np.conj(spectrum * _half_weights(length) / (d_w * d_w))
    # Re sum_k w_k^j g_k, as the interleaved real views' product (..., d).
    moments = g.view(float) @ powers[:forced.shape[-1]].T
    p0 = np.einsum("...ird,...d->...ir", forced, moments)  # the load's batch joins here
    p0 = p0.reshape(*p0.shape[:-2], p0.shape[-2] * n)
    x0 = v + g1 * load[..., :1]
    e = x0 - p0 / length
    w = e - (phi_l @ e[..., None])[..., 0]
    free = _times_z(numerators(den, adj, dphi, w[..., None, :], states)[..., 0, :, :, :])
    coef = np.stack(np.broadcast_arrays(forced[..., states, :], free))  # (2, ..., P+1, r, d)
    values = _evaluate(coef, powers, _workspace(coef.size // coef.shape[-1], powers.shape[1]))
    out = values[0]
    out *= spectrum[..., None, None, :]
    out += values[1]
    x = _to_time(out, den, powers, length, n_samples)
    # The start is known exactly; the transform returns it with rounding of the record's size.
    x[..., 0] = x0.reshape(*x0.shape[:-1], x0.shape[-1] // n, n)[..., states]
    return x
