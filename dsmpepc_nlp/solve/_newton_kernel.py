"""The box QP of the trust-region Newton step in compiled code (numba): the kernel alone.

A transcription of :func:`dsmpepc_nlp.solve.newton.box_qp_reference` (the definition, numpy)
with the same face tables and choice, held to it by a property test
(``tests/test_newton.py``). On 4 variables numpy's per-call overhead (some twenty small array
operations per step) cost more than the arithmetic; compiled, one step's QP is a few
microseconds. Imported only through :func:`dsmpepc_nlp.solve.newton.box_qp` (numba's cache
folder is set on import; see :func:`dsmpepc_nlp.solve.exact.import_numba_module`).
"""

from __future__ import annotations

import numba
import numpy as np


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
    :func:`dsmpepc_nlp.solve.newton._faces` (the non-convex branch of the reference).

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
