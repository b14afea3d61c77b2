"""The smooth DS-MPEPC cost as one SX graph in z, with the per-cycle world packed as parameters.

What the graph sees of the world (chosen for an all-SX graph; measured in ``nlp.py``'s notes):

- **Dynamic obstacles**: ``max_objects`` objects of up to ``circles_per_object`` circles, each
  circle ``(x, y, radius)`` now plus one velocity per object; predicted at constant velocity in
  the graph. Padding objects sit ``FAR`` away, where their collision probability underflows to
  exactly 0. A world with more objects keeps the ``max_objects`` nearest the robot; an object
  with more circles keeps the circles nearest the robot.
- **Static map**: ``map_disks`` occupied boundary cells as small disks ``(x, y, radius)``; the
  distance to the map is the soft-min gap to them, and static 1/TTC is the shared
  :func:`~dsmpepc_nlp.costs.disk_inverse_ttc` against disks of zero velocity (so one formula
  serves moving and still objects). Cells are taken nearest the robot first; where that leaves
  a wall sparse, neighbouring cells are merged (spacing up to two cells) into disks sized so
  that the scallops between them stay within half a cell of the true surface.
- **Navigation function**: ``nav_waypoints`` points ``w`` with their exact NF values; the graph
  uses ``NF(p) = softmin_w(|p - w| + NF(w))`` (the Bellman form of a path length). With no map the
  only waypoint is the goal and this is the exact Euclidean NF. With a map the waypoints lie on
  the grid's descent path from the robot (corners included), exact on and near that path.

Why not a B-spline of the signed distance / NF over a local window: CasADi's parametric
``bspline`` is an MX node (no SX expansion) whose derivatives transform the whole coefficient
vector on every call (casadi/casadi#3762), while the per-iteration budget here is ~0.1 ms.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .config import PlannerConfig, RobotState
from .control_law import clamp_measured, step_function, target_pose
from .costs import TERM_NAMES, assemble, disk_inverse_ttc, heading_error, inverse_ttg
from .smooth import CASADI, relu, smax, softmax_objects, softmin_objects

FAR = 1.0e3
"""Position of padding objects, disks and waypoints, m: exp(-FAR^2/sigma^2) is exactly 0."""


@dataclass(frozen=True)
class GraphSizes:
    """Fixed sizes of the parameter blocks; the graph is built once for them.

    Attributes
    ----------
    max_objects : int
        Dynamic objects K the graph holds (the nearest ones are kept).
    circles_per_object : int
        Circles per object (a pedestrian uses 1; padding repeats its first circle).
    map_disks : int
        Disks standing for the static map near the robot.
    nav_waypoints : int
        Waypoints of the navigation-function representation.
    """

    max_objects: int = 16
    circles_per_object: int = 1
    map_disks: int = 48
    nav_waypoints: int = 8

    def __post_init__(self):
        for name in ("max_objects", "circles_per_object", "map_disks", "nav_waypoints"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"GraphSizes.{name} = {value!r}: must be an integer >= 1")


PARAMETER_NAMES = ("state", "goal", "obstacle_circles", "obstacle_velocities", "map_disks",
                   "nav_waypoints")
"""Named parameter inputs of :func:`build_cost_function`, in order."""


def parameter_shapes(sizes: GraphSizes) -> dict:
    """Shape of each parameter block (CasADi column-major)."""
    return {
        "state": (5, 1),
        "goal": (2, 1),
        "obstacle_circles": (sizes.max_objects * sizes.circles_per_object, 3),
        "obstacle_velocities": (sizes.max_objects, 2),
        "map_disks": (sizes.map_disks, 3),
        "nav_waypoints": (sizes.nav_waypoints, 3),
    }


# --- the graph ----------------------------------------------------------------------------


def _circle_pairs(points, radii, centres, centre_radii):
    """Gap and relative position of every (robot circle, other circle) pair, flattened.

    ``points`` C x 2, ``centres`` Q x 2 (SX). Returns ``(gap, px, py, radius)`` each 1 x (C Q),
    pairs ordered circle-major over ``centres``.
    """
    n_c, n_q = points.shape[0], centres.shape[0]
    px = ca.repmat(points[:, 0], 1, n_q) - ca.repmat(centres[:, 0].T, n_c, 1)
    py = ca.repmat(points[:, 1], 1, n_q) - ca.repmat(centres[:, 1].T, n_c, 1)
    radius = ca.repmat(ca.DM(radii), 1, n_q) + ca.repmat(centre_radii.T, n_c, 1)
    gap = ca.sqrt(px * px + py * py) - radius
    flat = lambda m: ca.reshape(m, 1, n_c * n_q)  # noqa: E731
    return flat(gap), flat(px), flat(py), flat(radius)


def _per_object(values, n_objects):
    """Row of length n_objects * per into an n_objects x per matrix (objects in rows)."""
    per = values.shape[1] // n_objects
    return ca.reshape(values, per, n_objects).T


def _object_geometry(pose, speed, time, circles, velocities, disks, config, smoothing, sizes):
    """Distance (1 x M) and 1/TTC (1 x M) at one pose; object 0 is the map, then K objects."""
    c_obj, k_max = sizes.circles_per_object, sizes.max_objects
    footprint = np.array(config.robot.footprint)
    cos, sin = ca.cos(pose[2]), ca.sin(pose[2])
    points = ca.horzcat(pose[0] + cos * footprint[:, 0] - sin * footprint[:, 1],
                        pose[1] + sin * footprint[:, 0] + cos * footprint[:, 1])
    n_c = footprint.shape[0]
    vx, vy = speed * cos, speed * sin
    t_dist, t_inv = smoothing.distance, smoothing.inverse_time
    # Static map: one object; see _static_geometry for why its TTC is planar.
    static_d, static_inv = _static_geometry(points, footprint[:, 2], vx, vy, disks, config,
                                            smoothing)
    distance, inverse = [static_d], [static_inv]
    # Dynamic objects at this time; each circle moves with its object's velocity.
    obj_vel = ca.kron(velocities, ca.DM.ones(c_obj, 1))              # (K C_obj) x 2
    centres = circles[:, :2] + time * obj_vel
    gap, px, py, radius = _circle_pairs(points, footprint[:, 2], centres, circles[:, 2])
    # Pairs are ordered robot-circle-major; regroup so each object's pairs are one row.
    order = [c + n_c * q for q in range(k_max * c_obj) for c in range(n_c)]
    gap = _per_object(gap[:, order], k_max)
    distance.append(softmin_objects(gap, t_dist, CASADI).T)
    if config.anticipatory_pc:
        wx = vx - ca.reshape(ca.repmat(obj_vel[:, 0].T, n_c, 1), 1, n_c * k_max * c_obj)
        wy = vy - ca.reshape(ca.repmat(obj_vel[:, 1].T, n_c, 1), 1, n_c * k_max * c_obj)
        inv = disk_inverse_ttc(px, py, wx, wy, radius, smoothing, CASADI)
        inverse.append(softmax_objects(_per_object(inv[:, order], k_max), t_inv, CASADI).T)
    else:
        inverse.append(ca.SX.zeros(1, k_max))
    return ca.horzcat(*distance), ca.horzcat(*inverse)


_WEIGHT_TEMPERATURE = 1e-3
"""Floor of the temperature of the nearest-disk weights, m (the exact form has none to offer)."""


def _static_geometry(points, radii, vx, vy, disks, config, smoothing):
    """Distance (1x1) to the map disks and planar 1/TTC (1x1) from the footprint circles.

    1/TTC against the map is ``max(-v u.n, 0) / gap``, with ``n`` the direction away from the
    nearest disks (soft-min weights): the ray distance to a straight wall, which is what the
    exact ray march measures head-on and obliquely. Measured against per-disk
    :func:`disk_inverse_ttc` (zero velocity) it cost 3x the graph (48 disks) for a difference
    only at corners, so the planar form is used here.
    """
    t_dist = smoothing.distance
    distances, inverses = [], []
    for c in range(points.shape[0]):
        dx = points[c, 0] - disks[:, 0].T
        dy = points[c, 1] - disks[:, 1].T
        centre = ca.sqrt(dx * dx + dy * dy + 1e-12)
        gap = centre - disks[:, 2].T - radii[c]
        d = softmin_objects(gap, t_dist, CASADI)
        distances.append(d)
        if not config.anticipatory_pc:
            continue
        scaled = -gap / max(t_dist, _WEIGHT_TEMPERATURE)
        weights = ca.exp(scaled - ca.mmax(scaled))
        weights = weights / ca.sum2(weights)
        nx = ca.sum2(weights * dx / centre)
        ny = ca.sum2(weights * dy / centre)
        closing = relu(-(vx * nx + vy * ny), t_dist, CASADI)
        if t_dist == 0:
            inverses.append(ca.if_else(d <= 0, np.inf, closing / ca.fmax(d, 1e-300)))
        else:
            inverses.append(closing / smax(d, t_dist, t_dist, CASADI))
    distance = softmin_objects(ca.horzcat(*distances), t_dist, CASADI)
    if not inverses:
        return distance, ca.SX(0)
    return distance, softmax_objects(ca.horzcat(*inverses), smoothing.inverse_time, CASADI)


def _terminal_inverse_ttc(pose, time, circles, velocities, disks, config, smoothing, sizes):
    """1/TTC at the horizon's end moving along the terminal heading at v_limit (scalar)."""
    _, inverse = _object_geometry(pose, config.robot.v_limit, time, circles, velocities, disks,
                                  dataclasses.replace(config, anticipatory_pc=True), smoothing,
                                  sizes)
    return softmax_objects(inverse, smoothing.inverse_time, CASADI)


