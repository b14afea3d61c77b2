"""The exact cost of many trajectories, compiled: survivability, the assembly of the term
table's terms (``costs.assemble``, the formulas from :mod:`.terms`) and the batch entry points
:func:`exact_costs` and :func:`exact_costs_serial` (both cores, or the calling thread)."""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from ....core.terms import EndQuantities, StepQuantities
from .geometry import (
    culled_distance,
    descent,
    heading_error,
    inverse_ttg,
    nf_value,
    object_pose,
    place,
    static_pose,
    terminal_inverse_ttc,
)
from .law import rollout
from .layout import (
    ANTICIPATORY,
    CULL_FLOOR,
    CULL_SIGMAS,
    DT,
    FRAGILE_COLUMN,
    HAS_GRID,
    INV_TTC_TERMINAL_COLUMN,
    INV_TTG_COLUMN,
    MIN_DISTANCE_COLUMN,
    N_TERMS,
    ON_FIRST_TERM,
    OUT,
    S_TTC,
    SIGMA_DYNAMIC,
    SIGMA_DYNAMIC_GROWTH,
    SIGMA_STATIC,
    STEPWISE,
    TERMINAL,
    TOTAL_COLUMN,
    W_FIRST_TERM,
    A,
    cost_numbers,
    jit,
)
from .terms import END_TERMS, STEP_TERMS


@jit
def pairwise(a, n):
    """numpy's pairwise summation of ``a[:n]`` (the order ``np.sum`` adds in)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[i]
        return res
    if n <= 128:
        r = a[:8].copy()
        i = 8
        while i < n - (n % 8):
            for j in range(8):
                r[j] += a[i + j]
            i += 8
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
        while i < n:
            res += a[i]
            i += 1
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return pairwise(a, n2) + pairwise(a[n2:], n - n2)


@jit
def collision_probability(d, inv, sigma, p):
    """``costs.collision_probability`` of one pose and object."""
    d = max(d, 0.0)
    pc = math.exp(-(d * d) / (sigma * sigma))
    if p[ANTICIPATORY] != 0.0:
        s = p[S_TTC]
        pc = pc * (1.0 - p[A] * math.exp(-(inv * inv) / (s * s)))
    return pc


@jit
def survival_along(p, fp, sdf, pred, radii, velocities, starts, poses, vs, survival, pts):
    """Survivability at every pose; returns the smallest distance to any kept object.

    An object at ``d >= cull_sigmas * sigma`` has ``1 - P_c == 1.0`` exactly (see
    ``cycle.CULL_SIGMAS``): its factor is skipped, which changes no bit.
    """
    n_steps = vs.shape[0]
    far_static = p[CULL_SIGMAS] * p[SIGMA_STATIC]
    nearest = math.inf
    alive = 1.0
    for k in range(n_steps + 1):
        sigma = p[SIGMA_DYNAMIC] + p[SIGMA_DYNAMIC_GROWTH] * (k * p[DT])  # costs.dynamic_sigma
        far_dynamic = p[CULL_SIGMAS] * sigma
        ttc_below = far_dynamic if p[ANTICIPATORY] != 0.0 else -math.inf
        cos_h, sin_h = place(fp, poses[k, 0], poses[k, 1], poses[k, 2], pts)
        speed = vs[min(k, n_steps - 1)]
        q = 1.0
        if p[HAS_GRID] != 0.0:
            d, inv = static_pose(sdf, p, fp, pts, cos_h, sin_h, speed)
            nearest = min(nearest, d)
            if d < far_static:
                q *= 1.0 - collision_probability(d, inv, p[SIGMA_STATIC], p)
        centres = pred[k]
        for o in range(starts.shape[0] - 1):
            d, inv = object_pose(fp, pts, cos_h, sin_h, speed, centres, radii, velocities,
                                  starts[o], starts[o + 1], ttc_below,
                                  max(far_dynamic, nearest))
            nearest = min(nearest, d)
            if d < far_dynamic:
                q *= 1.0 - collision_probability(d, inv, sigma, p)
        alive = q if k == 0 else alive * q
        survival[k] = alive
    return nearest


@jit
def assemble(p, c, nf, poses, vs, omegas, survival, terminal_inv, scratch, out):
    """``costs.assemble``: every term of the table (:mod:`.terms`), each weighted or switched
    off, and the total. ``scratch`` has a row per term: a step term's values per step (summed
    as numpy sums them), an end term's value in its first column."""
    n_steps = vs.shape[0]
    dt = p[DT]
    nf_prev = nf_value(nf, p, poses[0, 0], poses[0, 1])
    for k in range(1, n_steps + 1):
        nf_k = nf_value(nf, p, poses[k, 0], poses[k, 1])
        STEP_TERMS(StepQuantities(survival[k], nf_k - nf_prev, vs[k - 1], omegas[k - 1], dt),
                   c, scratch, k - 1)
        nf_prev = nf_k
    final = survival[n_steps]
    x, y, phi = poses[n_steps, 0], poses[n_steps, 1], poses[n_steps, 2]
    ex, ey = descent(nf, p, x, y)
    inv_ttg = inverse_ttg(p, x, y, phi, vs[n_steps - 1])
    END_TERMS(EndQuantities(final, heading_error(ex, ey, phi), inv_ttg, terminal_inv), c,
              scratch, 0)
    total = 0.0
    for t in range(N_TERMS):
        raw = pairwise(scratch[t], n_steps) if STEPWISE[t] else scratch[t, 0]
        column = TOTAL_COLUMN + 1 + t
        out[column] = p[W_FIRST_TERM + t] * raw if p[ON_FIRST_TERM + t] != 0.0 else 0.0 * final
        total = out[column] if t == 0 else total + out[column]
    out[TOTAL_COLUMN] = total
    out[INV_TTG_COLUMN] = inv_ttg
    out[INV_TTC_TERMINAL_COLUMN] = terminal_inv


