"""The smooth DS-MPEPC cost as a small CasADi SX graph in z, with the world as local models.

This is the graph the built-in solvers (``nlp.py``) minimise today. The static map and the
navigation function enter as local quadratic models along a reference trajectory (exact value
and gradient there, curvature damped beyond ``MODEL_RADIUS``), static 1/TTC as the wall plane
the reference ray hit, and per pose only the ``near_objects`` objects nearest to the reference:
small enough for a fast exact SX Hessian, but honest only near the reference, so ``NlpSolver``
re-takes the models when a solution moves away. ``nlp_global.py`` is the graph that reads the
map and navigation tables themselves and is honest at every z (the one to embed).

Why each form, and what was measured: ``docs/nlp.md``. With exact temperatures this graph
equals ``costs.evaluate`` at the reference (tested).

Longer than 400 lines because the graph and the packing of its local models share one column
layout (``NAV_COLUMNS``, ``MAP_COLUMNS``, the near-object columns); the module goes once the
built-in solvers run on the global graph (``docs/nlp.md``, what is not reached yet).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.control_law import EXACT, clamp_measured, rollout, step_function, target_pose
from ..core.costs import TERM_NAMES, assemble, disk_inverse_ttc, heading_error, terminal_inverse_ttg
from ..core.errors import InputError
from ..core.geometry import body_to_world, footprint_points
from ..core.grid import FAR  # distance to nothing (also padding objects): exp(-FAR^2/s^2) == 0
from ..core.smooth import CASADI, relu, sigmoid, smax, softmax_objects, softmin_objects
from .compiled import blocks_finite, flatten_blocks

MODEL_RADIUS = 0.5
"""Trust radius of the local quadratic models, m: the curvature term is damped by
``1 / (1 + |dp|^2 / MODEL_RADIUS^2)`` so a model never bends back far from its reference."""

NAV_COLUMNS = 8
"""Per pose: reference point (x, y), NF value, gradient (2), Hessian (xx, xy, yy)."""
MAP_COLUMNS = 12
"""Per pose and footprint circle: reference centre (x, y), signed distance, gradient (2),
Hessian (xx, xy, yy), then the wall plane the reference ray hits: point (x, y), unit normal
(x, y) (a plane FAR ahead when the ray misses within ``ttc_range``)."""


@dataclass(frozen=True)
class GraphSizes:
    """Fixed sizes of the parameter blocks; the graph is built once for them.

    Attributes
    ----------
    max_objects : int
        Dynamic objects K the terminal time to collision sees (the nearest ones are kept).
    near_objects : int
        Dynamic objects per pose (the nearest to that reference pose at that time): the only
        ones whose collision probability is not ~0 along a trajectory near the reference.
    circles_per_object : int
        Circles per object (a pedestrian uses 1; padding repeats its nearest circle).
    """

    max_objects: int = 12
    near_objects: int = 3
    circles_per_object: int = 1

    def __post_init__(self):
        for name in ("max_objects", "near_objects", "circles_per_object"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise InputError(f"GraphSizes.{name} = {value!r}: must be an integer >= 1")


PARAMETER_NAMES = ("state", "goal", "obstacle_circles", "obstacle_velocities", "near_obstacles",
                   "nav_model", "map_model")
"""Named parameter inputs of :func:`build_cost_function`, in order."""


def near_columns(sizes: GraphSizes) -> int:
    """Columns of a pose's row of ``near_obstacles``: per object its circles' (x, y, radius)
    at that pose's time, then its velocity (vx, vy)."""
    return sizes.near_objects * (3 * sizes.circles_per_object + 2)


def parameter_shapes(config: PlannerConfig, sizes: GraphSizes) -> dict:
    """Shape of each parameter block (CasADi column-major)."""
    n_poses = config.horizon.n_steps + 1
    n_circles = len(config.robot.footprint)
    return {
        "state": (5, 1),
        "goal": (3, 1),
        "obstacle_circles": (sizes.max_objects * sizes.circles_per_object, 3),
        "obstacle_velocities": (sizes.max_objects, 2),
        "near_obstacles": (n_poses, near_columns(sizes)),
        "nav_model": (n_poses, NAV_COLUMNS),
        "map_model": (n_poses, MAP_COLUMNS * n_circles),
    }


# --- the graph ----------------------------------------------------------------------------


