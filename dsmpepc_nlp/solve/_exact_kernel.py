"""The exact cost of many trajectories in compiled code (numba, both cores): the kernel alone.

This module imports numba at its top and is imported only by :mod:`.exact` on first use (numba's
import alone takes a noticeable fraction of a second; the numpy path never pays it).

One source per formula: the kernel is a scalar transcription of the numpy reference
(:func:`~dsmpepc_nlp.core.control_law.rollout`, :func:`~dsmpepc_nlp.core.costs.exact_geometry`,
:func:`~dsmpepc_nlp.core.costs.assemble` with the exact smoothing,
``grid._interpolate``, ``OccupancyGrid.ray_distance`` and ``NavigationFunction.gradient``),
written operation for operation in the reference's order, and a property test
(``tests/test_exact_compiled.py``) holds every output to the reference to 1e-9 on random cycles
and edge cases. Sums over the steps follow numpy's pairwise summation so that the two paths
round alike. An edit to either form that the other does not follow fails that test.

The configuration enters as data (a vector named by :data:`.cycle.PARAMETERS`), so one compiled
kernel serves every configuration; :func:`.exact.kernel_cache_dir` keys the on-disk cache by
package version and this file's source hash.

Longer than the usual 400 lines: it is one transcription of the reference, function for
function, with a named index per parameter; split, the pairing with the reference would be
harder to read.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from .cycle import PARAMETERS

OUT = ("total", "progress", "action", "collision", "heading", "terminal", "min_distance",
       "inv_ttg", "inv_ttc_terminal", "fragile")
"""Columns of the kernel's per-trajectory output."""

FRAGILE_RHO = 1e-6
"""Target distance (m) below which the line of sight, and so the turn, rests on rounding."""
FRAGILE_ANGLE = 1e-6
"""Distance (rad) of theta or delta to +-pi within which wrapping may jump by 2 pi on rounding.

Near these two points the law is discontinuous: two correct evaluations that differ in the last
bit may turn opposite ways. A rollout that passes near them is marked fragile, and the caller
rolls that z out with the numpy reference instead (then costs it here)."""

# Indices into the parameter vector (numba freezes module-level ints as constants).
X0 = PARAMETERS.index('x0')
Y0 = PARAMETERS.index('y0')
PHI0 = PARAMETERS.index('phi0')
V0 = PARAMETERS.index('v0')
OMEGA0 = PARAMETERS.index('omega0')
K1 = PARAMETERS.index('k1')
K2 = PARAMETERS.index('k2')
BETA = PARAMETERS.index('beta')
LAM = PARAMETERS.index('lam')
R_THRESH = PARAMETERS.index('r_thresh')
OMEGA_LIMIT = PARAMETERS.index('omega_limit')
ACCEL_LIMIT = PARAMETERS.index('accel_limit')
ALPHA_LIMIT = PARAMETERS.index('alpha_limit')
V_LIMIT = PARAMETERS.index('v_limit')
DT = PARAMETERS.index('dt')
RHO_GUARD2 = PARAMETERS.index('rho_guard2')
HAS_GRID = PARAMETERS.index('has_grid')
SDF_RES = PARAMETERS.index('sdf_res')
SDF_OX = PARAMETERS.index('sdf_ox')
SDF_OY = PARAMETERS.index('sdf_oy')
TTC_RANGE = PARAMETERS.index('ttc_range')
SIGMA_STATIC = PARAMETERS.index('sigma_static')
SIGMA_DYNAMIC = PARAMETERS.index('sigma_dynamic')
A = PARAMETERS.index('a')
S_TTC = PARAMETERS.index('s_ttc')
S_TTG = PARAMETERS.index('s_ttg')
C_V = PARAMETERS.index('c_v')
C_W = PARAMETERS.index('c_w')
ANTICIPATORY = PARAMETERS.index('anticipatory')
TERMINAL = PARAMETERS.index('terminal')
NF_GRID = PARAMETERS.index('nf_grid')
NF_RES = PARAMETERS.index('nf_res')
NF_OX = PARAMETERS.index('nf_ox')
NF_OY = PARAMETERS.index('nf_oy')
GOAL_X = PARAMETERS.index('goal_x')
GOAL_Y = PARAMETERS.index('goal_y')
GOAL_TOL2 = PARAMETERS.index('goal_tol2')
CULL_FLOOR = PARAMETERS.index('cull_floor')
W_PROGRESS = PARAMETERS.index('w_progress')  # the five weights follow in TERM_NAMES order
ON_PROGRESS = PARAMETERS.index('on_progress')  # and the five switches
NEAR_STATIC = PARAMETERS.index('near_static')
GOAL_TOL = PARAMETERS.index('goal_tol')
CULL_SIGMAS = PARAMETERS.index('cull_sigmas')
TTG_NF = PARAMETERS.index('ttg_nf')

