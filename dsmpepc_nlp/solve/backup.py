"""The stall ladder's back-up rung: reverse trajectories the pose-following law cannot make.

The law turns only while it drives forward (its turn rate is the curvature times the speed),
so a robot that stands facing a person just ahead has no trajectory of its own that does not
first close the gap: every one costs more than standing, and the robot waits for as long as the
person stands (docs/results.md, "CrowdNav's stalls are a trap of the control law"). In the
spirit of Nav2's back-up recovery, when the chosen plan would stand and the stall ladder is at
``StallConfig.back_up_level`` or above (1 by default: stalled), or the robot expects to be
struck where the plan leaves it (``StallConfig.back_up_threat``), this rung sets a few reverse
trajectories against it, costed by the same exact cost (``exact_cost.evaluate``, the numpy
reference: the compiled kernel and the graph only ever see the law's forward trajectories),
and takes the cheapest when it is cheaper than the plan. ``StallConfig.back_up`` (m/s; 0 =
off) and ``back_up_time``; docs/method.md section 7.5.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.config import PlannerConfig
from ..core.control_law import Trajectory, arc_step, clamp_measured, rate_limit
from ..core.exact_cost import evaluate
from .records import Plan

TURN_RADIUS = 1.0
"""m: the curving back-ups turn at this radius (omega = speed / radius), either way."""


def back_up_speed(config: PlannerConfig) -> float:
    """The rung's reverse speed, m/s: ``stall.back_up`` capped at ``v_limit`` and at one plan
    period's braking (``accel_limit * dt``)."""
    robot = config.robot
    return min(config.stall.back_up, robot.v_limit, robot.accel_limit * config.horizon.dt)


def back_up_trajectories(state, config: PlannerConfig) -> Trajectory:
    """Three reverse trajectories from ``state``: straight back and curving back either way at
    :data:`TURN_RADIUS`, each commanding ``-stall.back_up`` m/s for ``stall.back_up_time``
    then 0, within the robot's acceleration limits from its measured speed and turn rate
    clipped to the forward limits (``clamp_measured``, as the law's rollouts start).

    The speed is capped at what one plan period's braking takes back (``accel_limit * dt``,
    0.3 m/s for the default robot), so the next plan's law starts from a stop: the law's
    rollout, the compiled kernel and the graph never see a reversing speed."""
    robot, dt, n = config.robot, config.horizon.dt, config.horizon.n_steps
    speed = back_up_speed(config)
    turn = min(speed / TURN_RADIUS, robot.omega_limit)
    reversing = int(round(config.stall.back_up_time / dt))
    poses = np.empty((3, n + 1, 3))
    v, omega = np.empty((3, n)), np.empty((3, n))
    start = clamp_measured(state, config)     # where the law's rollouts start too
    for i, sign in enumerate((0.0, 1.0, -1.0)):
        pose = np.array(state.pose, dtype=float)
        v_prev, omega_prev = start
        poses[i, 0] = pose
        for k in range(n):
            v_cmd, omega_cmd = (-speed, sign * turn) if k < reversing else (0.0, 0.0)
            v_prev = float(rate_limit(v_cmd, v_prev, robot.accel_limit, dt, 0.0))
            omega_prev = float(rate_limit(omega_cmd, omega_prev, robot.alpha_limit, dt, 0.0))
            pose = np.array(arc_step(pose, v_prev, omega_prev, dt))
            poses[i, k + 1], v[i, k], omega[i, k] = pose, v_prev, omega_prev
    stop = np.array([config.bounds.r_min, 0.0, 0.0, 0.0])
    return Trajectory(np.tile(stop, (3, 1)), poses, v, omega, poses[:, -1].copy())


def stands(plan: Plan, config: PlannerConfig) -> bool:
    """Whether ``plan`` gets less far than the stall window's least displacement over its
    whole horizon (it would stand, or all but)."""
    poses = plan.trajectory.poses
    path = float(np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T)))
    return path < config.stall.min_displacement


def threatened(plan: Plan, config: PlannerConfig) -> bool:
    """Whether the robot expects to be struck where ``plan`` would leave it: the plan's
    survival to the horizon's end is below ``stall.back_up_threat`` (never when that is 0)."""
    return _survival(plan) < config.stall.back_up_threat


def _survival(plan: Plan) -> float:
    """The plan's survivability at the horizon's end, ``p^s_N``."""
    return float(plan.cost.survivability[-1])


def consider(plan: Plan, state, cycle, level: int) -> Plan | None:
    """The back-up plan when the rung applies (on, the plan stands, and the ladder is at
    ``back_up_level`` or above or the plan is :func:`threatened`) and a reverse trajectory's
    exact cost is below the plan's; otherwise None (keep ``plan``)."""
    config = cycle.config
    if config.stall.back_up <= 0.0 or not stands(plan, config):
        return None
    if level < config.stall.back_up_level and not threatened(plan, config):
        return None
    candidates = back_up_trajectories(state, config)
    costs = evaluate(candidates, cycle.world, cycle.goal, config)
    total = np.where(np.isfinite(costs.total), costs.total, np.inf)
    best = int(np.argmin(total))
    if not total[best] < plan.fun:
        return None
    chosen = candidates[best]
    shape = ("straight", "curving left", "curving right")[best]
    if level >= config.stall.back_up_level:
        why = "stalled and the plan stood"
    else:
        why = (f"the plan stood where it expects to be struck (survival "
               f"{_survival(plan):.2f} < {config.stall.back_up_threat:g})")
    message = (f"{why} (exact cost {plan.fun:.3f}): backing up "
               f"{shape} at {config.stall.back_up:g} m/s (exact cost {total[best]:.3f}); "
               f"it replaced: {plan.message}")
    v0, omega0 = float(chosen.v[0]), float(chosen.omega[0])
    control = (v0, omega0) if math.isfinite(v0) and math.isfinite(omega0) else (0.0, 0.0)
    return dataclasses.replace(plan, x=chosen.z, fun=float(total[best]), success=True,
                               message=message, trajectory=chosen, control=control,
                               cost=costs[best], status="backing-up")