def local_quadratic(point, model):
    """A local model ``(x0, y0, f, gx, gy, hxx, hxy, hyy)`` evaluated at ``point``.

    ``f + g.dp + 0.5 dp'H dp / (1 + |dp|^2/R^2)`` with ``R = MODEL_RADIUS``: exact value and
    gradient at the reference; far from it the curvature term stays bounded (by
    ``0.5 |H| R^2``) so a distance model cannot bend back up. Returns ``(value, gradient)``
    with the gradient of the same expression (SX, 2 x 1).
    """
    dx, dy = point[0] - model[0], point[1] - model[1]
    quad = model[5] * dx * dx + 2.0 * model[6] * dx * dy + model[7] * dy * dy
    damp = 1.0 / (1.0 + (dx * dx + dy * dy) / MODEL_RADIUS**2)
    value = model[2] + model[3] * dx + model[4] * dy + 0.5 * quad * damp
    # d/dp of 0.5 quad damp = damp H dp - quad damp^2 dp / R^2
    hx = model[5] * dx + model[6] * dy
    hy = model[6] * dx + model[7] * dy
    shrink = quad * damp * damp / MODEL_RADIUS**2
    grad = (model[3] + damp * hx - shrink * dx, model[4] + damp * hy - shrink * dy)
    return value, grad


def _static_geometry(pose, speed, map_row, config, smoothing):
    """Gap to the map (scalar) and planar 1/TTC (scalar) at one pose from the local models.

    The gap is the local quadratic model of the signed distance. 1/TTC against the map is
    ``max(v (-u.n), 0) / (n.(p - q))``: the ray distance to the wall plane (point q, normal n)
    that the reference pose's ray hit, the exact ray march's answer at the reference and for
    any pose in front of a flat wall; the ray march's range cut (``ttc_range``) is a gate.
    """
    footprint = np.array(config.robot.footprint)
    cos, sin = ca.cos(pose[2]), ca.sin(pose[2])
    t_dist = smoothing.distance
    reach = config.cost.ttc_range
    gaps, inverses = [], []
    for c, (cx, cy, radius) in enumerate(footprint):
        row = map_row[MAP_COLUMNS * c:MAP_COLUMNS * (c + 1)]
        point = body_to_world(pose, cx, cy, ca)
        value, _ = local_quadratic(point, row[:8])
        gap = value - radius
        gaps.append(gap)
        if not config.anticipatory_pc and not config.terminal_cost:
            continue
        normal_x, normal_y = row[10], row[11]
        along = normal_x * (point[0] - row[8]) + normal_y * (point[1] - row[9])   # m, to plane
        closing = -(cos * normal_x + sin * normal_y) * speed                      # m/s
        if t_dist == 0:
            hit = ca.if_else(closing * reach >= speed * along, 1.0, 0.0)
            inv = ca.if_else(ca.fmin(gap, along) <= 0, np.inf,
                             hit * ca.fmax(closing, 0.0) / ca.fmax(along, 1e-300))
        else:
            gate = sigmoid((closing * reach - speed * along) / (t_dist * config.robot.v_limit),
                           CASADI)
            inv = gate * relu(closing, t_dist, CASADI) / smax(along, t_dist, t_dist, CASADI)
        inverses.append(inv)
    gap = softmin_objects(ca.horzcat(*gaps), t_dist, CASADI) if len(gaps) > 1 else gaps[0]
    if not inverses:
        return gap, ca.SX(0)
    inv = (softmax_objects(ca.horzcat(*inverses), smoothing.inverse_time, CASADI)
           if len(inverses) > 1 else inverses[0])
    return gap, inv


def _dynamic_geometry(pose, speed, time, circles, velocities, config, smoothing, sizes,
                      with_ttc, k_max):
    """Distance (1 x k_max) and 1/TTC (1 x k_max) to each of ``k_max`` objects at one pose.

    ``circles`` ((k_max C_obj) x 3: x, y, radius at time 0) move with ``velocities``
    (k_max x 2) for ``time`` seconds.
    """
    c_obj = sizes.circles_per_object
    footprint = np.array(config.robot.footprint)
    cos, sin = ca.cos(pose[2]), ca.sin(pose[2])
    obj_vel = ca.kron(velocities, ca.DM.ones(c_obj, 1))              # (K C_obj) x 2
    centres = circles[:, :2] + time * obj_vel
    gaps, inverses = [], []
    for cx, cy, radius in footprint:
        x, y = body_to_world(pose, cx, cy, ca)
        px, py = x - centres[:, 0], y - centres[:, 1]
        reach = radius + circles[:, 2]
        gaps.append(ca.sqrt(px * px + py * py) - reach)
        if with_ttc:
            wx, wy = speed * cos - obj_vel[:, 0], speed * sin - obj_vel[:, 1]
            inverses.append(disk_inverse_ttc(px, py, wx, wy, reach, smoothing, CASADI))

    def per_object(columns):
        # Rows: objects; columns: every robot circle x object circle of that object.
        stacked = ca.horzcat(*columns)                                # (K C_obj) x C
        return ca.reshape(stacked.T, len(columns) * c_obj, k_max).T   # K x (C C_obj)

    gap = per_object(gaps)
    distance = (softmin_objects(gap, smoothing.distance, CASADI) if gap.shape[1] > 1 else gap)
    if not with_ttc:
        return distance.T, ca.SX.zeros(1, k_max)
    inv = per_object(inverses)
    inv = softmax_objects(inv, smoothing.inverse_time, CASADI) if inv.shape[1] > 1 else inv
    return distance.T, inv.T


