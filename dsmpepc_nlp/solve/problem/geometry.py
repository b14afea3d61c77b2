"""The graph's formulas on CasADi symbols: the table look-ups and their central differences,
the static and dynamic geometry of a pose, and the terminal ray. (The rollout is the control
law's own, ``control_law.symbolic_rollout``.)"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ...core.costs import disk_inverse_ttc
from ...core.geometry import body_to_world
from ...core.smooth import CASADI, is_exact, relu, sigmoid, smax, softmax_objects, softmin_objects
from .layout import GraphSizes, ray_samples

STENCIL = ((0.0, 0.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0))
"""Look-ups per point, in cells: the point, then +-x and +-y for a central difference."""

_OUTSIDE_EPS = 1e-9
"""Squared-length floor (m^2) under the outside distance's square root: its slope at 0 would
be infinite and the derivatives NaN."""



def table_lookup(sizes: GraphSizes):
    """Bilinear interpolation of a (table_cells x table_cells) parametric table at one point.

    ``(uv 2 x 1 in cell units, table) -> value``. Called once per point in MX: each call reads
    the table in place (a mapped call copied it per point; see docs/design.md).
    """
    cells = [float(i) for i in range(sizes.table_cells)]
    return ca.interpolant("bilinear", "linear", [cells, cells], 1,
                          {"lookup_mode": ["exact", "exact"]})


def lookups(lookup, uv, table):
    """``lookup`` at every column of ``uv`` (MX, 2 x n): a row 1 x n."""
    return ca.horzcat(*(lookup(uv[:, i], table) for i in range(uv.shape[1])))


def cell_coordinates(points, frame):
    """Clamped cell coordinates (2 x n) and the distance (1 x n, m) to the clamped point."""
    res = frame[2]
    u = (points[0, :] - frame[0]) / res - 0.5
    v = (points[1, :] - frame[1]) / res - 0.5
    uc = ca.fmin(ca.fmax(u, 0.0), frame[3] - 1.0)
    vc = ca.fmin(ca.fmax(v, 0.0), frame[4] - 1.0)
    du, dv = u - uc, v - vc
    outside = res * (ca.sqrt(du * du + dv * dv + _OUTSIDE_EPS) - np.sqrt(_OUTSIDE_EPS))
    return ca.vertcat(uc, vc), outside


def _stencil_points(points, frame):
    """Every point with its four neighbours one cell away: 2 x (5 n), stencil-major."""
    res = frame[2]
    return ca.horzcat(*(points + res * ca.DM([dx, dy]) for dx, dy in STENCIL))


def circle_centres(poses, config):
    """Footprint circle centres, 2 x ((N+1) C), pose-major."""
    columns = []
    for k in range(poses.shape[1]):
        for cx, cy, _ in config.robot.footprint:
            x, y = body_to_world(poses[:, k], cx, cy, ca)
            columns.append(ca.vertcat(x, y))
    return ca.horzcat(*columns)


def stencil_coordinates(points, frame):
    """Cell coordinates (2 x 5n) of the stencil points and their outside distances (1 x 5n)."""
    return cell_coordinates(_stencil_points(points, frame), frame)


def central(values, n, res):
    """``(value, gx, gy)`` rows (1 x n each) from stencil-major look-ups (1 x 5n)."""
    block = [values[:, i * n:(i + 1) * n] for i in range(len(STENCIL))]
    return block[0], (block[1] - block[2]) / (2 * res), (block[3] - block[4]) / (2 * res)


def _static_terms(pose, speed, gap, normal, config, smoothing):
    """1/TTC against the nearest wall's tangent plane for one circle (scalar).

    ``closing = -v u.n`` (m/s) and the ray reaches the plane after ``gap v / closing`` m: a
    hit when that is within ``ttc_range`` (a gate), 1/TTC = closing / gap.
    """
    cos, sin = ca.cos(pose[2]), ca.sin(pose[2])
    norm = ca.sqrt(normal[0] ** 2 + normal[1] ** 2 + 1e-12)
    closing = -(cos * normal[0] + sin * normal[1]) / norm * speed
    reach, t_dist = config.cost.ttc_range, smoothing.distance
    if is_exact(t_dist):
        hit = ca.if_else(closing * reach >= speed * gap, 1.0, 0.0)
        return ca.if_else(gap <= 0, np.inf, hit * ca.fmax(closing, 0.0) / ca.fmax(gap, 1e-300))
    gate = sigmoid((closing * reach - speed * gap) / (t_dist * config.robot.v_limit), CASADI)
    return gate * relu(closing, t_dist, CASADI) / smax(gap, t_dist, t_dist, CASADI)


def static_geometry(poses, speeds, d, gx, gy, config, smoothing):
    """Per pose: gap to the map (min over circles) and 1/TTC (max over circles), 1 x 1 each."""
    radii = [r for _, _, r in config.robot.footprint]
    n_c = len(radii)
    distances, inverses = [], []
    for k in range(poses.shape[1]):
        gaps, invs = [], []
        for c, radius in enumerate(radii):
            i = k * n_c + c
            gap = d[i] - radius
            gaps.append(gap)
            invs.append(_static_terms(poses[:, k], speeds[k], gap, (gx[i], gy[i]), config,
                                      smoothing))
        distances.append(softmin_objects(ca.horzcat(*gaps), smoothing.distance, CASADI)
                         if n_c > 1 else gaps[0])
        inverses.append(softmax_objects(ca.horzcat(*invs), smoothing.inverse_time, CASADI)
                        if n_c > 1 else invs[0])
    return distances, inverses


def dynamic_geometry(pose, speed, time, circles, velocities, config, smoothing, sizes):
    """Distance (1 x K) and 1/TTC (1 x K) to each object at one pose, objects moved ``time``
    (K the rows of ``velocities``)."""
    c_obj, k_max = sizes.circles_per_object, velocities.shape[0]
    cos, sin = ca.cos(pose[2]), ca.sin(pose[2])
    obj_vel = ca.kron(velocities, ca.DM.ones(c_obj, 1))              # (K C_obj) x 2
    centres = circles[:, :2] + time * obj_vel
    gaps, inverses = [], []
    for cx, cy, radius in config.robot.footprint:
        x, y = body_to_world(pose, cx, cy, ca)
        px, py = x - centres[:, 0], y - centres[:, 1]
        reach = radius + circles[:, 2]
        gaps.append(ca.sqrt(px * px + py * py) - reach)
        wx, wy = speed * cos - obj_vel[:, 0], speed * sin - obj_vel[:, 1]
        inverses.append(disk_inverse_ttc(px, py, wx, wy, reach, smoothing, CASADI))

    def per_object(columns):
        stacked = ca.horzcat(*columns)                                # (K C_obj) x C
        return ca.reshape(stacked.T, len(columns) * c_obj, k_max).T   # K x (C C_obj)

    gap, inv = per_object(gaps), per_object(inverses)
    if gap.shape[1] > 1:
        gap = softmin_objects(gap, smoothing.distance, CASADI)
        inv = softmax_objects(inv, smoothing.inverse_time, CASADI)
    return gap.T, inv.T


def ray_points(end, config, sizes):
    """Samples along the terminal heading from each footprint circle: 2 x (M C), circle-major,
    and their distances along the ray (M: numpy's ``linspace(0, ttc_range, M)``, operation
    for operation, with ``ttc_range`` a parameter)."""
    m, reach = ray_samples(config, sizes), config.cost.ttc_range
    spacing = reach / (m - 1)
    along = [reach if j == m - 1 else j * spacing for j in range(m)]
    row = ca.horzcat(*along)
    cos, sin = ca.cos(end[2]), ca.sin(end[2])
    columns = []
    for cx, cy, _ in config.robot.footprint:
        x, y = body_to_world(end, cx, cy, ca)
        columns.append(ca.vertcat(x + cos * row, y + sin * row))
    return ca.horzcat(*columns), along


def ray_inverse_ttc(gaps, along, speed, smoothing):
    """1/TTC from the gaps (1 x M, m) at samples ``along`` (M,) of one ray: ``speed`` over the
    first crossing of gap 0, linearly interpolated between samples; 0 for a miss.

    Smooth: "first sample in contact" is a product of sigmoid gates at the distance
    temperature, so the crossing moves continuously with the trajectory.
    """
    t_dist = smoothing.distance
    exact = is_exact(t_dist)
    spacing = along[1] - along[0]
    inverse, free = 0.0, 1.0
    for j in range(gaps.shape[1]):
        gap = gaps[j]
        hit = ca.if_else(gap <= 0, 1.0, 0.0) if exact else sigmoid(-gap / t_dist, CASADI)
        if j == 0:
            crossing = relu(gap, t_dist, CASADI)
        else:
            before = gaps[j - 1]
            share = (before / (before - gap) if exact else
                     before / smax(before - gap, t_dist, t_dist, CASADI))
            crossing = along[j - 1] + spacing * ca.fmin(ca.fmax(share, 0.0), 1.0)
        weight = hit * free
        if exact:
            inv = ca.if_else(crossing <= 0, np.inf, speed / ca.fmax(crossing, 1e-300))
            inverse = inverse + ca.if_else(weight > 0, weight * inv, 0.0)
        else:
            inverse = inverse + weight * speed / smax(crossing, t_dist, t_dist, CASADI)
        free = free * (1.0 - hit)
    return inverse


def nav_points(poses, frame):
    """Where the NF is read: every pose's position, then the end's four neighbours."""
    end = poses[:2, -1]
    res = frame[2]
    return ca.horzcat(poses[:2, :], *(end + res * ca.DM([dx, dy]) for dx, dy in STENCIL[1:]))


