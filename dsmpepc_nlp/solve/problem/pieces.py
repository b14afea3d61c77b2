"""The small SX functions the graph calls: one pose's map geometry, one dynamic object's
``1 - P_c``, the terminal ray, and the assembly through ``costs.assemble``. Each takes the
``settings`` vector last, so one compiled piece serves every configuration of a structure."""

from __future__ import annotations

import copy

import casadi as ca

from ...core.costs import (
    assemble,
    collision_probability,
    dynamic_sigma,
    heading_error,
    inverse_ttg,
)
from ...core.smooth import CASADI, is_exact, softmax_objects
from ...core.terms import TERM_NAMES
from . import parameters as settings_block
from .geometry import (
    STENCIL,
    cell_coordinates,
    central,
    circle_centres,
    dynamic_geometry,
    nav_points,
    ray_inverse_ttc,
    ray_points,
    static_geometry,
    stencil_coordinates,
)
from .layout import parameter_shapes, ray_samples


def _symbols(config, sizes):
    """SX symbols of the small parameter blocks (not the tables, not the settings)."""
    shapes = parameter_shapes(config, sizes)
    return {name: ca.SX.sym(name, *shape) for name, shape in shapes.items()
            if not name.endswith("_table") and name != "settings"}


def symbolic(config, smoothing):
    """A fresh ``settings`` SX vector and the configuration and smoothing read from it
    (:func:`.settings.symbolic`): every SX piece takes the settings as its last input."""
    q = ca.SX.sym("settings", len(settings_block.names(config)))
    return (q, *settings_block.symbolic(config, q, smoothing))


def piece(name, inputs, outputs, fixed, positions):
    """A SX piece of the graph; with ``fixed``, its inputs at ``positions`` (parameters: they
    never depend on z) are marked not differentiable, so that a gradient in z does not carry
    their adjoints through every call (docs/experiments/2026-11-24-compile-per-structure.md)."""
    if not fixed:
        return ca.Function(name, inputs, outputs)
    flags = [i not in positions for i in range(len(inputs))]
    return ca.Function(name, inputs, outputs, {"is_diff_in": flags})


def pose_functions(config, sizes, smoothing, fixed=False):
    """SX pieces of one pose: where it reads the map table, and the map's geometry from the
    reads.

    ``pose_query(pose, map_frame, settings) -> uv`` (2 x 5C) and ``pose_geometry(pose, speed,
    raw 1 x 5C, map_frame, settings) -> (distance, inv_ttc)`` (scalars) against the map.
    """
    p = _symbols(config, sizes)
    q, config, smoothing = symbolic(config, smoothing)
    pose, speed = ca.SX.sym("pose", 3), ca.SX.sym("speed")
    n_c = len(config.robot.footprint)
    raw = ca.SX.sym("raw", 1, len(STENCIL) * n_c)
    frame = p["map_frame"]
    centres = circle_centres(pose, config)
    uv, outside = stencil_coordinates(centres, frame)
    query = piece("dsmpepc_pose_query", [pose, frame, q], [uv], fixed, (1, 2))
    d, gx, gy = central(raw + outside, n_c, frame[2])
    static_d, static_inv = static_geometry(pose, [speed], d, gx, gy, config, smoothing)
    inverse = static_inv[0] if config.anticipatory_pc else ca.SX(0)
    geometry = piece("dsmpepc_pose_geometry", [pose, speed, raw, frame, q],
                      [static_d[0], inverse], fixed, (3, 4))
    return query, geometry