def _navigation(point, nav_row, goal):
    """NF value and gradient at ``point``: the local model, or Euclidean when ``goal[2]`` is 1."""
    value, grad = local_quadratic(point, nav_row)
    dx, dy = point[0] - goal[0], point[1] - goal[1]
    norm = ca.sqrt(dx * dx + dy * dy + 1e-12)
    euclid = goal[2]
    return (euclid * norm + (1 - euclid) * value,
            (euclid * dx / norm + (1 - euclid) * grad[0],
             euclid * dy / norm + (1 - euclid) * grad[1]))


def _split_near(row, sizes):
    """A pose's ``near_obstacles`` row into ``(circles, velocities)`` matrices."""
    k, c_obj = sizes.near_objects, sizes.circles_per_object
    circles = ca.reshape(row[:3 * k * c_obj], 3, k * c_obj).T
    velocities = ca.reshape(row[3 * k * c_obj:], 2, k).T
    return circles, velocities


def pose_function(config: PlannerConfig, sizes: GraphSizes, smoothing) -> ca.Function:
    """Geometry of one pose as an SX ``Function`` named ``pose_geometry``.

    ``(pose[3], speed, near_row, nav_row, map_row, goal[3]) -> (distance 1 x (1+K_near),
    inv_ttc 1 x (1+K_near), nf, descent[2])``; object 0 is the map.
    """
    shapes = parameter_shapes(config, sizes)
    pose, speed = ca.SX.sym("pose", 3), ca.SX.sym("speed")
    near_row = ca.SX.sym("near_row", shapes["near_obstacles"][1])
    nav_row = ca.SX.sym("nav_row", NAV_COLUMNS)
    map_row = ca.SX.sym("map_row", shapes["map_model"][1])
    goal = ca.SX.sym("goal", 3)
    static_d, static_inv = _static_geometry(pose, speed, map_row, config, smoothing)
    circles, velocities = _split_near(near_row, sizes)
    dyn_d, dyn_inv = _dynamic_geometry(pose, speed, 0.0, circles, velocities, config,
                                       smoothing, sizes, config.anticipatory_pc,
                                       sizes.near_objects)
    nf, grad = _navigation(pose[:2], nav_row, goal)
    if not config.anticipatory_pc:
        static_inv = ca.SX(0)
    return ca.Function(
        "pose_geometry", [pose, speed, near_row, nav_row, map_row, goal],
        [ca.horzcat(static_d, dyn_d), ca.horzcat(static_inv, dyn_inv), nf, -ca.vertcat(*grad)],
        ["pose", "speed", "near_row", "nav_row", "map_row", "goal"],
        ["distance", "inv_ttc", "nf", "descent"])


def terminal_function(config: PlannerConfig, sizes: GraphSizes, smoothing) -> ca.Function:
    """1/TTC at the horizon's end moving along the terminal heading at v_limit (scalar)."""
    shapes = parameter_shapes(config, sizes)
    pose, time = ca.SX.sym("pose", 3), ca.SX.sym("time")
    map_row = ca.SX.sym("map_row", shapes["map_model"][1])
    circles = ca.SX.sym("circles", *shapes["obstacle_circles"])
    velocities = ca.SX.sym("velocities", *shapes["obstacle_velocities"])
    speed = config.robot.v_limit
    _, static_inv = _static_geometry(pose, speed, map_row, config, smoothing)
    _, dyn_inv = _dynamic_geometry(pose, speed, time, circles, velocities, config, smoothing,
                                   sizes, True, sizes.max_objects)
    inv = softmax_objects(ca.horzcat(static_inv, dyn_inv), smoothing.inverse_time, CASADI)
    return ca.Function("terminal_inv_ttc", [pose, time, map_row, circles, velocities], [inv],
                       ["pose", "time", "map_row", "circles", "velocities"], ["inv_ttc"])


