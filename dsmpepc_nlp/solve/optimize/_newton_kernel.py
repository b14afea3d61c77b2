"""The box QP of the trust-region Newton step in compiled code (numba): the kernel alone.

A transcription of :func:`.newton.box_qp_reference` (the definition, numpy)
with the same face tables and choice, held to it by a property test
(``tests/test_newton.py``). On 4 variables numpy's per-call overhead (some twenty small array
operations per step) cost more than the arithmetic; compiled, one step's QP is a few
microseconds. Imported only through :func:`dsmpepc_nlp.solve.optimize.newton.box_qp` (numba's cache
folder is set on import; see :func:`dsmpepc_nlp.core.compile_cache.import_numba_module`).
"""

from __future__ import annotations

import numba
import numpy as np

from . import trust_region
from .trust_region import ETA, SHRINK


@numba.njit(cache=True, fastmath=False, error_model="numpy")
def _inverse_if_definite(A, tol, out):  # pragma: no cover
    """Write ``A``'s inverse into ``out`` and return True when ``A`` (symmetric) is positive
    definite with every Cholesky pivot above ``tol``; False otherwise. No allocation."""
    n = A.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        pivot = A[j, j]
        for k in range(j):
            pivot -= L[j, k] * L[j, k]
        if not pivot > tol:
            return False
        L[j, j] = np.sqrt(pivot)
        for i in range(j + 1, n):
            value = A[i, j]
            for k in range(j):
                value -= L[i, k] * L[j, k]
            L[i, j] = value / L[j, j]
    for c in range(n):          # solve L L' x = e_c column by column
        y = np.zeros(n)
        for i in range(n):
            value = 1.0 if i == c else 0.0
            for k in range(i):
                value -= L[i, k] * y[k]
            y[i] = value / L[i, i]
        for i in range(n - 1, -1, -1):
            value = y[i]
            for k in range(i + 1, n):
                value -= L[k, i] * out[k, c]
            out[i, c] = value / L[i, i]
    return True


@numba.njit(cache=True, fastmath=False, error_model="numpy")
def box_qp_faces(g, H, lower, upper, at_low, at_up, subset, both, pad):  # pragma: no cover
    """Global minimiser of ``g.d + d'Hd/2`` over the box, from the face tables of
    :func:`dsmpepc_nlp.solve.optimize.newton._faces` (the non-convex branch of the reference).

    A reduced Hessian counts as definite when its Cholesky pivots exceed ``1e-10`` of the
    Hessian's scale (the reference asks the same of its smallest eigenvalue; they differ only
    on nearly singular blocks, where both choices give a minimiser on a lower face).
    """
    n = g.size
    n_sets = both.shape[0]
    scale = max(1.0, np.max(np.abs(H)))
    positive = np.zeros(n_sets, dtype=np.bool_)
    inverse = np.zeros((n_sets, n, n))
    reduced = np.empty((n, n))
    block = np.empty((n, n))
    for s in range(n_sets):
        for i in range(n):
            for j in range(n):
                reduced[i, j] = (H[i, j] if both[s, i, j] else 0.0) + pad[s, i, j]
        if _inverse_if_definite(reduced, 1e-10 * scale, block):
            positive[s] = True
            for i in range(n):
                for j in range(n):
                    inverse[s, i, j] = block[i, j] if both[s, i, j] else 0.0
    best, best_value = -1, np.inf
    best_d = np.zeros(n)
    d = np.empty(n)
    fixed = np.empty(n)
    for f in range(subset.size):
        s = subset[f]
        if not positive[s]:
            continue
        for i in range(n):
            fixed[i] = lower[i] if at_low[f, i] else (upper[i] if at_up[f, i] else 0.0)
        feasible = True
        for i in range(n):
            value = fixed[i]
            for j in range(n):
                rhs = g[j]
                for k in range(n):
                    rhs += fixed[k] * H[k, j]
                value -= inverse[s, i, j] * rhs
            d[i] = value
            slack = 1e-9 * (1.0 + abs(upper[i] - lower[i]))
            if d[i] < lower[i] - slack or d[i] > upper[i] + slack:
                feasible = False
        if not feasible:
            continue
        value = 0.0
        for i in range(n):
            d[i] = min(max(d[i], lower[i]), upper[i])
        for i in range(n):
            value += d[i] * g[i]
            for j in range(n):
                value += 0.5 * d[i] * H[i, j] * d[j]
        if value < best_value:
            best, best_value = f, value
            best_d[:] = d
    if best < 0:
        return np.zeros(n)
    return best_d


# --- the whole trust-region loop, calling the compiled cost through function pointers -------