_SINC_SERIES = 1e-4
_KAPPA_FLOOR = 1e-12

jit = numba.njit(cache=False, fastmath=False, error_model="numpy")


_TWO_PI = 2.0 * math.pi


@jit
def _wrap(angle):
    """``control_law.wrap`` (to (-pi, pi]) by arithmetic: the same angle to an ulp or two,
    without the reference's three transcendental calls."""
    if -math.pi < angle <= math.pi:
        return angle
    wrapped = angle - _TWO_PI * math.floor((angle + math.pi) / _TWO_PI)
    return wrapped + _TWO_PI if wrapped <= -math.pi else wrapped


@jit
def _rate_limit(value, previous, limit, dt):
    if limit == math.inf:
        return value
    low, high = previous - limit * dt, previous + limit * dt
    return min(max(value, low), high)


@jit
def _law(x, y, phi, tx, ty, tphi, v_max, p):
    """``control_law.law_command`` with the exact smoothing."""
    dx, dy = tx - x, ty - y
    rho = math.sqrt(dx * dx + dy * dy + p[RHO_GUARD2])
    los = math.atan2(dy, dx)
    th = _wrap(tphi - los)
    de = _wrap(phi - los)
    k1th = p[K1] * th
    kappa = -(p[K2] * (de - math.atan(-k1th)) + (1.0 + p[K1] / (1.0 + k1th * k1th))
              * math.sin(de)) / rho
    abs_kappa = abs(kappa)
    slowdown = kappa * kappa if p[LAM] == 2.0 else abs_kappa ** p[LAM]
    v = min(v_max / (1.0 + p[BETA] * slowdown), v_max * rho / p[R_THRESH])
    v_cap = p[OMEGA_LIMIT] / max(abs_kappa, _KAPPA_FLOOR)
    v = min(v, v_cap)
    fragile = rho < FRAGILE_RHO or abs(th) > math.pi - FRAGILE_ANGLE or \
        abs(de) > math.pi - FRAGILE_ANGLE
    return v, kappa * v, fragile


@jit
def _rollout(z, p, n_steps, poses, vs, omegas, target):
    """``control_law.rollout`` of one z into the given rows; True when it is fragile."""
    x, y, phi, v_prev, w_prev = p[X0], p[Y0], p[PHI0], p[V0], p[OMEGA0]
    dt = p[DT]
    los = phi - z[2]
    tx, ty, tphi = x + z[0] * math.cos(los), y + z[0] * math.sin(los), los + z[1]
    target[0], target[1], target[2] = tx, ty, tphi
    poses[0, 0], poses[0, 1], poses[0, 2] = x, y, phi
    fragile = False
    for j in range(n_steps):
        v, w, at_jump = _law(x, y, phi, tx, ty, tphi, z[3], p)
        fragile = fragile or at_jump
        v = _rate_limit(v, v_prev, p[ACCEL_LIMIT], dt)
        w = _rate_limit(w, w_prev, p[ALPHA_LIMIT], dt)
        half = w * dt / 2.0
        if abs(half) < _SINC_SERIES:
            sinc = 1.0 - half * half / 6.0
        else:
            sinc = math.sin(half) / half
        chord = v * dt * sinc
        heading = phi + half
        x, y, phi = x + chord * math.cos(heading), y + chord * math.sin(heading), phi + w * dt
        v_prev, w_prev = v, w
        vs[j], omegas[j] = v, w
        poses[j + 1, 0], poses[j + 1, 1], poses[j + 1, 2] = x, y, phi
    return fragile