def navigation_value(point, waypoints, temperature):
    """Smooth navigation function at ``point`` (2 x 1) from waypoints (W x 3: x, y, NF), m."""
    dx = point[0] - waypoints[:, 0].T
    dy = point[1] - waypoints[:, 1].T
    # A small floor keeps the gradient of |p - w| finite at a waypoint.
    through = ca.sqrt(dx * dx + dy * dy + 1e-12) + waypoints[:, 2].T
    return softmin_objects(through, temperature, CASADI)


def build_cost_function(config: PlannerConfig, sizes: GraphSizes, smoothing=None) -> ca.Function:
    """The smooth cost as an SX ``casadi.Function`` named ``dsmpepc_cost``.

    Inputs (see :func:`parameter_shapes`): ``z`` (4), ``state`` (5: x, y, phi, v, omega with
    the measured velocity within the limits), ``goal`` (2), ``obstacle_circles`` ((K C_obj) x 3:
    x, y, radius now, object-major), ``obstacle_velocities`` (K x 2), ``map_disks`` (P x 3),
    ``nav_waypoints`` (W x 3: x, y, NF value). Outputs: ``cost`` and each term of
    :data:`~dsmpepc_nlp.costs.TERM_NAMES`, all scalars.
    """
    smoothing = config.smoothing if smoothing is None else smoothing
    shapes = parameter_shapes(sizes)
    z = ca.SX.sym("z", 4)
    params = {name: ca.SX.sym(name, *shape) for name, shape in shapes.items()}
    total, terms = _cost_expression(z, params, config, sizes, smoothing)
    names = ["z", *PARAMETER_NAMES]
    return ca.Function("dsmpepc_cost", [z, *(params[n] for n in PARAMETER_NAMES)],
                       [total, *(terms[t] for t in TERM_NAMES)], names, ["cost", *TERM_NAMES])