def build_cost_function(config: PlannerConfig, sizes: GraphSizes, smoothing=None) -> ca.Function:
    """The smooth cost as an SX ``casadi.Function`` named ``dsmpepc_cost``.

    Inputs (see :func:`parameter_shapes`): ``z`` (4), ``state`` (5: x, y, phi, v, omega with
    the measured velocity within the limits), ``goal`` (3: x, y, and 1 for a Euclidean NF /
    0 for the local NF models), ``obstacle_circles`` ((K C_obj) x 3: x, y, radius now,
    object-major), ``obstacle_velocities`` (K x 2), ``nav_model`` ((N+1) x 8), ``map_model``
    ((N+1) x 8C). Outputs: ``cost`` and each term of :data:`~dsmpepc_nlp.core.costs.TERM_NAMES`.
    """
    smoothing = config.smoothing if smoothing is None else smoothing
    shapes = parameter_shapes(config, sizes)
    z = ca.SX.sym("z", 4)
    params = {name: ca.SX.sym(name, *shape) for name, shape in shapes.items()}
    total, terms = cost_expression(z, params, config, sizes, smoothing)
    return ca.Function("dsmpepc_cost", [z, *(params[n] for n in PARAMETER_NAMES)],
                       [total, *(terms[t] for t in TERM_NAMES)], ["z", *PARAMETER_NAMES],
                       ["cost", *TERM_NAMES])


def cost_expression(z, params, config, sizes, smoothing):
    """``(total, terms)`` as SX expressions of ``z`` and the parameter blocks."""
    state, goal = params["state"], params["goal"]
    circles, velocities = params["obstacle_circles"], params["obstacle_velocities"]
    nav, maps, near = params["nav_model"], params["map_model"], params["near_obstacles"]
    n_steps, dt = config.horizon.n_steps, config.horizon.dt
    law_step = step_function(config, smoothing)
    geometry = pose_function(config, sizes, smoothing)
    target = ca.vertcat(*target_pose([z[0], z[1], z[2]], [state[0], state[1], state[2]], CASADI))
    # SQP iterates can leave the box by the QP's tolerance (seen: v_max = -2.8e-3 from qrqp);
    # a negative v_max makes the law's smooth speed cap NaN (a negative base to the power 1/t)
    # and with it the Hessian ("nlp_hess_l ... NaN detected"). The cost is flat below 0.
    v_max = ca.fmax(z[3], 0.0)
    carry, poses, vs, omegas = state, [state[:3]], [], []
    for _ in range(n_steps):
        carry, v, omega = law_step(carry, target, v_max)
        poses.append(carry[:3])
        vs.append(v)
        omegas.append(omega)
    distances, inverses, nf = [], [], []
    descent = None
    for k, pose in enumerate(poses):
        speed = vs[min(k, n_steps - 1)]
        d, inv, value, descent = geometry(pose, speed, near[k, :].T, nav[k, :].T, maps[k, :].T,
                                          goal)
        distances.append(d)
        inverses.append(inv)
        nf.append(value)
    end = poses[-1]
    err = heading_error(end[2], descent[0], descent[1], CASADI, smoothing)
    # The TTG bell is s_ttg = 1e-3 1/s wide: a softplus of temperature inverse_time (0.02 1/s)
    # would add 0.014 1/s to 1/TTG and make C_TTG ~0 where the exact value is 1, so this
    # soft-clip runs at the same share of its bell's width as 1/TTC's (inverse_time / s_ttc):
    # 4e-5 1/s by default, C_TTG >= 0.999 where it is exactly 1, and it scales with smoothing.
    ttg_smoothing = dataclasses.replace(
        smoothing, inverse_time=smoothing.inverse_time * config.cost.s_ttg / config.cost.s_ttc)
    inv_ttg = terminal_inverse_ttg((end[0], end[1], end[2]), vs[-1], goal, nf[-1], descent,
                                   config, CASADI, ttg_smoothing)
    inv_term = ca.SX(0)
    if config.terminal_cost:
        terminal = terminal_function(config, sizes, smoothing)
        inv_term = terminal(end, n_steps * dt, maps[n_steps, :].T, circles, velocities)
    sigma = ca.DM([[config.cost.sigma_static]
                   + [config.cost.sigma_dynamic] * sizes.near_objects])
    sigma = ca.repmat(sigma, n_steps + 1, 1)  # CasADi does not broadcast a row
    total, terms, _ = assemble(ca.vertcat(*distances), ca.vertcat(*inverses), sigma,
                               ca.vertcat(*nf), ca.vertcat(*vs), ca.vertcat(*omegas), err,
                               inv_ttg, inv_term, config, smoothing, CASADI)
    return total, terms