@jit
def _interpolate(table, res, ox, oy, px, py):
    """``grid._interpolate`` at one point plus its outside distance (``grid.distance``)."""
    ny, nx = table.shape
    u = (px - ox) / res - 0.5
    v = (py - oy) / res - 0.5
    uc = min(max(u, 0.0), nx - 1.0)
    vc = min(max(v, 0.0), ny - 1.0)
    outside = res * math.hypot(u - uc, v - vc)
    ix0 = min(int(math.floor(uc)), max(nx - 2, 0))
    iy0 = min(int(math.floor(vc)), max(ny - 2, 0))
    ix1 = min(ix0 + 1, nx - 1)
    iy1 = min(iy0 + 1, ny - 1)
    fx = uc - ix0
    fy = vc - iy0
    bottom = (1.0 - fx) * table[iy0, ix0] + fx * table[iy0, ix1]
    top = (1.0 - fx) * table[iy1, ix0] + fx * table[iy1, ix1]
    return ((1.0 - fy) * bottom + fy * top) + outside


@jit
def _ray(sdf, p, sx, sy, cos_h, sin_h, clear):
    """``OccupancyGrid.ray_distance`` of one ray (sphere tracing, same steps and stops)."""
    res = p[SDF_RES]
    max_range = p[TTC_RANGE]
    floor = 0.25 * res
    travel = 0.0
    for _ in range(math.ceil(max_range / floor) + 1):
        s = travel
        d = _interpolate(sdf, res, p[SDF_OX], p[SDF_OY], sx + s * cos_h, sy + s * sin_h)
        if d <= clear + 1e-9:
            return s
        travel = min(s + max(d - clear, floor), max_range)
        if not s < max_range:
            break
    return math.inf


@jit
def _inverse(speed, along):
    """``costs._inverse``: speed over distance, 0 for a miss, inf for contact."""
    if math.isinf(along):
        return 0.0
    if along <= 0.0:
        return math.inf
    if speed <= 0.0:
        return 0.0
    return speed / along


@jit
def _disk_inverse_ttc(px, py, wx, wy, radius):
    """``costs.disk_inverse_ttc`` with the exact smoothing."""
    a = wx * wx + wy * wy
    b = px * wx + py * wy
    c = px * px + py * py - radius * radius
    disc = b * b - a * c
    if c <= 0:
        return math.inf
    num = max(-b, 0.0) + math.sqrt(max(disc, 0.0))
    hit = 1.0 if (b < 0 and disc >= 0) else 0.0
    return hit * num / max(c, 1e-300)


@jit
def _place(fp, x, y, phi, pts):
    """World positions of the footprint circles at one pose into ``pts`` (C, 2)."""
    cos_h, sin_h = math.cos(phi), math.sin(phi)
    for c in range(fp.shape[0]):
        pts[c, 0] = x + cos_h * fp[c, 0] - sin_h * fp[c, 1]
        pts[c, 1] = y + sin_h * fp[c, 0] + cos_h * fp[c, 1]
    return cos_h, sin_h


@jit
def _static_inverse_ttc(sdf, p, fp, pts, cos_h, sin_h, speed):
    """Largest 1/TTC of the footprint circles against the map along the heading."""
    best = -math.inf
    for c in range(fp.shape[0]):
        along = _ray(sdf, p, pts[c, 0], pts[c, 1], cos_h, sin_h, fp[c, 2])
        best = max(best, _inverse(speed, along))
    return best


@jit
def _nf(nf, p, px, py):
    """``NavigationFunction.value`` at one point."""
    if p[NF_GRID] != 0.0:
        return _interpolate(nf, p[NF_RES], p[NF_OX], p[NF_OY], px, py)
    return math.hypot(px - p[GOAL_X], py - p[GOAL_Y])


@jit
def _pairwise(a, n):
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
    return _pairwise(a, n2) + _pairwise(a[n2:], n - n2)


@jit
def _collision_probability(d, inv, sigma, p):
    """``costs.collision_probability`` of one pose and object."""
    d = max(d, 0.0)
    pc = math.exp(-(d * d) / (sigma * sigma))
    if p[ANTICIPATORY] != 0.0:
        s = p[S_TTC]
        pc = pc * (1.0 - p[A] * math.exp(-(inv * inv) / (s * s)))
    return pc


@jit
def _static_pose(sdf, p, fp, pts, cos_h, sin_h, speed):
    """Distance to the map and 1/TTC along the heading of one pose (``_static_geometry``)."""
    d = math.inf
    for c in range(fp.shape[0]):
        inner = _interpolate(sdf, p[SDF_RES], p[SDF_OX], p[SDF_OY], pts[c, 0], pts[c, 1])
        d = min(d, inner - fp[c, 2])
    inv = 0.0
    if p[ANTICIPATORY] != 0.0 and d < p[NEAR_STATIC]:
        inv = _static_inverse_ttc(sdf, p, fp, pts, cos_h, sin_h, speed)
    return d, inv


