"""The exact geometry, compiled: table look-ups, the ray to the map, time to collision with
a disk, the navigation function and the terminal quantities (``exact_cost.exact_geometry``)."""

from __future__ import annotations

import math

from .layout import (
    ANTICIPATORY,
    GOAL_TOL,
    GOAL_TOL2,
    GOAL_X,
    GOAL_Y,
    HAS_GRID,
    NEAR_STATIC,
    NF_GRID,
    NF_OX,
    NF_OY,
    NF_RES,
    SDF_OX,
    SDF_OY,
    SDF_RES,
    TTC_RANGE,
    V_LIMIT,
    jit,
)


@jit
def interpolate(table, res, ox, oy, px, py):
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
def ray(sdf, p, sx, sy, cos_h, sin_h, clear):
    """``OccupancyGrid.ray_distance`` of one ray (sphere tracing, same steps and stops)."""
    res = p[SDF_RES]
    max_range = p[TTC_RANGE]
    floor = 0.25 * res
    travel = 0.0
    for _ in range(math.ceil(max_range / floor) + 1):
        s = travel
        d = interpolate(sdf, res, p[SDF_OX], p[SDF_OY], sx + s * cos_h, sy + s * sin_h)
        if d <= clear + 1e-9:
            return s
        travel = min(s + max(d - clear, floor), max_range)
        if not s < max_range:
            break
    return math.inf


@jit
def inverse(speed, along):
    """``exact_cost._inverse``: speed over distance, 0 for a miss, inf for contact."""
    if math.isinf(along):
        return 0.0
    if along <= 0.0:
        return math.inf
    if speed <= 0.0:
        return 0.0
    return speed / along


@jit
def disk_inverse_ttc(px, py, wx, wy, radius):
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
def place(fp, x, y, phi, pts):
    """World positions of the footprint circles at one pose into ``pts`` (C, 2)."""
    cos_h, sin_h = math.cos(phi), math.sin(phi)
    for c in range(fp.shape[0]):
        pts[c, 0] = x + cos_h * fp[c, 0] - sin_h * fp[c, 1]
        pts[c, 1] = y + sin_h * fp[c, 0] + cos_h * fp[c, 1]
    return cos_h, sin_h


@jit
def static_inverse_ttc(sdf, p, fp, pts, cos_h, sin_h, speed):
    """Largest 1/TTC of the footprint circles against the map along the heading."""
    best = -math.inf
    for c in range(fp.shape[0]):
        along = ray(sdf, p, pts[c, 0], pts[c, 1], cos_h, sin_h, fp[c, 2])
        best = max(best, inverse(speed, along))
    return best


@jit
def nf_value(nf, p, px, py):
    """``NavigationFunction.value`` at one point."""
    if p[NF_GRID] != 0.0:
        return interpolate(nf, p[NF_RES], p[NF_OX], p[NF_OY], px, py)
    return math.hypot(px - p[GOAL_X], py - p[GOAL_Y])


@jit
def static_pose(sdf, p, fp, pts, cos_h, sin_h, speed):
    """Distance to the map and 1/TTC along the heading of one pose (``_static_geometry``)."""
    d = math.inf
    for c in range(fp.shape[0]):
        inner = interpolate(sdf, p[SDF_RES], p[SDF_OX], p[SDF_OY], pts[c, 0], pts[c, 1])
        d = min(d, inner - fp[c, 2])
    inv = 0.0
    if p[ANTICIPATORY] != 0.0 and d < p[NEAR_STATIC]:
        if speed < 0.0:     # along the direction of travel: backwards for a reverse
            inv = static_inverse_ttc(sdf, p, fp, pts, -cos_h, -sin_h, -speed)
        else:
            inv = static_inverse_ttc(sdf, p, fp, pts, cos_h, sin_h, speed)
    return d, inv


@jit
def object_pose(fp, pts, cos_h, sin_h, speed, centres, radii, velocities, first, last,
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
            inv = max(inv, disk_inverse_ttc(rx, ry, rvx - velocities[j, 0],
                                             rvy - velocities[j, 1], fp[c, 2] + radii[j]))
    return d, inv


@jit
def culled_distance(fp, poses, pred, radii, pts):
    """Smallest distance to the culled circles (only needed when nothing kept is nearer)."""
    d = math.inf
    for k in range(poses.shape[0]):
        place(fp, poses[k, 0], poses[k, 1], poses[k, 2], pts)
        for c in range(fp.shape[0]):
            for j in range(radii.shape[0]):
                rx, ry = pts[c, 0] - pred[k, j, 0], pts[c, 1] - pred[k, j, 1]
                d = min(d, math.sqrt(rx * rx + ry * ry) - fp[c, 2] - radii[j])
    return d


@jit
def descent(nf, p, x, y):
    """``-NavigationFunction.gradient`` at the terminal position, (0, 0) on the goal."""
    dx, dy = x - p[GOAL_X], y - p[GOAL_Y]
    norm = math.sqrt(dx * dx + dy * dy)
    gx, gy = (dx / norm, dy / norm) if norm > 0 else (0.0, 0.0)
    if p[NF_GRID] != 0.0:
        # central differences, blended into the Euclidean direction within a step of the goal
        h = p[NF_RES]
        weight = min(norm / h, 1.0)
        fx = (nf_value(nf, p, x + h, y) - nf_value(nf, p, x - h, y)) / (2 * h)
        fy = (nf_value(nf, p, x, y + h) - nf_value(nf, p, x, y - h)) / (2 * h)
        gx = weight * fx + (1.0 - weight) * gx
        gy = weight * fy + (1.0 - weight) * gy
    ex, ey = -gx, -gy
    if math.hypot(x - p[GOAL_X], y - p[GOAL_Y]) <= p[GOAL_TOL]:
        ex, ey = 0.0, 0.0
    return ex, ey


@jit
def heading_error(ex, ey, phi):
    """``costs.heading_error`` against the NF descent direction ``(ex, ey)``."""
    if ex == 0 and ey == 0:
        return 0.0
    cos_phi, sin_phi = math.cos(phi), math.sin(phi)
    dot = cos_phi * ex + sin_phi * ey
    cross = cos_phi * ey - sin_phi * ex
    return math.atan2(abs(cross), dot)


@jit
def inverse_ttg(p, x, y, phi, v_terminal):
    """``costs.inverse_ttg`` (exact)."""
    dx, dy = p[GOAL_X] - x, p[GOAL_Y] - y
    along = v_terminal * (math.cos(phi) * dx + math.sin(phi) * dy)
    squared = dx * dx + dy * dy
    if squared <= p[GOAL_TOL2]:
        return math.inf
    return max(along / (squared + 1e-12), 0.0)


@jit
def terminal_inverse_ttc(p, fp, sdf, centres, radii, velocities, x, y, phi, pts):
    """``exact_cost._terminal_inverse_ttc``: along the terminal heading at v_limit, every circle."""
    cos_h, sin_h = place(fp, x, y, phi, pts)
    inv = 0.0
    if p[HAS_GRID] != 0.0:
        inv = static_inverse_ttc(sdf, p, fp, pts, cos_h, sin_h, p[V_LIMIT])
    if radii.shape[0]:
        _, dyn = object_pose(fp, pts, cos_h, sin_h, p[V_LIMIT], centres, radii, velocities, 0,
                              radii.shape[0], math.inf, -math.inf)
        inv = max(inv, dyn)
    return inv