# --- packing the world into parameters (numpy) ----------------------------------------------


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


def pack_near_obstacles(poses, world, config: PlannerConfig, sizes: GraphSizes) -> np.ndarray:
    """Per reference pose k the ``near_objects`` objects nearest to it at time ``k dt``.

    Returns ((N+1), near_columns): each object's circles ``(x, y, radius)`` at that time, then
    its velocity; padding objects sit FAR away.
    """
    n_poses, k_near, c_obj = poses.shape[0], sizes.near_objects, sizes.circles_per_object
    circles = np.tile([FAR, FAR, 0.1], (n_poses, k_near, c_obj, 1))
    velocities = np.zeros((n_poses, k_near, 2))
    obstacles = list(world.obstacles)
    if obstacles:
        times = np.arange(n_poses) * config.horizon.dt
        centers, radii, obj_vel, owner = world.stacked_obstacles()
        predicted = centers[None] + obj_vel[None] * times[:, None, None]        # (N+1, Q, 2)
        gap = np.linalg.norm(predicted - poses[:, None, :2], axis=-1) - radii      # (N+1, Q)
        n_obj = len(obstacles)
        per_object = np.full((n_poses, n_obj), np.inf)
        np.minimum.at(per_object.T, owner, gap.T)
        order = np.argsort(per_object, axis=1, kind="stable")[:, :k_near]
        if len(owner) == n_obj:      # one circle per object (pedestrians): no loop needed
            rows = np.arange(n_poses)[:, None]
            m = order.shape[1]
            circles[:, :m, :, :2] = predicted[rows, order][:, :, None, :]
            circles[:, :m, :, 2] = radii[order][:, :, None]
            velocities[:, :m] = obj_vel[order]
            order = order[:0]
        for k in range(order.shape[0]):
            for slot, index in enumerate(order[k]):
                mine = np.flatnonzero(owner == index)
                near = mine[np.argsort(gap[k, mine], kind="stable")[:c_obj]]
                near = np.r_[near, np.repeat(near[:1], c_obj - len(near))]
                circles[k, slot, :, :2] = predicted[k, near]
                circles[k, slot, :, 2] = radii[near]
                velocities[k, slot] = obstacles[index].velocity
    return np.concatenate([circles.reshape(n_poses, -1), velocities.reshape(n_poses, -1)], 1)


_STENCIL = np.array([(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1),
                     (-1, -1)], dtype=float)