@jit
def _object_pose(fp, pts, cos_h, sin_h, speed, centres, radii, velocities, first, last,
                 ttc_below, needed):
    """Distance and 1/TTC of one pose to the circles ``first:last`` of one object.

    Circle pairs whose distance is at least ``needed`` are skipped without a square root (the
    caller needs neither their distance nor their collision probability), so the distance is
    exact below ``needed`` and may be inf above it. 1/TTC is only computed when the distance
    is below ``ttc_below`` (else it is -inf: unused).
    """
    d, inv = math.inf, -math.inf
    for c in range(fp.shape[0]):
        for j in range(first, last):
            rx, ry = pts[c, 0] - centres[j, 0], pts[c, 1] - centres[j, 1]
            squared = rx * rx + ry * ry
            limit = needed + fp[c, 2] + radii[j]
            if limit > 0.0 and squared >= limit * limit:
                continue
            d = min(d, math.sqrt(squared) - fp[c, 2] - radii[j])
    if not d < ttc_below:
        return d, inv
    rvx, rvy = speed * cos_h, speed * sin_h
    for c in range(fp.shape[0]):
        for j in range(first, last):
            rx, ry = pts[c, 0] - centres[j, 0], pts[c, 1] - centres[j, 1]
            inv = max(inv, _disk_inverse_ttc(rx, ry, rvx - velocities[j, 0],
                                             rvy - velocities[j, 1], fp[c, 2] + radii[j]))
    return d, inv


@jit
def _survival(p, fp, sdf, pred, radii, velocities, starts, poses, vs, survival, pts):
    """Survivability at every pose; returns the smallest distance to any kept object.

    An object at ``d >= cull_sigmas * sigma`` has ``1 - P_c == 1.0`` exactly (see
    ``cycle.CULL_SIGMAS``): its factor is skipped, which changes no bit.
    """
    n_steps = vs.shape[0]
    far_static, far_dynamic = p[CULL_SIGMAS] * p[SIGMA_STATIC], p[CULL_SIGMAS] * p[SIGMA_DYNAMIC]
    ttc_below = far_dynamic if p[ANTICIPATORY] != 0.0 else -math.inf
    nearest = math.inf
    alive = 1.0
    for k in range(n_steps + 1):
        cos_h, sin_h = _place(fp, poses[k, 0], poses[k, 1], poses[k, 2], pts)
        speed = vs[min(k, n_steps - 1)]
        q = 1.0
        if p[HAS_GRID] != 0.0:
            d, inv = _static_pose(sdf, p, fp, pts, cos_h, sin_h, speed)
            nearest = min(nearest, d)
            if d < far_static:
                q *= 1.0 - _collision_probability(d, inv, p[SIGMA_STATIC], p)
        centres = pred[k]
        for o in range(starts.shape[0] - 1):
            d, inv = _object_pose(fp, pts, cos_h, sin_h, speed, centres, radii, velocities,
                                  starts[o], starts[o + 1], ttc_below,
                                  max(far_dynamic, nearest))
            nearest = min(nearest, d)
            if d < far_dynamic:
                q *= 1.0 - _collision_probability(d, inv, p[SIGMA_DYNAMIC], p)
        alive = q if k == 0 else alive * q
        survival[k] = alive
    return nearest


@jit
def _culled_distance(fp, poses, pred, radii, pts):
    """Smallest distance to the culled circles (only needed when nothing kept is nearer)."""
    d = math.inf
    for k in range(poses.shape[0]):
        _place(fp, poses[k, 0], poses[k, 1], poses[k, 2], pts)
        for c in range(fp.shape[0]):
            for j in range(radii.shape[0]):
                rx, ry = pts[c, 0] - pred[k, j, 0], pts[c, 1] - pred[k, j, 1]
                d = min(d, math.sqrt(rx * rx + ry * ry) - fp[c, 2] - radii[j])
    return d


