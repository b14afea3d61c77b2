"""Docking at a fixed goal: within ``DockingConfig.radius``, head straight for it while that is
safe enough (docs/method.md section 7.1)."""

from __future__ import annotations

import math

import numpy as np

from ...core.config import PlannerConfig, RobotState
from ...core.control_law import (
    Trajectory,
    clamp_measured,
    commanded,
    rollout_from,
    wrap,
    z_from_target,
)
from ..exact.evaluator import Evaluation, Evaluator
from ..optimize.starts import clip_to_bounds


def dock(evaluator: Evaluator, config: PlannerConfig, goal_tolerance: float = 0.0) -> tuple | None:
    """``(evaluation, message)`` of the straight-to-the-goal trajectory when the goal of the
    ``evaluator``'s cycle is within the docking radius and that trajectory's survivability
    (until arrival, see :func:`arrival_survival`) is above ``min_survival``; else, with
    ``docking.region_points`` and a ``goal_tolerance`` (m, the task's) above the arrival
    radius, the cheapest passing trajectory to a point of the goal's region
    (:func:`region_targets`); else None."""
    state, goal = evaluator.cycle.state, evaluator.cycle.goal
    docking = config.docking
    distance = math.hypot(goal[0] - state.x, goal[1] - state.y)
    radius = docking_radius(config)
    if distance > radius or distance == 0.0:
        return None

    def survival_until_arrival(evaluated, point):
        return until_arrival(evaluated, point, goal, goal_tolerance, config)

    def cheapest(candidates):     # (evaluation, how, target) each
        passing = []
        for candidate, how, target in candidates:
            step, reached = survival_until_arrival(candidate, target)
            if passes(candidate, step, reached, config):
                passing.append((float(candidate.costs.total[0]), candidate, how, step,
                                reached, target))
        return (len(passing), min(passing, key=lambda entry: entry[0])) if passing else None

    [(evaluated, how)] = approaches(evaluator, [goal], config)
    step, survival = survival_until_arrival(evaluated, goal)
    if survival > docking.min_survival:
        return evaluated, (f"docked: the goal is {distance:.2f} m away, within the docking "
                           f"radius {radius:g} m; {how} ({_survived(step, survival, config)})")
    targets = region_targets(state, goal, goal_tolerance, config)
    if not docking.region_turns:
        targets = [target for target in targets
                   if not needs_turn(state.pose, target, docking.turn_in_place)]
    found = cheapest((candidate, how, target) for target, (candidate, how)
                     in zip(targets, approaches(evaluator, targets, config)))
    if found is not None:
        count, (_, candidate, how, step, reached, target) = found
        off = math.hypot(target[0] - goal[0], target[1] - goal[1])
        return candidate, (f"docked within the goal's tolerance {goal_tolerance:g} m: the goal "
                           f"point's survivability until arrival is {survival:.2f}, not above "
                           f"{docking.min_survival:g}; the cheapest of {count} passing points "
                           f"{off:.2f} m from it; {how} ({_survived(step, reached, config)})")
    return None


def passes(evaluated: Evaluation, step, survival: float, config: PlannerConfig) -> bool:
    """Whether a docking way (the first row of ``evaluated``, read ``(step, survival)`` by
    :func:`until_arrival`) passes docking's test: survivability above ``min_survival`` and a
    finite exact cost."""
    return (survival > config.docking.min_survival
            and math.isfinite(evaluated.costs.total[0]))


def _survived(step, survival, config: PlannerConfig) -> str:
    until = "the horizon's end" if step is None else f"arrival (step {step})"
    return f"survivability until {until} {survival:.2f} > {config.docking.min_survival:g}"