def quadratic_models(function, points, step, gradient=None) -> np.ndarray:
    """Local models ``(x, y, f, gx, gy, hxx, hxy, hyy)`` (P, 8) of ``function`` at ``points``.

    Central differences with ``step`` (m) on a 3 x 3 stencil: ``f`` is the exact value, the
    gradient ``gradient(points)`` when given (e.g. the navigation function's own, so the model
    agrees with what the exact cost uses), else central differences.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    values = function(points[:, None, :] + step * _STENCIL).reshape(-1, 9)
    f0, fe, fw, fn, fs, fne, fse, fnw, fsw = values.T
    grad = (gradient(points) if gradient is not None
            else np.column_stack([(fe - fw) / (2 * step), (fn - fs) / (2 * step)]))
    hxx = (fe - 2 * f0 + fw) / step**2
    hyy = (fn - 2 * f0 + fs) / step**2
    hxy = (fne - fse - fnw + fsw) / (4 * step**2)
    return np.column_stack([points, f0, grad, hxx, hxy, hyy])


def reference_poses(state: RobotState, config: PlannerConfig, reference=None) -> np.ndarray:
    """Poses (N+1, 3) the local models are taken at: ``reference`` given as poses or as a z."""
    if reference is None:
        return np.tile(np.array(state.pose, dtype=float), (config.horizon.n_steps + 1, 1))
    reference = np.asarray(reference, dtype=float)
    if reference.shape == (4,):
        return rollout(reference, state, config, EXACT).poses
    return reference.reshape(config.horizon.n_steps + 1, 3)


def _wall_planes(world, centres, headings, radii, reach) -> np.ndarray:
    """Hit point and unit normal (P, 4) of the wall plane each ray meets."""
    along = world.static_ray_distance(centres, headings, radii, reach)
    direction = np.column_stack([np.cos(headings), np.sin(headings)])
    # A miss: a plane FAR ahead facing the ray, whose 1/TTC is below 1e-3 1/s and gated off.
    planes = np.column_stack([centres + FAR * direction, -direction])
    hit = np.isfinite(along)
    if np.any(hit):
        direction = direction[hit]
        points = centres[hit] + along[hit, None] * direction
        step = world.grid.resolution
        normal = quadratic_models(world.static_distance, points, step)[:, 3:5]
        norm = np.linalg.norm(normal, axis=1, keepdims=True)
        # A ray that starts in contact (along = 0) or a degenerate normal: face the ray.
        normal = np.where(norm > 1e-6, normal / np.maximum(norm, 1e-12), -direction)
        planes[hit, :2] = points
        planes[hit, 2:] = normal
    return planes


def pack_models(poses, world, goal, config: PlannerConfig) -> tuple:
    """``(nav_model, map_model, euclidean)`` around the reference ``poses`` (N+1, 3)."""
    n_poses = poses.shape[0]
    footprint = np.array(config.robot.footprint)
    n_circles = len(footprint)
    nav = world.navigation(np.asarray(goal, dtype=float), config.robot.inflation_radius,
                           near=poses[0, :2], reach=config.reach)
    if nav.values is None:
        nav_model = np.zeros((n_poses, NAV_COLUMNS))
        nav_model[:, :2] = poses[:, :2]
        euclidean = 1.0
    else:
        step = nav.working_grid.resolution
        nav_model = quadratic_models(nav.value, poses[:, :2], step, nav.gradient)
        euclidean = 0.0
    centres = footprint_points(poses, footprint).reshape(-1, 2)
    models = np.zeros((n_poses * n_circles, MAP_COLUMNS))
    if world.grid is None:
        models[:, :2] = centres
        models[:, 2] = FAR
        models[:, 8:] = _wall_planes(world, centres, np.repeat(poses[:, 2], n_circles),
                                     np.tile(footprint[:, 2], n_poses), 0.0)
    else:
        models[:, :8] = quadratic_models(world.static_distance, centres, world.grid.resolution)
        headings = np.repeat(poses[:, 2], n_circles)
        radii = np.tile(footprint[:, 2], n_poses)
        models[:, 8:] = _wall_planes(world, centres, headings, radii, config.cost.ttc_range)
    return nav_model, models.reshape(n_poses, -1), euclidean


def pack_parameters(state: RobotState, world, goal, config: PlannerConfig, sizes: GraphSizes,
                    reference=None) -> dict:
    """Every parameter block of :func:`build_cost_function` from ``(state, world, goal)``.

    Parameters
    ----------
    reference : ndarray (4,) or (N+1, 3), optional
        The trajectory the local map and NF models are taken along: a z (rolled out exactly)
        or its poses. Default: the robot standing still.

    Returns a dict over :data:`PARAMETER_NAMES` of numpy arrays shaped by
    :func:`parameter_shapes`. The measured ``(v, omega)`` is clamped to the limits.
    """
    v0, omega0 = clamp_measured(state, config)
    circles, velocities = pack_obstacles(state, world, sizes)
    poses = reference_poses(state, config, reference)
    nav_model, map_model, euclidean = pack_models(poses, world, goal, config)
    near = pack_near_obstacles(poses, world, config, sizes)
    goal = np.asarray(goal, dtype=float).reshape(2)
    return {
        "state": np.array([state.x, state.y, state.phi, v0, omega0]),
        "goal": np.array([goal[0], goal[1], euclidean]),
        "obstacle_circles": circles,
        "obstacle_velocities": velocities,
        "near_obstacles": near,
        "nav_model": nav_model,
        "map_model": map_model,
    }


def flatten_parameters(params: dict) -> np.ndarray:
    """The blocks as one vector, each column-major (CasADi's ``vec``), in PARAMETER_NAMES order."""
    return flatten_blocks(params, PARAMETER_NAMES)


def is_finite_parameters(params: dict) -> bool:
    """True when every block is finite."""
    return blocks_finite(params, PARAMETER_NAMES)


__all__ = ["FAR", "MODEL_RADIUS", "GraphSizes", "PARAMETER_NAMES", "build_cost_function",
           "cost_expression", "flatten_parameters", "pack_parameters", "pack_models",
           "parameter_shapes", "quadratic_models", "reference_poses", "is_finite_parameters"]
