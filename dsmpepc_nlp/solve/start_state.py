"""The start of a plan: the state as a caller may give it, whether the robot's footprint
already overlaps the map or an obstacle there, and what a robot in collision does: it brakes as
hard as its limits allow and moves no other way (the paper's Lemma 3)."""

from __future__ import annotations

import math

import numpy as np

from ..core.config import PlannerConfig, RobotConfig, RobotState
from ..core.control_law import Trajectory, arc_step, rate_limit, rollout, stacked
from ..core.errors import InputError
from ..core.exact_cost import evaluate
from ..core.geometry import body_to_world
from .optimize.starts import stop_z
from .plan import Plan, unmeasured


def as_state(state) -> RobotState:
    """``state`` as a :class:`RobotState`: one already, or ``(x, y, phi[, v, omega])``."""
    if isinstance(state, RobotState):
        return state
    try:
        values = np.asarray(state, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        values = None
    if values is None or values.size not in (3, 5) or np.ndim(state) != 1:
        shown = repr(state) if np.size(state) <= 10 else f"an array of shape {np.shape(state)}"
        raise InputError(f"state = {shown}: must be a RobotState or (x, y, phi[, v, omega]) "
                         "in m, m, rad, m/s, rad/s")
    return RobotState(*(float(v) for v in values))


def start_overlap(state: RobotState, world, config: PlannerConfig) -> str:
    """Words naming the deepest overlap of the footprint at ``state`` with the map or a
    dynamic obstacle (distance, which one), or "" when the start is free."""
    circles = np.array(config.robot.footprint, dtype=float)
    centers = np.stack(body_to_world(state.pose, circles[:, 0], circles[:, 1]), axis=1)
    worst, words = 0.0, ""
    static = np.asarray(world.static_distance(centers)) - circles[:, 2]
    if static.size and float(static.min()) < worst:
        i = int(np.argmin(static))
        worst = float(static[i])
        x, y = (float(c) for c in centers[i])
        words = f"the map's occupied cells, around ({x:.2f}, {y:.2f}) m"
    obstacles, radii, _, owner = world.stacked_obstacles()
    if len(radii):
        gaps = (np.linalg.norm(centers[:, None, :] - obstacles[None], axis=-1)
                - circles[:, 2, None] - radii[None])
        i, k = np.unravel_index(int(np.argmin(gaps)), gaps.shape)
        if float(gaps[i, k]) < worst:
            worst = float(gaps[i, k])
            kind = world.obstacles[int(owner[k])].kind
            x, y = (float(c) for c in obstacles[k])
            words = f"obstacle {int(owner[k])} (a {kind} at ({x:.2f}, {y:.2f}) m)"
    if not words:
        return ""
    return (f"start in collision: the footprint at ({state.x:.2f}, {state.y:.2f}) m overlaps "
            f"{words} by {-worst:.3f} m")


def bounded_control(v: float, omega: float, robot: RobotConfig) -> tuple:
    """``(v, omega)`` inside the robot's declared limits: ``v`` in ``[-reverse_limit,
    v_limit]``, ``|omega| <= omega_limit``; a stop where either is not finite. Every plan's
    control passes through it last."""
    v, omega = float(v), float(omega)
    if not (math.isfinite(v) and math.isfinite(omega)):
        return (0.0, 0.0)
    return (min(max(v, -robot.reverse_limit), robot.v_limit),
            min(max(omega, -robot.omega_limit), robot.omega_limit))


def law_control(trajectory: Trajectory, config: PlannerConfig) -> tuple:
    """First command of a law's trajectory, forced finite and inside the limits (the law
    never reverses)."""
    v, omega = bounded_control(trajectory.v[0], trajectory.omega[0], config.robot)
    return (max(v, 0.0), omega)


def braking(state: RobotState, config: PlannerConfig) -> Trajectory:
    """The trajectory of a robot in collision (Lemma 3): from its measured ``(v, omega)``,
    each step brought toward 0 as hard as ``accel_limit`` and ``alpha_limit`` allow, within
    the limits of :func:`bounded_control`, then held at rest. It turns only while its turn
    rate brakes, and neither speeds up nor reverses."""
    robot, dt, n = config.robot, config.horizon.dt, config.horizon.n_steps
    poses = np.empty((n + 1, 3))
    poses[0] = state.pose
    v, omega = np.zeros(n), np.zeros(n)
    speed, turn = float(state.v), float(state.omega)
    for k in range(n):
        speed = float(rate_limit(0.0, speed, robot.accel_limit, dt, 0.0))  # toward 0
        turn = float(rate_limit(0.0, turn, robot.alpha_limit, dt, 0.0))
        speed, turn = bounded_control(speed, turn, robot)
        v[k], omega[k] = speed, turn
        poses[k + 1] = arc_step(poses[k], speed, turn, dt)
    return Trajectory(stop_z(config), poses, v, omega, poses[-1].copy())


def as_goal(goal) -> np.ndarray:
    """``goal`` as a finite ``(x, y)`` array; InputError otherwise."""
    try:
        goal = np.asarray(goal, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"goal = {goal!r}: must be a finite (x, y) pair") from None
    if goal.shape != (2,) or not np.all(np.isfinite(goal)):
        raise InputError(f"goal = {goal!r}: must be a finite (x, y) pair")
    return goal


def as_tolerance(value) -> float:
    """``Planner.plan``'s ``goal_tolerance`` as a float, or an InputError naming what is
    allowed."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if isinstance(value, bool) or not (math.isfinite(number) and number >= 0.0):
        raise InputError(f"goal_tolerance = {value!r}: must be a finite number of metres >= 0")
    return number



def braking_plan(state: RobotState, world, goal, overlap: str, config: PlannerConfig) -> Plan:
    """The plan of a robot whose footprint already overlaps the map or an object (``overlap``
    says which, :func:`start_overlap`): the :func:`braking` trajectory, whatever the preset,
    the solver or the stall ladder would do (the paper's Lemma 3: in a collision state the
    robot does not move); its exact cost, or inf when even that cannot be measured."""
    trajectory = braking(state, config)
    try:
        cost = evaluate(stacked([trajectory]), world, goal, config)[0]
        fun = float(cost.total) if math.isfinite(float(cost.total)) else math.inf
    except Exception:  # noqa: BLE001 - a robot in collision must still get its brake
        cost, fun = unmeasured(trajectory), math.inf
    v, omega = float(trajectory.v[0]), float(trajectory.omega[0])
    message = (f"{overlap}; braking as hard as the limits allow and moving no other way "
               f"(Lemma 3): v {state.v:.2f} -> {v:.2f} m/s, omega {state.omega:.2f} -> "
               f"{omega:.2f} rad/s")
    return Plan(trajectory.z, fun, False, message, 0, trajectory,
                bounded_control(v, omega, config.robot), cost, "start-in-collision", ())


def stop_plan(state: RobotState, records, config: PlannerConfig) -> Plan:
    """Nothing finite: the stop trajectory (v_max = 0), finite by construction.

    Its cost is reported as ``inf``: nothing could be measured, and a plan is never NaN.
    Should even the rollout fail, the robot holds its pose over the horizon.
    """
    z = stop_z(config)
    n_steps = config.horizon.n_steps
    try:
        trajectory = rollout(z, state, config)
    except Exception:  # noqa: BLE001 - the last resort must not raise
        pose = np.array(state.pose, dtype=float)
        trajectory = Trajectory(z, np.tile(pose, (n_steps + 1, 1)), np.zeros(n_steps),
                                np.zeros(n_steps), pose)
    message = ("stopped: no start, solve or sample had a finite cost (or every stage "
               "failed), so the robot brakes to a stop (v_max = 0); cost reported as inf")
    return Plan(z, math.inf, False, message, 0, trajectory, law_control(trajectory, config),
                unmeasured(trajectory), "stopped", tuple(records))


__all__ = ["as_state", "as_tolerance", "bounded_control", "braking", "braking_plan", "law_control",
           "start_overlap", "stop_plan"]
