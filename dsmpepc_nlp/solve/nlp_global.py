"""The smooth DS-MPEPC cost as one CasADi graph in z, valid wherever the horizon can reach.

This is the graph the built-in solvers minimise (compiled, ``problem.py``) and the cost to
embed in your own optimiser (:func:`cost_function`): it reads the world through parameters set
once per cycle, never through models taken along a reference trajectory, so its value is
honest at every z:

- the static signed distance and the navigation function as look-up tables over a window of
  ``GraphSizes.table_cells`` cells around the robot (the cycle's own tables, cut out at their
  resolution), read by the same clamped bilinear interpolation plus outside distance as
  ``core/world.py::_interpolate`` (a parametric CasADi ``interpolant``, called once per point
  in MX so that the table is read in place);
- the gradient of either table (the wall normal for the static time to collision, the NF
  descent direction for the heading term) as central differences one cell wide, the formula
  of ``NavigationFunction.gradient``;
- static 1/TTC along the trajectory as the closing speed over the gap to the nearest wall's
  tangent plane (the exact ray distance in front of any flat wall); at the horizon's end,
  where it reaches ``ttc_range`` ahead, from samples of the distance along the ray at most a
  footprint radius apart (:func:`ray_samples`) (first crossing, interpolated between samples);
- the ``max_objects`` dynamic objects that come nearest to the robot's start over the horizon
  for the terminal time to collision, and at every pose the nearest ``pose_objects`` of those
  the robot can reach, moved at constant velocity inside the graph, each computed only at the
  poses it can reach that soon (:func:`pose_mask`, a CasADi conditional per pair).

Everything but the look-ups is SX (compact derivatives); the cost is ``costs.assemble``, the
formula the exact cost uses. Accuracy and speed, with the commands, are in ``docs/nlp.md``.
Longer than 400 lines (~700) because the graph's pieces and the packing of their parameters
must change together; splitting them would put one parameter layout in two files.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..core.config import TERM_NAMES, PlannerConfig
from ..core.control_law import clamp_measured, step, target_pose
from ..core.costs import (
    assemble,
    collision_probability,
    disk_inverse_ttc,
    heading_error,
    terminal_inverse_ttg,
)
from ..core.errors import InputError
from ..core.geometry import body_to_world
from ..core.grid import FAR
from ..core.smooth import CASADI, is_exact, relu, sigmoid, smax, softmax_objects, softmin_objects
from . import settings as settings_block
from .cycle import CULL_SIGMAS

# FAR (core.grid's): the distance reported by padding objects and by a world without a map,
# m; exp(-FAR^2/sigma^2) is exactly 0.

FRAME_COLUMNS = 5
"""A table's frame: origin (x, y) of its lower-left cell corner, resolution, and the number of
valid columns and rows (the clamping box of the bilinear interpolation)."""

_STENCIL = ((0.0, 0.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0))
"""Look-ups per point, in cells: the point, then +-x and +-y for a central difference."""

_OUTSIDE_EPS = 1e-9
"""Squared-length floor (m^2) under the outside distance's square root: its slope at 0 would
be infinite and the derivatives NaN."""


@dataclass(frozen=True)
class GraphSizes:
    """Fixed sizes of the parameter blocks; the graph is built once for them.

    Attributes
    ----------
    max_objects : int
        Dynamic objects the graph sees at every pose (those that come nearest to the robot's
        start over the horizon).
    circles_per_object : int
        Circles per object (a pedestrian uses 1; padding repeats its nearest circle).
    table_cells : int
        Side of the square window of the distance and navigation tables, cells. The window
        holds the whole map when it fits, else the part around the robot.
    ray_samples : int or None
        Samples of the distance table along the terminal ray (``ttc_range`` long, start
        included) from which the terminal static time to collision is read; None (default):
        :func:`ray_samples`, spaced by at most the smallest footprint radius.
    pose_objects : int or None
        Dynamic objects the graph sees at every pose of the horizon (the nearest of those the
        robot can reach: an object out of reach has ``1 - P_c == 1.0`` exactly, see
        ``cycle.CULL_SIGMAS``); None: ``max_objects``. The terminal time to collision always
        sees ``max_objects``. The solvers compile a few sizes and pick the smallest that holds
        the cycle's objects in reach (``SolverConfig.pose_object_buckets``).
    """

    max_objects: int = 12
    circles_per_object: int = 1
    table_cells: int = 256
    ray_samples: int | None = None
    pose_objects: int | None = None

    def __post_init__(self):
        for name, low in (("max_objects", 1), ("circles_per_object", 1), ("table_cells", 2),
                          ("ray_samples", 2), ("pose_objects", 0)):
            value = getattr(self, name)
            if name in ("pose_objects", "ray_samples") and value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise InputError(f"GraphSizes.{name} = {value!r}: must be an integer >= {low}")

    @property
    def k_pose(self) -> int:
        """Objects seen at every pose."""
        return self.max_objects if self.pose_objects is None else self.pose_objects


RAY_LADDER_BASE = 7
"""The terminal ray's sample counts are ``7 * 2^k``: the default ray (8 m, 0.3 m radius, 28
samples) is on the ladder, and every other range and footprint rounds up to one of a few
counts, so that they share compiled libraries (the count is structure)."""


def ray_samples(config: PlannerConfig, sizes: GraphSizes) -> int:
    """Samples along the terminal ray: ``sizes.ray_samples``, or (None) enough that they are
    at most the smallest footprint radius apart, rounded up to the ladder
    ``RAY_LADDER_BASE * 2^k``.

    A ray that crosses a wall spends at least a footprint diameter within a radius of it
    (gap <= 0), so samples a radius apart put at least two in contact: no wall is skipped,
    and the first crossing is interpolated between samples a radius apart. (A ray that only
    grazes a wall's inflated edge is missed at any finite count.) More samples buy no accuracy
    and cost gradient time (docs/nlp.md).
    """
    if sizes.ray_samples is not None:
        return sizes.ray_samples
    smallest = min(radius for _, _, radius in config.robot.footprint)
    needed = max(2, int(np.ceil(config.cost.ttc_range / smallest)) + 1)
    count = RAY_LADDER_BASE
    while count < needed:
        count *= 2
    return count


PARAMETER_NAMES = ("state", "goal", "obstacle_circles", "obstacle_velocities", "pose_circles",
                   "pose_velocities", "pose_mask", "map_frame", "map_table", "nav_frame",
                   "nav_table", "settings")
"""Named parameter inputs of :func:`build_cost_function`, in order."""


def parameter_shapes(config: PlannerConfig, sizes: GraphSizes) -> dict:
    """Shape of each parameter block (CasADi column-major)."""
    cells = sizes.table_cells * sizes.table_cells
    return {
        "state": (5, 1),
        "goal": (3, 1),
        "obstacle_circles": (sizes.max_objects * sizes.circles_per_object, 3),
        "obstacle_velocities": (sizes.max_objects, 2),
        "pose_circles": (sizes.k_pose * sizes.circles_per_object, 3),
        "pose_velocities": (sizes.k_pose, 2),
        "pose_mask": (config.horizon.n_steps + 1, sizes.k_pose),
        "map_frame": (FRAME_COLUMNS, 1),
        "map_table": (cells, 1),
        "nav_frame": (FRAME_COLUMNS, 1),
        "nav_table": (cells, 1),
        "settings": (len(settings_block.names(config)), 1),
    }


# --- the graph ----------------------------------------------------------------------------


def table_lookup(sizes: GraphSizes):
    """Bilinear interpolation of a (table_cells x table_cells) parametric table at one point.

    ``(uv 2 x 1 in cell units, table) -> value``. Called once per point in MX: each call reads
    the table in place (a mapped call copied it per point; see docs/nlp.md).
    """
    cells = [float(i) for i in range(sizes.table_cells)]
    return ca.interpolant("bilinear", "linear", [cells, cells], 1,
                          {"lookup_mode": ["exact", "exact"]})


def _lookups(lookup, uv, table):
    """``lookup`` at every column of ``uv`` (MX, 2 x n): a row 1 x n."""
    return ca.horzcat(*(lookup(uv[:, i], table) for i in range(uv.shape[1])))


def _cell_coordinates(points, frame):
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
    return ca.horzcat(*(points + res * ca.DM([dx, dy]) for dx, dy in _STENCIL))


def _rollout(z, state, config, smoothing):
    """Poses (3 x (N+1)), speeds and turn rates (N x 1 each) of the law from ``state``."""
    target = ca.vertcat(*target_pose([z[0], z[1], z[2]], [state[0], state[1], state[2]], CASADI))
    # SQP iterates can leave the box by the QP's tolerance (seen: v_max = -2.8e-3); a negative
    # v_max makes the law's smooth speed cap NaN (a negative base to the power 1/t).
    v_max = ca.fmax(z[3], 0.0)
    carry, poses, vs, omegas = state, [state[:3]], [], []
    for _ in range(config.horizon.n_steps):
        carry, v, omega = step(ca.vertsplit(carry), ca.vertsplit(target), v_max, config,
                               smoothing, CASADI)
        carry = ca.vertcat(*carry)
        poses.append(carry[:3])
        vs.append(v)
        omegas.append(omega)
    return ca.horzcat(*poses), ca.vertcat(*vs), ca.vertcat(*omegas)


def _circle_centres(poses, config):
    """Footprint circle centres, 2 x ((N+1) C), pose-major."""
    columns = []
    for k in range(poses.shape[1]):
        for cx, cy, _ in config.robot.footprint:
            x, y = body_to_world(poses[:, k], cx, cy, ca)
            columns.append(ca.vertcat(x, y))
    return ca.horzcat(*columns)


def _stencil_coordinates(points, frame):
    """Cell coordinates (2 x 5n) of the stencil points and their outside distances (1 x 5n)."""
    return _cell_coordinates(_stencil_points(points, frame), frame)


def _central(values, n, res):
    """``(value, gx, gy)`` rows (1 x n each) from stencil-major look-ups (1 x 5n)."""
    block = [values[:, i * n:(i + 1) * n] for i in range(len(_STENCIL))]
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


def _static_geometry(poses, speeds, d, gx, gy, config, smoothing):
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


def _dynamic_geometry(pose, speed, time, circles, velocities, config, smoothing, sizes):
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


def _ray_points(end, config, sizes):
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


def _ray_inverse_ttc(gaps, along, speed, smoothing):
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


def _symbols(config, sizes):
    """SX symbols of the small parameter blocks (not the tables, not the settings)."""
    shapes = parameter_shapes(config, sizes)
    return {name: ca.SX.sym(name, *shape) for name, shape in shapes.items()
            if not name.endswith("_table") and name != "settings"}


def _symbolic(config, smoothing):
    """A fresh ``settings`` SX vector and the configuration and smoothing read from it
    (:func:`.settings.symbolic`): every SX piece takes the settings as its last input."""
    q = ca.SX.sym("settings", len(settings_block.names(config)))
    return (q, *settings_block.symbolic(config, q, smoothing))


def _piece(name, inputs, outputs, fixed, positions):
    """A SX piece of the graph; with ``fixed``, its inputs at ``positions`` (parameters: they
    never depend on z) are marked not differentiable, so that a gradient in z does not carry
    their adjoints through every call (docs/nlp.md, "Pass 12")."""
    if not fixed:
        return ca.Function(name, inputs, outputs)
    flags = [i not in positions for i in range(len(inputs))]
    return ca.Function(name, inputs, outputs, {"is_diff_in": flags})


def _pose_functions(config, sizes, smoothing, fixed=False):
    """SX pieces of one pose: where it reads the map table, and the map's geometry from the
    reads.

    ``pose_query(pose, map_frame, settings) -> uv`` (2 x 5C) and ``pose_geometry(pose, speed,
    raw 1 x 5C, map_frame, settings) -> (distance, inv_ttc)`` (scalars) against the map.
    """
    p = _symbols(config, sizes)
    q, config, smoothing = _symbolic(config, smoothing)
    pose, speed = ca.SX.sym("pose", 3), ca.SX.sym("speed")
    n_c = len(config.robot.footprint)
    raw = ca.SX.sym("raw", 1, len(_STENCIL) * n_c)
    frame = p["map_frame"]
    centres = _circle_centres(pose, config)
    uv, outside = _stencil_coordinates(centres, frame)
    query = _piece("dsmpepc_pose_query", [pose, frame, q], [uv], fixed, (1, 2))
    d, gx, gy = _central(raw + outside, n_c, frame[2])
    static_d, static_inv = _static_geometry(pose, [speed], d, gx, gy, config, smoothing)
    inverse = static_inv[0] if config.anticipatory_pc else ca.SX(0)
    geometry = _piece("dsmpepc_pose_geometry", [pose, speed, raw, frame, q],
                      [static_d[0], inverse], fixed, (3, 4))
    return query, geometry


def _object_function(config, sizes, smoothing, fixed=False):
    """``object_kept(mask, pose, speed, step, circles C_obj x 3, velocity 1 x 2, settings) ->
    1 - P_c`` of one dynamic object at pose ``step`` (``costs.collision_probability``), or
    exactly 1 without computing anything where ``mask`` is 0 (a CasADi conditional: the object
    cannot come within ``CULL_SIGMAS`` sigma of that pose, where ``1 - P_c == 1.0`` exactly;
    see :func:`pose_mask`)."""
    q, config, smoothing = _symbolic(config, smoothing)
    pose, speed, k = ca.SX.sym("pose", 3), ca.SX.sym("speed"), ca.SX.sym("step")
    circles = ca.SX.sym("circles", sizes.circles_per_object, 3)
    velocity = ca.SX.sym("velocity", 1, 2)
    distance, inverse = _dynamic_geometry(pose, speed, k * config.horizon.dt, circles, velocity,
                                          config, smoothing, sizes)
    kept = 1.0 - collision_probability(distance, inverse, config.cost.sigma_dynamic, config,
                                       smoothing, CASADI)
    inputs = [pose, speed, k, circles, velocity, q]
    near = _piece("dsmpepc_object_kept", inputs, [kept], fixed, (2, 3, 4, 5))
    # Exactly 1 with a zero derivative, written so that it reads every input: its adjoint is
    # then dense like the computation's, and the conditional's reverse mode writes it without
    # projecting a structurally zero one, a measurable share of a gradient (docs/nlp.md).
    far = _piece("dsmpepc_object_far", inputs,
                 [ca.fmax(1.0, -ca.fabs(ca.sum1(ca.vertcat(*(ca.vec(x) for x in inputs)))))],
                 fixed, (2, 3, 4, 5))
    # Index 0 (mask 0) is the far branch; any other index runs the default, the computation.
    return ca.Function.conditional("dsmpepc_object_if", [far], near)


def _terminal_functions(config, sizes, smoothing, fixed=False):
    """``ray_query(end, map_frame, settings) -> uv`` (2 x MC) and ``terminal(end, raw 1 x MC,
    map_frame, circles, velocities, settings) -> 1/TTC`` at v_limit along the terminal
    heading."""
    p = _symbols(config, sizes)
    q, config, smoothing = _symbolic(config, smoothing)
    end, frame = ca.SX.sym("end", 3), p["map_frame"]
    m = ray_samples(config, sizes)
    raw = ca.SX.sym("raw", 1, m * len(config.robot.footprint))
    points, along = _ray_points(end, config, sizes)
    uv, outside = _cell_coordinates(points, frame)
    query = _piece("dsmpepc_ray_query", [end, frame, q], [uv], fixed, (1, 2))
    speed = config.robot.v_limit
    gaps = raw + outside
    static = [_ray_inverse_ttc(gaps[:, c * m:(c + 1) * m] - radius, along, speed, smoothing)
              for c, (_, _, radius) in enumerate(config.robot.footprint)]
    _, dyn = _dynamic_geometry(end, speed, config.horizon.n_steps * config.horizon.dt,
                               p["obstacle_circles"], p["obstacle_velocities"], config,
                               smoothing, sizes)
    inv = softmax_objects(ca.horzcat(*static, dyn), smoothing.inverse_time, CASADI)
    terminal = _piece("dsmpepc_terminal", [end, raw, frame, p["obstacle_circles"],
                                           p["obstacle_velocities"], q], [inv], fixed,
                      (2, 3, 4, 5))
    return query, terminal


def _nav_points(poses, frame):
    """Where the NF is read: every pose's position, then the end's four neighbours."""
    end = poses[:2, -1]
    res = frame[2]
    return ca.horzcat(poses[:2, :], *(end + res * ca.DM([dx, dy]) for dx, dy in _STENCIL[1:]))


def _final_functions(config, sizes, smoothing, fixed=False):
    """``nav_query(poses, nav_frame) -> uv`` and ``assemble(poses, v, omega, goal, nav_frame,
    nav_raw, distance, inv_ttc, kept, inv_term, settings) -> (cost, *terms)`` through
    ``costs.assemble`` (``distance``, ``inv_ttc``: the map's, (N+1) x 1; ``kept``: the
    dynamic objects' product of ``1 - P_c`` per pose, (N+1) x 1)."""
    p = _symbols(config, sizes)
    q, config, smoothing = _symbolic(config, smoothing)
    n_steps = config.horizon.n_steps
    poses = ca.SX.sym("poses", 3, n_steps + 1)
    vs, omegas = ca.SX.sym("v", n_steps), ca.SX.sym("omega", n_steps)
    goal, frame = p["goal"], p["nav_frame"]
    uv, outside = _cell_coordinates(_nav_points(poses, frame), frame)
    query = _piece("dsmpepc_nav_query", [poses, frame], [uv], fixed, (1,))
    raw = ca.SX.sym("nav_raw", 1, n_steps + 5)
    values = raw + outside
    n = n_steps + 1
    table_nf = values[:, :n]
    grad = ((values[n] - values[n + 1]) / (2 * frame[2]),
            (values[n + 2] - values[n + 3]) / (2 * frame[2]))
    dx, dy = poses[0, :] - goal[0], poses[1, :] - goal[1]
    norm = ca.sqrt(dx * dx + dy * dy + 1e-12)
    euclid = goal[2]
    nf = euclid * norm + (1 - euclid) * table_nf
    descent = -ca.vertcat(euclid * dx[-1] / norm[-1] + (1 - euclid) * grad[0],
                          euclid * dy[-1] / norm[-1] + (1 - euclid) * grad[1])
    distance, inverse = ca.SX.sym("distance", n, 1), ca.SX.sym("inv_ttc", n, 1)
    kept, inv_term = ca.SX.sym("kept", n, 1), ca.SX.sym("inv_term")
    end = poses[:, -1]
    err = heading_error(end[2], descent[0], descent[1], CASADI, smoothing)
    # The TTG bell is s_ttg = 1e-3 1/s wide: its soft-clip runs at the same share of the bell's
    # width as 1/TTC's (inverse_time * s_ttg / s_ttc), else C_TTG ~ 0 where it is exactly 1.
    ttg_smoothing = copy.copy(smoothing)
    if not is_exact(smoothing.inverse_time):
        object.__setattr__(ttg_smoothing, "inverse_time",
                           smoothing.inverse_time * config.cost.s_ttg / config.cost.s_ttc)
    inv_ttg = terminal_inverse_ttg((end[0], end[1], end[2]), vs[-1], goal, nf[-1], descent,
                                   config, CASADI, ttg_smoothing)
    sigma = ca.DM.ones(n, 1) * config.cost.sigma_static
    total, terms, _ = assemble(distance, inverse, sigma, nf.T, vs, omegas, err, inv_ttg,
                               inv_term, config, smoothing, CASADI, kept=kept)
    final = _piece("dsmpepc_assemble",
                   [poses, vs, omegas, goal, frame, raw, distance, inverse, kept, inv_term, q],
                   [total, *(terms[t] for t in TERM_NAMES)], fixed, (3, 4, 10))
    return query, final


def resolved_sizes(config: PlannerConfig, sizes: GraphSizes) -> GraphSizes:
    """``sizes`` with its terminal ray's sample count resolved (:func:`ray_samples`): what a
    compiled library's key holds."""
    return dataclasses.replace(sizes, ray_samples=ray_samples(config, sizes))


def build_cost_function(config: PlannerConfig, sizes: GraphSizes, smoothing=None,
                        fixed_parameters: bool = False) -> ca.Function:
    """The smooth cost as a ``casadi.Function`` named ``dsmpepc_cost``.

    Inputs: ``z`` (4) and the blocks of :data:`PARAMETER_NAMES` (shapes from
    :func:`parameter_shapes`, values from :func:`pack_parameters`; the configuration's numbers
    are the ``settings`` block, so one graph serves every configuration of the same
    :func:`.settings.structure`). Outputs: ``cost`` and each term of
    :data:`~dsmpepc_nlp.core.config.TERM_NAMES`. A ``smoothing`` other than the configuration's
    is built in as constants.

    An MX graph of small SX functions (the rollout, one pose's geometry called N+1 times, the
    terminal ray, the assembly) and the table look-ups: each piece and its derivatives exist
    once in generated code, so it compiles in seconds, not minutes. With ``fixed_parameters``
    (the solvers' graph) derivatives exist in ``z`` alone: every parameter block is marked
    not differentiable.
    """
    sizes = resolved_sizes(config, sizes)
    fixed = fixed_parameters
    shapes = parameter_shapes(config, sizes)
    n_steps = config.horizon.n_steps
    z_sx, state_sx = ca.SX.sym("z", 4), ca.SX.sym("state", 5)
    q, sym_config, sym_smoothing = _symbolic(config, smoothing)
    rollout = _piece("dsmpepc_rollout", [z_sx, state_sx, q],
                     list(_rollout(z_sx, state_sx, sym_config, sym_smoothing)), fixed, (1, 2))
    pose_query, pose_geometry = _pose_functions(config, sizes, smoothing, fixed)
    object_kept = _object_function(config, sizes, smoothing, fixed)
    ray_query, terminal = _terminal_functions(config, sizes, smoothing, fixed)
    nav_query, final = _final_functions(config, sizes, smoothing, fixed)
    lookup = table_lookup(sizes)
    z = ca.MX.sym("z", 4)
    p = {name: ca.MX.sym(name, *shape) for name, shape in shapes.items()}
    settings = p["settings"]
    objects = (p["obstacle_circles"], p["obstacle_velocities"])
    c_obj = sizes.circles_per_object
    poses, vs, omegas = rollout(z, p["state"], settings)
    distances, inverses, kept = [], [], []
    for k in range(n_steps + 1):
        pose, speed = poses[:, k], vs[min(k, n_steps - 1)]
        raw = _lookups(lookup, pose_query(pose, p["map_frame"], settings), p["map_table"])
        d, inv = pose_geometry(pose, speed, raw, p["map_frame"], settings)
        distances.append(d)
        inverses.append(inv)
        product = ca.MX(1.0)
        for j in range(sizes.k_pose):
            product = product * object_kept(p["pose_mask"][k, j], pose, speed, k,
                                             p["pose_circles"][j * c_obj:(j + 1) * c_obj, :],
                                             p["pose_velocities"][j, :], settings)
        kept.append(product)
    inv_term = ca.MX(0)
    if sym_config.terminal_cost:        # always: MPEPC's is the switch's 0 (settings.py)
        end = poses[:, -1]
        raw = _lookups(lookup, ray_query(end, p["map_frame"], settings), p["map_table"])
        inv_term = terminal(end, raw, p["map_frame"], *objects, settings)
    nav_raw = _lookups(lookup, nav_query(poses, p["nav_frame"]), p["nav_table"])
    outputs = final(poses, vs, omegas, p["goal"], p["nav_frame"], nav_raw,
                    ca.vertcat(*distances), ca.vertcat(*inverses), ca.vertcat(*kept), inv_term,
                    settings)
    return ca.Function("dsmpepc_cost", [z, *(p[n] for n in PARAMETER_NAMES)], outputs,
                       ["z", *PARAMETER_NAMES], ["cost", *TERM_NAMES])

# --- packing the world into parameters (numpy) ----------------------------------------------


def pack_obstacles(cycle, sizes: GraphSizes, k_max: int | None = None,
                   reach_only: bool = False):
    """``(circles, velocities, indices)`` of the ``k_max`` objects that come nearest to the
    robot's start.

    Returns ``circles`` ((K C_obj), 3: x, y, radius now), ``velocities`` (K, 2) and
    ``indices`` ((K C_obj,): each packed circle's index among the cycle's circles, -1 for
    padding); padding objects sit FAR away. ``k_max`` defaults to ``sizes.max_objects``; with
    ``reach_only`` only the objects the robot can reach within the horizon are candidates
    (``Cycle.in_reach``: the others change no bit of the collision probability).
    """
    k_max = sizes.max_objects if k_max is None else k_max
    c_obj = sizes.circles_per_object
    circles = np.tile([FAR, FAR, 0.1], (k_max * c_obj, 1))
    velocities = np.zeros((k_max, 2))
    indices = np.full(k_max * c_obj, -1)
    owner = cycle.owner
    if len(owner) == 0 or k_max == 0:
        return circles, velocities, indices
    position = np.array([cycle.state.x, cycle.state.y])
    gap = np.min(np.linalg.norm(cycle.predicted - position, axis=-1), axis=0) - cycle.radii
    n_obj = int(owner.max()) + 1
    per_object = np.full(n_obj, np.inf)
    np.minimum.at(per_object, owner, gap)
    candidates = np.argsort(per_object, kind="stable")
    if reach_only:
        reach = np.asarray(cycle.in_reach, dtype=bool)[:n_obj]
        candidates = candidates[reach[candidates]]
    count = np.bincount(owner, minlength=n_obj)
    chosen = candidates[count[candidates] > 0][:k_max]
    # Each object's circles nearest first (ties by index: a stable sort by owner, then gap),
    # the first c_obj of each chosen object; padding circles repeat the nearest one (the min
    # over circles is unchanged). Vectorised: a loop over objects was slower.
    order = np.lexsort((gap, owner))
    first = np.searchsorted(owner[order], chosen)
    column = np.arange(c_obj)
    near = order[first[:, None] + np.where(column < count[chosen][:, None], column, 0)]
    flat, m = near.reshape(-1), near.size
    circles[:m] = np.column_stack([cycle.centers[flat], cycle.radii[flat]])
    velocities[:len(chosen)] = cycle.velocities[near[:, 0]]
    indices[:m] = flat
    return circles, velocities, indices


def pose_mask(cycle, indices, circles_per_object: int) -> np.ndarray:
    """``(N+1, K)``: 1 where the packed object ``j`` may matter at pose ``k``, else 0.

    ``indices`` are the packed circles' indices among the cycle's (:func:`pack_obstacles`,
    -1 for padding); the graph moves them as the cycle predicts them (constant velocity). An
    object is 0 at a pose where ``Cycle.reach_bounds`` of every circle of it is at least
    ``CULL_SIGMAS * sigma_dynamic``: there ``1 - P_c`` is 1.0 exactly for every z in the box,
    so the graph skips it (the bound that leaves whole objects out of a cycle, per pose; in
    the crowded demo scene about 70 % of the pose-object pairs).
    """
    bounds = np.full((cycle.reach_bounds.shape[0], len(indices)), np.inf)
    real = indices >= 0
    bounds[:, real] = cycle.reach_bounds[:, indices[real]]
    per_object = bounds.reshape(len(bounds), -1, circles_per_object).min(axis=2)
    return (per_object < CULL_SIGMAS * cycle.config.cost.sigma_dynamic).astype(float)


def objects_in_reach(cycle) -> int:
    """How many dynamic objects the robot can reach within the horizon this cycle."""
    return int(np.count_nonzero(cycle.in_reach))


def pack_table(table, resolution, origin, centre, cells: int) -> tuple:
    """``(frame, values)``: a window of ``cells`` x ``cells`` of ``table`` (ny, nx) around
    ``centre``, as the graph reads it (x fastest); the whole table when it fits."""
    ny, nx = table.shape
    u0 = int(np.clip(np.floor((centre[0] - origin[0]) / resolution) - cells // 2, 0,
                     max(nx - cells, 0)))
    v0 = int(np.clip(np.floor((centre[1] - origin[1]) / resolution) - cells // 2, 0,
                     max(ny - cells, 0)))
    window = table[v0:v0 + cells, u0:u0 + cells]
    values = np.zeros((cells, cells))
    values[:window.shape[0], :window.shape[1]] = window
    frame = np.array([origin[0] + u0 * resolution, origin[1] + v0 * resolution, resolution,
                      window.shape[1], window.shape[0]], dtype=float)
    return frame, values.reshape(-1)


def pack_parameters(cycle, sizes: GraphSizes) -> dict:
    """Every parameter block of :func:`build_cost_function` from a prepared ``Cycle``.

    Returns a dict over :data:`PARAMETER_NAMES` of numpy arrays shaped by
    :func:`parameter_shapes`. The measured ``(v, omega)`` is clamped to the limits.
    """
    state, config, cells = cycle.state, cycle.config, sizes.table_cells
    v0, omega0 = clamp_measured(state, config)
    circles, velocities, _ = pack_obstacles(cycle, sizes)
    pose_circles, pose_velocities, pose_indices = pack_obstacles(cycle, sizes, sizes.k_pose,
                                                                 reach_only=True)
    centre = (state.x, state.y)
    grid = cycle.world.grid
    if grid is None:
        map_frame = np.array([state.x - 1.0, state.y - 1.0, 1.0, 2.0, 2.0])
        map_table = np.full(cells * cells, FAR)
    else:
        map_frame, map_table = pack_table(grid.signed_distance, grid.resolution, grid.origin,
                                          centre, cells)
    nav = cycle.navigation
    if nav.values is None:
        nav_frame, nav_table, euclidean = map_frame, np.zeros(cells * cells), 1.0
    else:
        work = nav.working_grid
        nav_frame, nav_table = pack_table(nav.values, work.resolution, work.origin, centre,
                                          cells)
        euclidean = 0.0
    goal = np.asarray(cycle.goal, dtype=float).reshape(2)
    return {
        "state": np.array([state.x, state.y, state.phi, v0, omega0]),
        "goal": np.array([goal[0], goal[1], euclidean]),
        "obstacle_circles": circles,
        "obstacle_velocities": velocities,
        "pose_circles": pose_circles,
        "pose_velocities": pose_velocities,
        "pose_mask": pose_mask(cycle, pose_indices, sizes.circles_per_object),
        "map_frame": map_frame,
        "map_table": map_table,
        "nav_frame": nav_frame,
        "nav_table": nav_table,
        "settings": settings_block.values(config),
    }


def flatten_parameters(params: dict) -> np.ndarray:
    """The blocks as one vector, each column-major (CasADi's ``vec``), in PARAMETER_NAMES order:
    the flat ``p`` the solvers and the compiled functions take."""
    return np.concatenate([np.asarray(params[n], dtype=float).reshape(-1, order="F")
                           for n in PARAMETER_NAMES])


def is_finite_parameters(params: dict) -> bool:
    """True when every block is finite."""
    return all(np.all(np.isfinite(params[n])) for n in PARAMETER_NAMES)


def flat_cost(config: PlannerConfig, sizes: GraphSizes, smoothing=None) -> ca.Function:
    """The cost as ``(z, p) -> f`` with ``p`` the flat vector of :func:`flatten_parameters`
    (what the solvers and the compiled code take; derivatives in ``z`` alone)."""
    cost = build_cost_function(config, sizes, smoothing, fixed_parameters=True)
    shapes = parameter_shapes(config, sizes)
    counts = [int(np.prod(shapes[n])) for n in PARAMETER_NAMES]
    z, p = ca.MX.sym("z", 4), ca.MX.sym("p", sum(counts))
    blocks = ca.vertsplit(p, np.cumsum([0, *counts]).tolist())
    blocks = [ca.reshape(b, *shapes[n]) for b, n in zip(blocks, PARAMETER_NAMES)]
    # Inlined (not a call of ``cost``): a call's reverse sweep would also build the adjoint
    # of every parameter, the two 65k-entry tables included, on every gradient.
    return ca.Function("dsmpepc_flat_cost", [z, p], [cost.call([z, *blocks], True, False)[0]])


def cost_function(config: PlannerConfig, sizes: GraphSizes | None = None,
                  smoothing=None) -> ca.Function:
    """The smooth DS-MPEPC cost as a ``casadi.Function`` to embed in your own problem.

    Parameters
    ----------
    config : PlannerConfig
        Method and parameters; the temperatures come from ``config.smoothing`` unless
        ``smoothing`` is given (``SmoothingConfig.exact()`` gives the non-smooth forms).
    sizes : GraphSizes, optional
        Objects seen, table window and terminal ray samples.

    Returns
    -------
    casadi.Function
        Named inputs ``z`` (4: r [m], theta [rad], delta [rad], v_max [m/s]) and the blocks of
        :data:`PARAMETER_NAMES` (from :func:`pack_parameters` of a prepared ``Cycle``); named
        outputs ``cost``, ``progress``, ``action``, ``collision``, ``heading``, ``terminal``.

    Examples
    --------
    >>> f = cost_function(PlannerConfig())                       # doctest: +SKIP
    >>> params = pack_parameters(Cycle.prepare(state, world, goal, config), GraphSizes())
    ...                                                          # doctest: +SKIP
    >>> f(z=[2.0, 0.0, 0.0, 0.8], **params)["cost"]              # doctest: +SKIP
    """
    return build_cost_function(config, GraphSizes() if sizes is None else sizes, smoothing)


__all__ = ["GraphSizes", "PARAMETER_NAMES", "build_cost_function",
           "cost_function", "flat_cost", "flatten_parameters", "pack_parameters", "pack_table",
           "parameter_shapes", "is_finite_parameters", "pose_mask", "ray_samples"]