_jit = numba.njit(cache=False, fastmath=False, error_model="numpy")
_step_bounds = _jit(trust_region.step_bounds)
_model_decrease = _jit(trust_region.model_decrease)
_converged = _jit(trust_region.converged)
_next_radius = _jit(trust_region.next_radius)
_sr1_update = _jit(trust_region.sr1_update)
"""The trust-region step's arithmetic (:mod:`.trust_region`), the text the Python loop runs,
compiled."""


@numba.njit(cache=True, fastmath=False, error_model="numpy")
def _call(fn, buffers, z_in, z):  # pragma: no cover
    """One generated CasADi function at ``z``: ``buffers`` = (arg, res, iw, w) addresses."""
    z_in[:] = z
    return fn(buffers[0], buffers[1], buffers[2], buffers[3], 0) == 0


@numba.njit(cache=True, fastmath=False, error_model="numpy")
def _box_qp(g, H, lower, upper, at_low, at_up, subset, both, pad):  # pragma: no cover
    """``newton.box_qp``: the convex Newton step when it lies in the box, else the faces."""
    try:
        factor = np.linalg.cholesky(H)
        d = -np.linalg.solve(factor.T, np.linalg.solve(factor, g))
        inside = True
        for i in range(g.size):
            if not (d[i] >= lower[i] and d[i] <= upper[i]):
                inside = False
        if inside:
            return d
    except Exception:  # noqa: BLE001 (numba: not positive definite)
        pass
    return box_qp_faces(g, H, lower, upper, at_low, at_up, subset, both, pad)


@numba.njit(cache=True, fastmath=False, error_model="numpy")
def _finite(fx, g, H):  # pragma: no cover
    return np.isfinite(fx) and np.all(np.isfinite(g)) and np.all(np.isfinite(H))


@numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy")
def minimize_sr1(f_fn, f_buf, f_in, f_out, g_fn, g_buf, g_in, g_out, g_grad,  # pragma: no cover
                 h_fn, h_buf, h_in, h_out, h_grad, h_hess, x0, lower, upper, radius,
                 max_iter, tol, min_radius, at_low, at_up, subset, both, pad):
    """``newton.minimize`` with ``newton.sr1``'s Hessian, evaluation for evaluation, on the
    compiled F, G, H (``*_fn`` ctypes function pointers, ``*_buf`` their work addresses,
    ``*_in`` the z buffer they read, ``*_out``/``*_grad``/``*_hess`` the buffers they write).

    Returns ``(x, fun, nit, status, nfev, nhev)``; status 0 converged, 1 max_iter,
    2 small_radius, 3 non-finite.
    """
    n = x0.size
    span = np.empty(n)
    x = np.empty(n)
    for i in range(n):
        span[i] = upper[i] - lower[i] if upper[i] > lower[i] else 1.0
        x[i] = min(max(x0[i], lower[i]), upper[i])
    ok = _call(h_fn, h_buf, h_in, x)
    fx = h_out[0] if ok else np.nan
    g = h_grad.copy()
    H = h_hess.reshape((n, n)).T.copy()      # CasADi is column-major (H is symmetric)
    nfev, nhev = 0, 1
    if not _finite(fx, g, H):
        return x, fx, 0, 3, nfev, nhev
    # sr1's state: the last point the derivatives were taken at (accepted or not).
    z_prev, g_prev, H_prev = x.copy(), g.copy(), H.copy()
    status, nit = 1, 0
    while nit < max_iter:
        nit += 1
        step_low, step_up = _step_bounds(x, lower, upper, radius, span)
        d = _box_qp(g, H, step_low, step_up, at_low, at_up, subset, both, pad)
        predicted, on_edge = _model_decrease(g, H, d, radius, span)
        if _converged(predicted, on_edge, tol):
            status = 0
            break
        trial = x + d
        f_trial = f_out[0] if _call(f_fn, f_buf, f_in, trial) else np.nan
        nfev += 1
        ratio, radius = _next_radius(fx, f_trial, predicted, d, span, radius, on_edge)
        if ratio > ETA:
            f_new = g_out[0] if _call(g_fn, g_buf, g_in, trial) else np.nan
            g_new = g_grad.copy()
            H_new = _sr1_update(H_prev, trial - z_prev, g_new - g_prev)
            z_prev, g_prev, H_prev = trial.copy(), g_new, H_new
            nhev += 1
            if _finite(f_new, g_new, H_new):
                x, fx, g, H = trial, f_new, g_new, H_new.copy()
            else:
                radius *= SHRINK
        if radius < min_radius:
            status = 2
            break
    return x, fx, nit, status, nfev, nhev