def _cost_expression(z, params, config, sizes, smoothing):
    state, goal = params["state"], params["goal"]
    circles, velocities = params["obstacle_circles"], params["obstacle_velocities"]
    disks, waypoints = params["map_disks"], params["nav_waypoints"]
    n_steps, dt = config.horizon.n_steps, config.horizon.dt
    law_step = step_function(config, smoothing)
    target = ca.vertcat(*target_pose([z[0], z[1], z[2]], [state[0], state[1], state[2]], CASADI))
    carry, poses, vs, omegas = state, [state[:3]], [], []
    for _ in range(n_steps):
        carry, v, omega = law_step(carry, target, z[3])
        poses.append(carry[:3])
        vs.append(v)
        omegas.append(omega)
    distances, inverses, nf = [], [], []
    for k, pose in enumerate(poses):
        speed = vs[min(k, n_steps - 1)]
        d, inv = _object_geometry(pose, speed, k * dt, circles, velocities, disks, config,
                                  smoothing, sizes)
        distances.append(d)
        inverses.append(inv)
        nf.append(navigation_value(pose[:2], waypoints, smoothing.distance))
    end = poses[-1]
    point = ca.SX.sym("point", 2)
    nf_end = navigation_value(point, waypoints, smoothing.distance)
    descent = -ca.substitute(ca.gradient(nf_end, point), point, end[:2])
    err = heading_error(end[2], descent[0], descent[1], CASADI, smoothing)
    inv_ttg = inverse_ttg((end[0], end[1], end[2]), vs[-1], goal, CASADI, smoothing)
    inv_term = (_terminal_inverse_ttc(end, n_steps * dt, circles, velocities, disks, config,
                                      smoothing, sizes)
                if config.terminal_cost else ca.SX(0))
    sigma = ca.DM([[config.cost.sigma_static] + [config.cost.sigma_dynamic] * sizes.max_objects])
    sigma = ca.repmat(sigma, n_steps + 1, 1)  # CasADi does not broadcast a row
    total, terms, _ = assemble(ca.vertcat(*distances), ca.vertcat(*inverses), sigma,
                               ca.vertcat(*nf), ca.vertcat(*vs), ca.vertcat(*omegas), err,
                               inv_ttg, inv_term, config, smoothing, CASADI)
    return total, terms


