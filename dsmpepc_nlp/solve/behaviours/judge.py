"""Judging the turns in place beyond the horizon (``stall.judge_beyond``, off by default): the
stalled plan and the turns of :func:`.ways.turn_trajectories`, each carried on past the horizon
by the docking trajectory, costed over the longer horizon through the plan's evaluator
(docs/method.md section 7.5)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...core.config import PlannerConfig
from ...core.control_law import Trajectory, rollout_from, stacked
from ..exact.evaluator import Evaluator
from ..plan import Plan
from . import docking
from .ways import replaced, turn_named, turn_trajectories

LAW_STATUSES = ("nlp", "sampling", "sampling-fallback")
"""The statuses of a plan of the law (the NLP's or the sampler's), which :func:`judge_turns`
judges."""


def lengthened(config: PlannerConfig, beyond: float) -> PlannerConfig:
    """``config`` with its horizon at least ``beyond`` seconds longer (whole plan periods)."""
    horizon = config.horizon
    extra = math.ceil(beyond / horizon.dt - 1e-9)
    return dataclasses.replace(config, horizon=dataclasses.replace(
        horizon, n_steps=horizon.n_steps + extra))


def docked_beyond(trajectories: Trajectory, goal, config: PlannerConfig,
                  longer: PlannerConfig) -> Trajectory:
    """``trajectories`` (a batch over ``config``'s horizon), each carried on to ``longer``'s
    horizon by the docking trajectory to ``goal`` from where it ends (the law from its last
    pose and command, :func:`.docking.docking_z`): the same way after the horizon for every
    one, so that what the longer horizon adds is only what each leaves there."""
    n, extra = config.horizon.n_steps, longer.horizon.n_steps - config.horizon.n_steps
    ends = trajectories.poses[:, n]
    zs = np.array([docking.docking_z(pose, goal, config) for pose in ends])
    carry = (*ends.T, trajectories.v[:, n - 1], trajectories.omega[:, n - 1])
    after = rollout_from(zs, carry, config, n_steps=extra)
    return Trajectory(trajectories.z, np.concatenate([trajectories.poses, after.poses[:, 1:]], 1),
                      np.concatenate([trajectories.v, after.v], 1),
                      np.concatenate([trajectories.omega, after.omega], 1), trajectories.target)


def arrival_estimate(trajectories: Trajectory, goal, radius: float,
                     config: PlannerConfig) -> np.ndarray:
    """s, per trajectory of the batch: when it first comes within ``radius`` of ``goal``;
    for one that does not, its end's time plus the straight way left to ``goal`` at the
    speed limit (a lower bound on its arrival)."""
    poses, dt = trajectories.poses, config.horizon.dt
    left = np.hypot(poses[:, -1, 0] - goal[0], poses[:, -1, 1] - goal[1])
    late = (poses.shape[1] - 1) * dt + left / config.robot.v_limit
    steps = [docking.arrival_step(p, goal, radius) for p in poses]
    return np.array([late[i] if step is None else step * dt for i, step in enumerate(steps)])


def judged(plan: Plan, state, evaluator: Evaluator, goal_tolerance: float = 0.0) -> tuple:
    """``(batch, total, arrival)``: the plan (row 0) and :func:`turn_trajectories` over the
    horizon, their exact costs over the horizon lengthened by ``stall.judge_beyond`` (every
    one carried on past the horizon by :func:`docked_beyond`; by the plan's ``evaluator``,
    with the lengthened config) and their :func:`arrival_estimate` (within
    ``goal_tolerance``, else ``docking.arrival_radius``), s.
    What :func:`judge_turns` decides on, and ``tools/dev/plan_profile.py`` prints."""
    cycle = evaluator.cycle
    config = cycle.config
    longer = lengthened(config, config.stall.judge_beyond)
    turns = turn_trajectories(plan, state, cycle.goal, config)
    batch = stacked([plan.trajectory, turns])
    carried = docked_beyond(batch, cycle.goal, config, longer)
    total = evaluator.evaluate_trajectories(carried, longer).total
    radius = goal_tolerance if goal_tolerance > 0.0 else config.docking.arrival_radius
    return (batch, np.where(np.isfinite(total), total, np.inf),
            arrival_estimate(carried, cycle.goal, radius, config))


def judge_turns(plan: Plan, state, evaluator: Evaluator,
                goal_tolerance: float = 0.0) -> Plan | None:
    """The cheapest of :func:`turn_trajectories` when, over the horizon lengthened by
    ``stall.judge_beyond``, it costs less than ``plan`` (:func:`judged`); None otherwise.
    With ``stall.judge_sooner`` only the turns whose arrival estimate is sooner than the
    plan's compete. The turn comes back as planned over the horizon and costed over it, as
    every plan is (by the plan's ``evaluator``)."""
    config = evaluator.cycle.config
    batch, total, arrival = judged(plan, state, evaluator, goal_tolerance)
    sooner = ""
    if config.stall.judge_sooner:
        total[1:] = np.where(arrival[1:] < arrival[0], total[1:], np.inf)
    best = 1 + int(np.argmin(total[1:]))
    if not total[best] < total[0]:
        return None
    if config.stall.judge_sooner:
        sooner = f", arriving by {arrival[best]:.2f} s against {arrival[0]:.2f} s"
    chosen = batch[best]
    cost = evaluator.evaluate_trajectories(chosen)
    duration = lengthened(config, config.stall.judge_beyond).horizon.duration
    message = (f"stalled; judged over {duration:g} s, turning in place "
               f"{turn_named(best - 1, chosen, plan)}, then heading on (exact cost "
               f"{total[best]:.3f}{sooner}) is cheaper than the plan ({total[0]:.3f}); it "
               f"replaced: {plan.message}")
    return replaced(plan, chosen, cost, message, "turning", config)