@jit
def rows(first, stride, z, p, c, fp, sdf, nf, pred, radii, velocities, starts, culled_pred,
          culled_radii, end_centres, end_radii, end_velocities, poses, vs, omegas, targets,
          survival, out, given):
    """Rows ``first, first + stride, ...`` of :func:`exact_costs`."""
    n, n_steps = z.shape[0], vs.shape[1]
    scratch = np.empty((N_TERMS, n_steps))
    pts = np.empty((fp.shape[0], 2))
    for i in range(first, n, stride):
        fragile = False
        if not given:
            fragile = rollout(z[i], p, n_steps, poses[i], vs[i], omegas[i], targets[i])
        nearest = survival_along(p, fp, sdf, pred, radii, velocities, starts, poses[i], vs[i],
                            survival[i], pts)
        if culled_radii.shape[0] and not nearest <= p[CULL_FLOOR]:
            nearest = min(nearest, culled_distance(fp, poses[i], culled_pred, culled_radii,
                                                    pts))
        end = poses[i, n_steps]
        terminal_inv = 0.0
        if p[TERMINAL] != 0.0:
            terminal_inv = terminal_inverse_ttc(p, fp, sdf, end_centres, end_radii,
                                                 end_velocities, end[0], end[1], end[2], pts)
        assemble(p, c, nf, poses[i], vs[i], omegas[i], survival[i], terminal_inv, scratch, out[i])
        out[i, MIN_DISTANCE_COLUMN] = nearest
        out[i, FRAGILE_COLUMN] = 1.0 if fragile else 0.0


@numba.njit(parallel=True, cache=True, nogil=True, fastmath=False, error_model="numpy")
def exact_costs(z, p, c, fp, sdf, nf, pred, radii, velocities, starts, culled_pred, culled_radii,
                end_centres, end_radii, end_velocities, poses, vs, omegas, targets, survival,
                out, given, threads):
    """Roll out and cost every row of ``z`` (n, 4) on every core; results go into the outputs.

    With ``given`` the rollouts already in ``poses``, ``vs``, ``omegas`` are costed instead.

    ``p`` is the parameter vector, ``c`` the cost's numbers (``layout.cost_numbers``);
    ``pred``/``radii``/``velocities`` the kept circles (objects contiguous, object ``o`` is
    ``starts[o]:starts[o+1]``); ``culled_*`` the circles beyond reach (for the smallest
    distance only); ``end_*`` every circle at the horizon's end (terminal time to collision).
    Outputs: ``poses`` (n, N+1, 3), ``vs``, ``omegas`` (n, N), ``targets`` (n, 3),
    ``survival`` (n, N+1), ``out`` (n, len(OUT)).
    """
    # One interleaved block of rows per thread (``threads``: numba's thread count, read by
    # the caller; read here it would keep the kernel out of the disk cache): the thread pool
    # hands each thread an equal run of blocks, so equal blocks keep the threads equally busy
    # (256 blocks left one thread with 256 rows and the other 144 in a 400-row batch).
    blocks = max(min(z.shape[0], threads), 1)
    for b in prange(blocks):
        rows(b, blocks, z, p, c, fp, sdf, nf, pred, radii, velocities, starts, culled_pred,
              culled_radii, end_centres, end_radii, end_velocities, poses, vs, omegas, targets,
              survival, out, given)


@numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy")
def exact_costs_serial(z, p, c, fp, sdf, nf, pred, radii, velocities, starts, culled_pred,
                       culled_radii, end_centres, end_radii, end_velocities, poses, vs, omegas,
                       targets, survival, out, given, threads):
    """:func:`exact_costs` on the calling thread (``threads`` unused: one signature for both):
    for small batches, where waking the thread pool costs more than it saves."""
    rows(0, 1, z, p, c, fp, sdf, nf, pred, radii, velocities, starts, culled_pred, culled_radii,
          end_centres, end_radii, end_velocities, poses, vs, omegas, targets, survival, out,
          given)


__all__ = ["OUT", "cost_numbers", "exact_costs", "exact_costs_serial"]