# --- packing the world into parameters (numpy) ----------------------------------------------


def reach_radius(config: PlannerConfig) -> float:
    """How far from the robot the horizon can matter, m: travel, footprint and bell width."""
    return (config.robot.v_limit * config.horizon.duration + config.robot.bounding_radius
            + 6.0 * max(config.cost.sigma_static, config.cost.sigma_dynamic))


def pack_obstacles(state: RobotState, world, sizes: GraphSizes):
    """``(circles, velocities)`` of the K nearest objects, padded far away.

    Returns ``circles`` ((K C_obj), 3) and ``velocities`` (K, 2), m and m/s.
    """
    k_max, c_obj = sizes.max_objects, sizes.circles_per_object
    circles = np.tile([FAR, FAR, 0.1], (k_max * c_obj, 1))
    velocities = np.zeros((k_max, 2))
    position = np.array([state.x, state.y])
    obstacles = list(world.obstacles)
    if not obstacles:
        return circles, velocities
    gaps = [np.min(np.linalg.norm(o.centers - position, axis=1) - o.radii) for o in obstacles]
    for slot, index in enumerate(np.argsort(gaps, kind="stable")[:k_max]):
        obstacle = obstacles[index]
        near = np.argsort(np.linalg.norm(obstacle.centers - position, axis=1))[:c_obj]
        rows = np.column_stack([obstacle.centers[near], obstacle.radii[near]])
        # Padding circles repeat the nearest one: the min over circles is unchanged.
        rows = np.vstack([rows, np.repeat(rows[:1], c_obj - len(rows), axis=0)])
        circles[slot * c_obj:(slot + 1) * c_obj] = rows
        velocities[slot] = obstacle.velocity
    return circles, velocities


def _boundary_cells(grid):
    """Centres (n, 2) of occupied cells with a free 4-neighbour (outside the grid is free)."""
    occ = np.pad(grid.occupied, 1, constant_values=False)
    inner = occ[1:-1, 1:-1]
    interior = occ[:-2, 1:-1] & occ[2:, 1:-1] & occ[1:-1, :-2] & occ[1:-1, 2:]
    iy, ix = np.nonzero(inner & ~interior)
    return grid.origin + grid.resolution * (np.column_stack([ix, iy]) + 0.5)


def pack_map(state: RobotState, world, config: PlannerConfig, sizes: GraphSizes) -> np.ndarray:
    """Disks ``(x, y, radius)`` (P, 3) standing for the map near the robot, padded far away."""
    disks = np.tile([FAR, FAR, 0.1], (sizes.map_disks, 1))
    if world.grid is None:
        return disks
    res = world.grid.resolution
    cells = _boundary_cells(world.grid)
    position = np.array([state.x, state.y])
    far_enough = reach_radius(config) + config.cost.ttc_range
    cells = cells[np.linalg.norm(cells - position, axis=1) <= far_enough]
    if len(cells) == 0:
        return disks
    radius = 0.5 * res
    if len(cells) > sizes.map_disks:
        # Merge cells on a two-cell lattice; the radius res grows the disks so that scallops
        # between centres 2 res apart stay within res / 2 of the surface (e = s^2 / (16 r0)).
        key = np.floor((cells - world.grid.origin) / (2 * res)).astype(np.int64)
        _, first = np.unique(key, axis=0, return_index=True)
        cells = cells[np.sort(first)]
        radius = res
    order = np.argsort(np.linalg.norm(cells - position, axis=1), kind="stable")
    chosen = cells[order[:sizes.map_disks]]
    disks[:len(chosen), :2] = chosen
    disks[:len(chosen), 2] = radius
    return disks