@jit
def _descent(nf, p, x, y):
    """``-NavigationFunction.gradient`` at the terminal position, (0, 0) on the goal."""
    dx, dy = x - p[GOAL_X], y - p[GOAL_Y]
    norm = math.sqrt(dx * dx + dy * dy)
    gx, gy = (dx / norm, dy / norm) if norm > 0 else (0.0, 0.0)
    if p[NF_GRID] != 0.0:
        # central differences, blended into the Euclidean direction within a step of the goal
        h = p[NF_RES]
        weight = min(norm / h, 1.0)
        fx = (_nf(nf, p, x + h, y) - _nf(nf, p, x - h, y)) / (2 * h)
        fy = (_nf(nf, p, x, y + h) - _nf(nf, p, x, y - h)) / (2 * h)
        gx = weight * fx + (1.0 - weight) * gx
        gy = weight * fy + (1.0 - weight) * gy
    ex, ey = -gx, -gy
    if math.hypot(x - p[GOAL_X], y - p[GOAL_Y]) <= p[GOAL_TOL]:
        ex, ey = 0.0, 0.0
    return ex, ey


@jit
def _heading_error(ex, ey, phi):
    """``costs.heading_error`` against the NF descent direction ``(ex, ey)``."""
    if ex == 0 and ey == 0:
        return 0.0
    cos_phi, sin_phi = math.cos(phi), math.sin(phi)
    dot = cos_phi * ex + sin_phi * ey
    cross = cos_phi * ey - sin_phi * ex
    return math.atan2(abs(cross), dot)


@jit
def _inverse_ttg(p, x, y, phi, v_terminal):
    """``costs.inverse_ttg`` (exact)."""
    dx, dy = p[GOAL_X] - x, p[GOAL_Y] - y
    along = v_terminal * (math.cos(phi) * dx + math.sin(phi) * dy)
    squared = dx * dx + dy * dy
    if squared <= p[GOAL_TOL2]:
        return math.inf
    return max(along / (squared + 1e-12), 0.0)


@jit
def _inverse_ttg_along_nf(p, nf_end, ex, ey, x, y, phi, v_terminal):
    """``costs.inverse_ttg_along_nf`` (exact; on the goal as ``exact_geometry`` marks it)."""
    if math.hypot(x - p[GOAL_X], y - p[GOAL_Y]) <= p[GOAL_TOL]:
        return math.inf
    norm = math.sqrt(ex * ex + ey * ey + 1e-24)
    along = v_terminal * (math.cos(phi) * ex + math.sin(phi) * ey) / norm
    return max(along / (max(nf_end, 0.0) + 1e-12), 0.0)


@jit
def _terminal_inverse_ttc(p, fp, sdf, centres, radii, velocities, x, y, phi, pts):
    """``costs._terminal_inverse_ttc``: along the terminal heading at v_limit, every circle."""
    cos_h, sin_h = _place(fp, x, y, phi, pts)
    inv = 0.0
    if p[HAS_GRID] != 0.0:
        inv = _static_inverse_ttc(sdf, p, fp, pts, cos_h, sin_h, p[V_LIMIT])
    if radii.shape[0]:
        _, dyn = _object_pose(fp, pts, cos_h, sin_h, p[V_LIMIT], centres, radii, velocities, 0,
                              radii.shape[0], math.inf, -math.inf)
        inv = max(inv, dyn)
    return inv


@jit
def _assemble(p, nf, poses, vs, omegas, survival, terminal_inv, scratch, out):
    """``costs.assemble``: the five terms, each weighted or switched off, and the total."""
    n_steps = vs.shape[0]
    dt = p[DT]
    nf_prev = _nf(nf, p, poses[0, 0], poses[0, 1])
    for k in range(1, n_steps + 1):
        nf_k = _nf(nf, p, poses[k, 0], poses[k, 1])
        scratch[0, k - 1] = survival[k] * (nf_k - nf_prev)
        scratch[1, k - 1] = 1.0 - survival[k]
        nf_prev = nf_k
        v, w = vs[k - 1], omegas[k - 1]
        scratch[2, k - 1] = (p[C_V] * v * v + p[C_W] * w * w) * dt
    final = survival[n_steps]
    x, y, phi = poses[n_steps, 0], poses[n_steps, 1], poses[n_steps, 2]
    ex, ey = _descent(nf, p, x, y)
    if p[TTG_NF] != 0.0:
        inv_ttg = _inverse_ttg_along_nf(p, nf_prev, ex, ey, x, y, phi, vs[n_steps - 1])
    else:
        inv_ttg = _inverse_ttg(p, x, y, phi, vs[n_steps - 1])
    s_ttg, s_ttc = p[S_TTG], p[S_TTC]
    raw = (_pairwise(scratch[0], n_steps), _pairwise(scratch[2], n_steps),
           _pairwise(scratch[1], n_steps), _heading_error(ex, ey, phi) * final,
           -final * math.exp(-(inv_ttg * inv_ttg) / (s_ttg * s_ttg))
           * math.exp(-(terminal_inv * terminal_inv) / (s_ttc * s_ttc)))
    total = 0.0
    for t in range(5):
        out[1 + t] = p[W_PROGRESS + t] * raw[t] if p[ON_PROGRESS + t] != 0.0 else 0.0 * final
        total = out[1 + t] if t == 0 else total + out[1 + t]
    out[0] = total
    out[7] = inv_ttg
    out[8] = terminal_inv


