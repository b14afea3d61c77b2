"""Docking at a fixed goal: within ``DockingConfig.radius``, head straight for it while that is
safe enough (docs/method.md section 7.1)."""

from __future__ import annotations

import math

import numpy as np

from ..core.config import PlannerConfig
from ..core.control_law import z_from_target
from .evaluator import Evaluation, Evaluator
from .starts import clip_to_bounds


def dock(evaluator: Evaluator, config: PlannerConfig) -> tuple | None:
    """``(evaluation, message)`` of the straight-to-the-goal trajectory when the goal of the
    ``evaluator``'s cycle is within the docking radius and that trajectory's survivability
    (until arrival, see :func:`arrival_survival`) is above ``min_survival``; else None."""
    state, goal = evaluator.cycle.state, evaluator.cycle.goal
    docking = config.docking
    distance = math.hypot(goal[0] - state.x, goal[1] - state.y)
    radius = docking_radius(config)
    if distance > radius or distance == 0.0:
        return None
    heading = math.atan2(goal[1] - state.y, goal[0] - state.x)
    z = z_from_target((goal[0], goal[1], heading), config.robot.v_limit, state.pose)
    evaluated = evaluator.evaluate(clip_to_bounds(np.array(z, dtype=float), config))
    step, survival = arrival_survival(evaluated, goal, docking.arrival_radius)
    if not survival > docking.min_survival:
        return None
    until = "the horizon's end" if step is None else f"arrival (step {step})"
    return evaluated, (f"docked: the goal is {distance:.2f} m away, within the docking radius "
                       f"{radius:g} m; heading straight to it (survivability until "
                       f"{until} {survival:.2f} > {docking.min_survival:g})")


def docking_radius(config: PlannerConfig) -> float:
    """The distance to a fixed goal within which the planner docks, m: ``docking.radius``, or
    the horizon's reach (:attr:`PlannerConfig.reach`) when larger and
    ``docking.radius_from_reach`` is on."""
    docking = config.docking
    return max(docking.radius, config.reach) if docking.radius_from_reach else docking.radius


def arrival_survival(evaluated: Evaluation, goal, radius: float) -> tuple:
    """``(step, survivability)`` of the first trajectory of ``evaluated`` at the first step
    within ``radius`` of ``goal``; ``(None, survivability at the horizon's end)`` when
    ``radius`` is 0 or the trajectory never comes that near."""
    survival = evaluated.costs.survivability[0]
    if radius > 0.0:
        poses = evaluated.trajectories.poses
        poses = poses[0] if poses.ndim == 3 else poses
        near = np.hypot(poses[:, 0] - goal[0], poses[:, 1] - goal[1]) <= radius
        if np.any(near):
            step = int(np.argmax(near))
            return step, float(survival[step])
    return None, float(survival[-1])