def pack_navigation(state: RobotState, world, goal, config: PlannerConfig,
                    sizes: GraphSizes) -> np.ndarray:
    """Waypoints ``(x, y, NF)`` (W, 3): the goal without a map, else the NF descent path."""
    goal = np.asarray(goal, dtype=float)
    waypoints = np.tile([FAR, FAR, 2 * FAR], (sizes.nav_waypoints, 1))
    nav = world.navigation(goal, config.robot.inflation_radius)
    if nav.values is None:
        waypoints[0] = [goal[0], goal[1], 0.0]
        return waypoints
    path = _descent_path(nav, np.array([state.x, state.y]), reach_radius(config) + 2.0)
    # Evenly spaced along the path by arc length, the far end and the goal (when near) included.
    along = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))]
    n = sizes.nav_waypoints
    points = path[np.searchsorted(along, np.linspace(0.0, along[-1], n), side="left")
                  .clip(0, len(path) - 1)] if along[-1] > 0 else path[:1]
    points = np.unique(points, axis=0)
    waypoints[:len(points), :2] = points
    waypoints[:len(points), 2] = nav.value(points)
    return waypoints


def _descent_path(nav, start, length):
    """Steepest 8-neighbour descent of the NF table from ``start`` for up to ``length`` m."""
    work, values = nav.working_grid, nav.values
    res = work.resolution
    ny, nx = values.shape
    cell = np.floor((start - work.origin) / res).astype(int)
    ix, iy = int(np.clip(cell[0], 0, nx - 1)), int(np.clip(cell[1], 0, ny - 1))
    path = [start]
    travelled = 0.0
    steps = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    while travelled < length:
        best, best_value = None, values[iy, ix]
        for dx, dy in steps:
            jx, jy = ix + dx, iy + dy
            if 0 <= jx < nx and 0 <= jy < ny and values[jy, jx] < best_value - 1e-12:
                best, best_value = (jx, jy), values[jy, jx]
        if best is None:
            break
        ix, iy = best
        point = work.origin + res * (np.array([ix, iy]) + 0.5)
        travelled += float(np.linalg.norm(point - path[-1]))
        path.append(point)
    if np.linalg.norm(path[-1] - nav.goal) < length - travelled + res:
        path.append(nav.goal.copy())
    return np.array(path)


def pack_parameters(state: RobotState, world, goal, config: PlannerConfig,
                    sizes: GraphSizes) -> dict:
    """Every parameter block of :func:`build_cost_function` from ``(state, world, goal)``.

    The measured ``(v, omega)`` is clamped to the limits (the law's rate limits start from it).
    Returns a dict over :data:`PARAMETER_NAMES` of numpy arrays shaped by
    :func:`parameter_shapes`.
    """
    v0, omega0 = clamp_measured(state, config)
    circles, velocities = pack_obstacles(state, world, sizes)
    return {
        "state": np.array([state.x, state.y, state.phi, v0, omega0]),
        "goal": np.asarray(goal, dtype=float).reshape(2),
        "obstacle_circles": circles,
        "obstacle_velocities": velocities,
        "map_disks": pack_map(state, world, config, sizes),
        "nav_waypoints": pack_navigation(state, world, goal, config, sizes),
    }


def flatten_parameters(params: dict) -> np.ndarray:
    """The blocks as one vector, each column-major (CasADi's ``vec``), in PARAMETER_NAMES order."""
    return np.concatenate([np.asarray(params[n], dtype=float).reshape(-1, order="F")
                           for n in PARAMETER_NAMES])


def is_finite_parameters(params: dict) -> bool:
    """True when every block is finite."""
    return all(np.all(np.isfinite(params[n])) for n in PARAMETER_NAMES)


__all__ = ["FAR", "GraphSizes", "PARAMETER_NAMES", "build_cost_function", "flatten_parameters",
           "pack_parameters", "parameter_shapes", "reach_radius", "navigation_value",
           "is_finite_parameters"]