def approaches(evaluator: Evaluator, targets, config: PlannerConfig) -> list:
    """``(evaluation, how)`` for each point of ``targets`` (the goal, or the points of its
    region): the docking trajectory to it, straight (the target pose on the point, facing
    along the line of sight, at the speed limit: :func:`docking_z`), or, where the line to it
    is more than ``docking.turn_in_place`` off the heading, first a turn in place toward it
    (:func:`turn_toward`; a differential drive can turn where it stands, while the law turns
    only along its curve and slows with the curvature, so near a goal behind it the robot
    crawled round a wide arc: 0.04 m/s at 0.95 m from the goal in a replayed crowd, until
    the deadlock rule ended the run) and the straight trajectory from where the turn ends. The
    exact cost is the cycle's (toward its own goal), in two batches, both by the evaluator: the
    straight ones as z, those behind a turn by the numpy reference
    (:meth:`.Evaluator.evaluate_trajectories`, as the back-up rung's); each row is the row it
    would be alone (tested). A turned row's ``z`` is the law's part, seen from
    where the turn ends."""
    state = evaluator.cycle.state
    limit = config.docking.turn_in_place
    offs = [abs(float(off_the_line(state.pose, target))) for target in targets]
    turning = [i for i, target in enumerate(targets) if needs_turn(state.pose, target, limit)]
    straight = [i for i in range(len(targets)) if i not in turning]
    found = {}
    if straight:
        evaluated = evaluator.evaluate(np.array([docking_z(state.pose, targets[i], config)
                                                 for i in straight]))
        found.update({i: (evaluated[[row]], "heading straight to it")
                      for row, i in enumerate(straight)})
    if turning:
        cycle = evaluator.cycle
        turnings = {sign: turn_in_place(state, config, sign)      # only the ways needed
                    for sign in {turn_sign(state.pose, targets[i]) for i in turning}}
        cuts = []
        for i in turning:
            spin, steps = turn_toward(state, targets[i], config, limit, turnings)
            pose = spin.poses[min(max(int(steps), 1), config.horizon.n_steps - 1)]
            heading = math.atan2(targets[i][1] - pose[1], targets[i][0] - pose[0])
            cuts.append((spin, steps, (*targets[i], heading), config.robot.v_limit))
        trajectories = turns_then_law(config, cuts, cycle.goal)
        evaluated = Evaluation(trajectories.z, trajectories,
                               evaluator.evaluate_trajectories(trajectories))
        found.update({i: (evaluated[[row]], (
            f"turning in place first ({offs[i]:.2f} rad off the line to it, more than "
            f"{limit:g}), then heading straight to it")) for row, i in enumerate(turning)})
    return [found[i] for i in range(len(targets))]


def region_targets(state: RobotState, goal, goal_tolerance: float,
                   config: PlannerConfig) -> list:
    """The points of the goal's region that docking tries when the goal point fails
    (``docking.region_points``): evenly round the circle of radius ``goal_tolerance -
    docking.arrival_radius`` about ``goal``, the first on the line to the robot; none when
    that radius is not positive, the count is 0 or the robot is farther than
    ``docking.radius`` (IROS 2012's docking radius: the last metres)."""
    docking = config.docking
    ring = goal_tolerance - docking.arrival_radius
    count = docking.region_points
    if count == 0 or not ring > 0.0 or \
            math.hypot(goal[0] - state.x, goal[1] - state.y) > docking.radius:
        return []
    toward = math.atan2(state.y - goal[1], state.x - goal[0])
    return [(goal[0] + ring * math.cos(toward + 2.0 * math.pi * k / count),
             goal[1] + ring * math.sin(toward + 2.0 * math.pi * k / count))
            for k in range(count)]


def turn_toward(state: RobotState, goal, config: PlannerConfig, limit: float,
                turnings=None) -> tuple:
    """``(turning, steps)``: the turn in place toward ``goal`` (:func:`turn_in_place`, taken
    from ``turnings`` by sign when given) and the plan periods after which the line to the
    goal is within ``limit`` rad of the heading (the horizon's last but one at the most)."""
    n = config.horizon.n_steps
    sign = turn_sign(state.pose, goal)
    turning = turn_in_place(state, config, sign) if turnings is None else turnings[sign]
    off = np.abs(off_the_line(turning.poses.T, goal))
    return turning, next((i for i in range(1, n) if off[i] <= limit), n - 1)


def turns_then_law(config: PlannerConfig, cuts, goal) -> Trajectory:
    """Turns in place, each cut after some plan periods and followed by the law over the rest
    of the horizon, all the law's rollouts in one batch. ``cuts``: ``(turning, steps, target,
    v_max)`` each, ``turning`` a :func:`turn_in_place` rollout, ``steps`` clipped to 1 ..
    n - 1; the law then heads for the target pose ``target`` at ``v_max``, or, with ``target``
    None, on the docking trajectory to ``goal`` (:func:`docking_z`). Each row's ``z`` is the
    law's part, seen from where its turn ends."""
    n = config.horizon.n_steps
    ks, zs, starts = [], [], []
    for turning, steps, target, v_max in cuts:
        k = min(max(int(steps), 1), n - 1)
        pose = turning.poses[k]
        if target is None:
            z = docking_z(pose, goal, config)
        else:
            z = clip_to_bounds(np.array(z_from_target(target, v_max, pose), dtype=float),
                               config)
        ks.append(k)
        zs.append(z)
        starts.append((*pose, *clamp_measured(
            RobotState(*pose, turning.v[k - 1], turning.omega[k - 1]), config)))
    carry = tuple(np.array(column, dtype=float) for column in zip(*starts))
    law = rollout_from(np.array(zs), carry, config, n_steps=n - min(ks))
    turns = [cut[0] for cut in cuts]

    def spliced(name, first):     # the turn's ``k`` steps, then the law's ``n - k``
        return np.array([np.concatenate([getattr(turn, name)[:k + first],
                                         getattr(law, name)[i, first:n - k + first]])
                         for i, (turn, k) in enumerate(zip(turns, ks))])

    return Trajectory(np.array(zs), spliced("poses", 1), spliced("v", 0), spliced("omega", 0),
                      law.target)