def object_function(config, sizes, smoothing, fixed=False):
    """``object_kept(mask, pose, speed, step, circles C_obj x 3, velocity 1 x 2, settings) ->
    1 - P_c`` of one dynamic object at pose ``step`` (``costs.collision_probability``), or
    exactly 1 without computing anything where ``mask`` is 0 (a CasADi conditional: the object
    cannot come within ``CULL_SIGMAS`` sigma of that pose, where ``1 - P_c == 1.0`` exactly;
    see :func:`pose_mask`)."""
    q, config, smoothing = symbolic(config, smoothing)
    pose, speed, k = ca.SX.sym("pose", 3), ca.SX.sym("speed"), ca.SX.sym("step")
    circles = ca.SX.sym("circles", sizes.circles_per_object, 3)
    velocity = ca.SX.sym("velocity", 1, 2)
    distance, inverse = dynamic_geometry(pose, speed, k * config.horizon.dt, circles, velocity,
                                          config, smoothing, sizes)
    sigma = dynamic_sigma(k * config.horizon.dt, config.cost)
    kept = 1.0 - collision_probability(distance, inverse, sigma, config, smoothing, CASADI)
    inputs = [pose, speed, k, circles, velocity, q]
    parameters = (2, 3, 4, 5)
    near = piece("dsmpepc_object_kept", inputs, [kept], fixed, parameters)
    # Exactly 1 with a zero derivative, written so that it reads every differentiable input:
    # its adjoint is then dense like the computation's, and the conditional's reverse mode
    # writes it without projecting a structurally zero one, a measurable share of a gradient
    # (docs/design.md). Inputs marked not differentiable have no adjoint, so it need not read
    # them (the settings alone were 37 additions a call, on every far pose of every object).
    read = [x for i, x in enumerate(inputs) if not (fixed and i in parameters)]
    far = piece("dsmpepc_object_far", inputs,
                 [ca.fmax(1.0, -ca.fabs(ca.sum1(ca.vertcat(*(ca.vec(x) for x in read)))))],
                 fixed, parameters)
    # Index 0 (mask 0) is the far branch; any other index runs the default, the computation.
    return ca.Function.conditional("dsmpepc_object_if", [far], near)


def terminal_functions(config, sizes, smoothing, fixed=False):
    """``ray_query(end, map_frame, settings) -> uv`` (2 x MC) and ``terminal(end, raw 1 x MC,
    map_frame, circles, velocities, settings) -> 1/TTC`` at v_limit along the terminal
    heading."""
    p = _symbols(config, sizes)
    q, config, smoothing = symbolic(config, smoothing)
    end, frame = ca.SX.sym("end", 3), p["map_frame"]
    m = ray_samples(config, sizes)
    raw = ca.SX.sym("raw", 1, m * len(config.robot.footprint))
    points, along = ray_points(end, config, sizes)
    uv, outside = cell_coordinates(points, frame)
    query = piece("dsmpepc_ray_query", [end, frame, q], [uv], fixed, (1, 2))
    speed = config.robot.v_limit
    gaps = raw + outside
    static = [ray_inverse_ttc(gaps[:, c * m:(c + 1) * m] - radius, along, speed, smoothing)
              for c, (_, _, radius) in enumerate(config.robot.footprint)]
    _, dyn = dynamic_geometry(end, speed, config.horizon.n_steps * config.horizon.dt,
                               p["obstacle_circles"], p["obstacle_velocities"], config,
                               smoothing, sizes)
    inv = softmax_objects(ca.horzcat(*static, dyn), smoothing.inverse_time, CASADI)
    terminal = piece("dsmpepc_terminal", [end, raw, frame, p["obstacle_circles"],
                                           p["obstacle_velocities"], q], [inv], fixed,
                      (2, 3, 4, 5))
    return query, terminal


def final_functions(config, sizes, smoothing, fixed=False):
    """``nav_query(poses, nav_frame) -> uv`` and ``assemble(poses, v, omega, goal, nav_frame,
    nav_raw, distance, inv_ttc, kept, inv_term, settings) -> (cost, *terms)`` through
    ``costs.assemble`` (``distance``, ``inv_ttc``: the map's, (N+1) x 1; ``kept``: the
    dynamic objects' product of ``1 - P_c`` per pose, (N+1) x 1)."""
    p = _symbols(config, sizes)
    q, config, smoothing = symbolic(config, smoothing)
    n_steps = config.horizon.n_steps
    poses = ca.SX.sym("poses", 3, n_steps + 1)
    vs, omegas = ca.SX.sym("v", n_steps), ca.SX.sym("omega", n_steps)
    goal, frame = p["goal"], p["nav_frame"]
    uv, outside = cell_coordinates(nav_points(poses, frame), frame)
    query = piece("dsmpepc_nav_query", [poses, frame], [uv], fixed, (1,))
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
    inv_ttg = inverse_ttg((end[0], end[1], end[2]), vs[-1], goal, CASADI, ttg_smoothing)
    sigma = ca.DM.ones(n, 1) * config.cost.sigma_static
    total, terms, _ = assemble(distance, inverse, sigma, nf.T, vs, omegas, err, inv_ttg,
                               inv_term, config, smoothing, CASADI, kept=kept)
    final = piece("dsmpepc_assemble",
                   [poses, vs, omegas, goal, frame, raw, distance, inverse, kept, inv_term, q],
                   [total, *(terms[t] for t in TERM_NAMES)], fixed, (3, 4, 10))
    return query, final