@jit
def _rows(first, stride, z, p, fp, sdf, nf, pred, radii, velocities, starts, culled_pred,
          culled_radii, end_centres, end_radii, end_velocities, poses, vs, omegas, targets,
          survival, out, given):
    """Rows ``first, first + stride, ...`` of :func:`exact_costs`."""
    n, n_steps = z.shape[0], vs.shape[1]
    scratch = np.empty((3, n_steps))
    pts = np.empty((fp.shape[0], 2))
    for i in range(first, n, stride):
        fragile = False
        if not given:
            fragile = _rollout(z[i], p, n_steps, poses[i], vs[i], omegas[i], targets[i])
        nearest = _survival(p, fp, sdf, pred, radii, velocities, starts, poses[i], vs[i],
                            survival[i], pts)
        if culled_radii.shape[0] and not nearest <= p[CULL_FLOOR]:
            nearest = min(nearest, _culled_distance(fp, poses[i], culled_pred, culled_radii,
                                                    pts))
        end = poses[i, n_steps]
        terminal_inv = 0.0
        if p[TERMINAL] != 0.0:
            terminal_inv = _terminal_inverse_ttc(p, fp, sdf, end_centres, end_radii,
                                                 end_velocities, end[0], end[1], end[2], pts)
        _assemble(p, nf, poses[i], vs[i], omegas[i], survival[i], terminal_inv, scratch, out[i])
        out[i, 6] = nearest
        out[i, 9] = 1.0 if fragile else 0.0


@numba.njit(parallel=True, cache=True, nogil=True, fastmath=False, error_model="numpy")
def exact_costs(z, p, fp, sdf, nf, pred, radii, velocities, starts, culled_pred, culled_radii,
                end_centres, end_radii, end_velocities, poses, vs, omegas, targets, survival,
                out, given, threads):
    """Roll out and cost every row of ``z`` (n, 4) on every core; results go into the outputs.

    With ``given`` the rollouts already in ``poses``, ``vs``, ``omegas`` are costed instead.

    ``p`` is the parameter vector; ``pred``/``radii``/``velocities`` the kept circles (objects
    contiguous, object ``o`` is ``starts[o]:starts[o+1]``); ``culled_*`` the circles beyond
    reach (for the smallest distance only); ``end_*`` every circle at the horizon's end
    (terminal time to collision). Outputs: ``poses`` (n, N+1, 3), ``vs``, ``omegas`` (n, N),
    ``targets`` (n, 3), ``survival`` (n, N+1), ``out`` (n, len(OUT)).
    """
    # One interleaved block of rows per thread (``threads``: numba's thread count, read by
    # the caller; read here it would keep the kernel out of the disk cache): the thread pool
    # hands each thread an equal run of blocks, so equal blocks keep the threads equally busy
    # (256 blocks left one thread with 256 rows and the other 144 in a 400-row batch).
    blocks = max(min(z.shape[0], threads), 1)
    for b in prange(blocks):
        _rows(b, blocks, z, p, fp, sdf, nf, pred, radii, velocities, starts, culled_pred,
              culled_radii, end_centres, end_radii, end_velocities, poses, vs, omegas, targets,
              survival, out, given)


@numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy")
def exact_costs_serial(z, p, fp, sdf, nf, pred, radii, velocities, starts, culled_pred,
                       culled_radii, end_centres, end_radii, end_velocities, poses, vs, omegas,
                       targets, survival, out, given, threads):
    """:func:`exact_costs` on the calling thread (``threads`` unused: one signature for both):
    for small batches, where waking the thread pool costs more than it saves."""
    _rows(0, 1, z, p, fp, sdf, nf, pred, radii, velocities, starts, culled_pred, culled_radii,
          end_centres, end_radii, end_velocities, poses, vs, omegas, targets, survival, out,
          given)