def turn_in_place(state: RobotState, config: PlannerConfig, sign: float) -> Trajectory:
    """A whole horizon of turning in place at ``sign * omega_limit`` from the measured
    command (one trajectory)."""
    return commanded(state, config, np.tile((0.0, sign * config.robot.omega_limit),
                                            (1, config.horizon.n_steps, 1)))[0]


def turn_sign(pose, goal) -> float:
    """Which way to turn in place toward ``goal``: 1.0 (left) or -1.0 (right)."""
    return 1.0 if off_the_line(pose, goal) > 0 else -1.0


def needs_turn(pose, target, limit: float) -> bool:
    """Whether docking at ``target`` from ``pose`` begins with a turn in place: the line to it
    is more than ``limit`` (``docking.turn_in_place``, rad; 0: never) off the heading."""
    return 0.0 < limit < abs(float(off_the_line(pose, target)))


def off_the_line(pose, goal):
    """How far the line from ``pose`` to ``goal`` turns from the heading, rad in (-pi, pi]
    (positive: the goal is to the left); ``pose`` an ``(x, y, phi)`` of scalars or arrays."""
    x, y, phi = pose
    return wrap(np.arctan2(goal[1] - y, goal[0] - x) - phi)


def docking_z(pose, goal, config: PlannerConfig) -> np.ndarray:
    """The docking trajectory's z from ``pose``: the target pose on the goal, facing along
    the line of sight, at the speed limit; inside the box."""
    heading = math.atan2(goal[1] - pose[1], goal[0] - pose[0])
    z = z_from_target((goal[0], goal[1], heading), config.robot.v_limit, pose)
    return clip_to_bounds(np.array(z, dtype=float), config)


def docking_radius(config: PlannerConfig) -> float:
    """The distance to a fixed goal within which the planner docks, m: ``docking.radius``, or
    the horizon's reach (:attr:`PlannerConfig.reach`) when larger and
    ``docking.radius_from_reach`` is on."""
    docking = config.docking
    return max(docking.radius, config.reach) if docking.radius_from_reach else docking.radius


def until_arrival(evaluated: Evaluation, point, goal, goal_tolerance: float,
                  config: PlannerConfig) -> tuple:
    """``(step, survivability)`` of a docking way to ``point`` (the goal or a point of its
    region) as docking reads it: where the way first comes within the task's
    ``goal_tolerance`` of ``goal`` (``docking.arrival_at_tolerance``, a tolerance above the
    arrival radius), else within ``docking.arrival_radius`` of ``point``
    (:func:`arrival_survival`)."""
    docking = config.docking
    task = docking.arrival_at_tolerance and goal_tolerance > docking.arrival_radius
    return arrival_survival(evaluated, *((goal, goal_tolerance) if task else
                                         (point, docking.arrival_radius)))


def arrival_survival(evaluated: Evaluation, goal, radius: float) -> tuple:
    """``(step, survivability)`` of the first trajectory of ``evaluated`` at the first step
    within ``radius`` of ``goal``; ``(None, survivability at the horizon's end)`` when
    ``radius`` is 0 or the trajectory never comes that near."""
    survival = evaluated.costs.survivability[0]
    poses = evaluated.trajectories.poses
    step = arrival_step(poses[0] if poses.ndim == 3 else poses, goal, radius)
    return (None, float(survival[-1])) if step is None else (step, float(survival[step]))


def arrival_step(poses, goal, radius: float) -> int | None:
    """The first step of ``poses`` (one trajectory's, ``(N+1, 3)``) within ``radius`` of
    ``goal``; None when ``radius`` is not positive or it never comes that near."""
    if not radius > 0.0:
        return None
    near = np.hypot(poses[:, 0] - goal[0], poses[:, 1] - goal[1]) <= radius
    return int(np.argmax(near)) if np.any(near) else None
