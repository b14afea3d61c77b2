"""One trust-region step's arithmetic, written once for both Newton loops.

The Python loop (:func:`.newton.minimize`, the definition) runs these functions on numpy arrays;
the compiled loop (:func:`._newton_kernel.minimize_sr1`) has numba compile the same functions.
Only what differs between the loops stays in each: how they call the objective and its
derivatives (Python callables; the generated C through function pointers) and the box QP.
"""

from __future__ import annotations

import numpy as np

ETA = 0.05
"""Smallest ratio of actual to predicted decrease for a step to be accepted."""
SHRINK, GROW = 0.25, 4.0
"""Trust radius factors after a poor (ratio < 0.25) and a very good (ratio > 0.75) step."""


def step_bounds(x, lower, upper, radius, span):
    """The step's box: the bounds' box around ``x`` intersected with the trust region (the max
    norm of the step over each variable's range ``span`` at most ``radius``)."""
    return np.maximum(lower - x, -radius * span), np.minimum(upper - x, radius * span)


def model_decrease(g, H, d, radius, span):
    """The decrease the quadratic model predicts for step ``d``, and whether ``d`` reaches the
    trust region's edge in some variable."""
    predicted = -(g @ d + 0.5 * d @ H @ d)
    on_edge = np.any(np.abs(np.abs(d) - radius * span) < 1e-9 * span)
    return predicted, on_edge


def converged(predicted, on_edge, tol) -> bool:
    """Converged: a step inside the trust region (or a negligible one on its edge) predicts a
    decrease below ``tol``."""
    return predicted <= tol and (not on_edge or predicted <= 1e-3 * tol)


def next_radius(fx, f_trial, predicted, d, span, radius, on_edge):
    """The ratio of actual to predicted decrease and the trust radius after the step: shrunk
    to a quarter of the step after a poor ratio, grown fourfold (to the whole range at most)
    after a very good step that reached the edge."""
    ratio = (fx - f_trial) / predicted if np.isfinite(f_trial) else -np.inf
    if ratio < 0.25:
        radius = SHRINK * max(np.max(np.abs(d) / span), 1e-12)
    elif ratio > 0.75 and on_edge:
        radius = min(GROW * radius, 1.0)
    return ratio, radius


def sr1_update(H, step, change):
    """The symmetric rank-one update of the Hessian ``H`` from a ``step`` and the gradient's
    ``change`` over it (a new array; unchanged when the update's denominator is too small)."""
    out = H.copy()
    residual = change - out @ step
    denominator = residual @ step
    if abs(denominator) > 1e-8 * np.linalg.norm(step) * np.linalg.norm(residual):
        out += np.outer(residual, residual) / denominator
    return out


__all__ = ["ETA", "GROW", "SHRINK", "converged", "model_decrease", "next_radius", "step_bounds",
           "sr1_update"]
