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
off) and ``back_up_time``; docs/method.md section 7.5. With it come forward dodges against a
plan the robot expects to be struck on (``StallConfig.dodge``) and, once stalled, turns in place
each followed by the law (``StallConfig.turn_to_goal``): moves the law cannot make either.
Its last resort (``StallConfig.doomed_below``, :func:`clearest`): over a plan struck almost
surely within the next second, where the cost's collision term has saturated for every way
near it, the way that keeps the widest gap over that second, not the cheapest.
"""

from __future__ import annotations

import dataclasses
import math
from functools import cached_property

import numpy as np

from ..core.config import PlannerConfig
from ..core.control_law import Trajectory, commanded, rollout_from
from ..core.exact_cost import evaluate
from . import docking, passive
from .passive import clearance
from .records import Plan
from .start_state import bounded_control

TURN_RADIUS = 1.0
"""m: the curving back-ups turn at this radius (omega = speed / radius), either way."""


def back_up_speed(config: PlannerConfig) -> float:
    """The rung's reverse speed, m/s: ``stall.back_up`` capped at the robot's declared
    ``reverse_limit``, at ``v_limit`` and at one plan period's braking (``accel_limit * dt``).
    0 when the robot never reverses: the rung then has no reverses."""
    robot = config.robot
    return min(config.stall.back_up, robot.reverse_limit, robot.v_limit,
               robot.accel_limit * config.horizon.dt)


def back_up_trajectories(state, config: PlannerConfig) -> Trajectory:
    """Three reverse trajectories from ``state``: straight back and curving back either way at
    :data:`TURN_RADIUS`, each commanding ``-stall.back_up`` m/s for ``stall.back_up_time``
    then 0, within the robot's acceleration limits from its measured speed and turn rate
    clipped to the forward limits (``clamp_measured``, as the law's rollouts start).

    The speed is capped at what one plan period's braking takes back (``accel_limit * dt``,
    0.3 m/s for the default robot), so the next plan's law starts from a stop: the law's
    rollout, the compiled kernel and the graph never see a reversing speed."""
    dt, n = config.horizon.dt, config.horizon.n_steps
    speed = back_up_speed(config)
    turn = min(speed / TURN_RADIUS, config.robot.omega_limit)
    reversing = np.arange(n) < int(round(config.stall.back_up_time / dt))
    commands = np.zeros((3, n, 2))
    for i, sign in enumerate((0.0, 1.0, -1.0)):
        commands[i, reversing] = (-speed, sign * turn)
    return commanded(state, config, commands)


DODGE_TURN_STEPS = 8
"""A dodge turns for 0 to 7 plan periods (up to 1.4 s: a half turn at 1.5 rad/s takes 2.1 s,
a quarter turn 1.0 s plus the turn rate's ramp)."""


def dodge_trajectories(state, config: PlannerConfig) -> Trajectory:
    """Forward dodges from ``state`` (``StallConfig.dodge``): turn at ``omega_limit`` either
    way for 0 to :data:`DODGE_TURN_STEPS` - 1 plan periods, at a standstill or half or full
    ``v_limit``, then straight ahead at half or full ``v_limit``: 96 trajectories, within the
    robot's acceleration limits from where the law's rollouts start. Never a reversing speed,
    so the next plan's law starts where it always does."""
    robot, n = config.robot, config.horizon.n_steps
    speeds = (0.0, 0.5 * robot.v_limit, robot.v_limit)
    commands = []
    for sign in (1.0, -1.0):
        for turning in range(DODGE_TURN_STEPS):
            for v_turn in speeds:
                for v_ahead in speeds[1:]:
                    c = np.tile((v_ahead, 0.0), (n, 1))
                    c[:turning] = (v_turn, sign * robot.omega_limit)
                    commands.append(c)
    return commanded(state, config, np.array(commands))


def turn_trajectories(plan: Plan, state, goal, config: PlannerConfig) -> Trajectory:
    """The turns in place of a stalled robot (``stall.turn_to_goal``): toward the goal until
    within ``turn_to_goal`` of the line to it, then the docking trajectory to it; toward the
    plan's own target as far, then the law to it at the plan's ``v_max`` (the way the plan
    meant, without the crawl round: the law slows with its curvature); and 1 to
    :data:`DODGE_TURN_STEPS` - 1 plan periods either way, then the docking trajectory to the
    goal (round a person standing on the line to it). 16 in all
    (:func:`.docking.turn_toward`, :func:`.docking.turns_then_law`)."""
    limit = config.stall.turn_to_goal
    target = np.asarray(plan.trajectory.target, dtype=float)
    # One turning rollout a side serves every way, each cut where its turn ends; the law's
    # rollouts after them run as one batch.
    turnings = {sign: docking.turn_in_place(state, config, sign) for sign in (1.0, -1.0)}
    cuts = [(*docking.turn_toward(state, goal, config, limit, turnings), None, None)]
    if np.all(np.isfinite(target)):
        cuts.append((*docking.turn_toward(state, target[:2], config, limit, turnings), target,
                     float(plan.x[3])))
    cuts += [(turning, steps, None, None) for turning in turnings.values()
             for steps in range(1, DODGE_TURN_STEPS)]          # 1..7 periods either way
    return docking.turns_then_law(config, cuts, goal)


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


def judged(plan: Plan, state, cycle, goal_tolerance: float = 0.0) -> tuple:
    """``(batch, total, arrival)``: the plan (row 0) and :func:`turn_trajectories` over the
    horizon, their exact costs over the horizon lengthened by ``stall.judge_beyond`` (every
    one carried on past the horizon by :func:`docked_beyond`) and their
    :func:`arrival_estimate` (within ``goal_tolerance``, else ``docking.arrival_radius``), s.
    What :func:`judge_turns` decides on, and ``tools/plan_profile.py`` prints."""
    config = cycle.config
    longer = lengthened(config, config.stall.judge_beyond)
    turns = turn_trajectories(plan, state, cycle.goal, config)
    batch = stacked([plan.trajectory, turns])
    carried = docked_beyond(batch, cycle.goal, config, longer)
    total = evaluate(carried, cycle.world, cycle.goal, longer).total
    radius = goal_tolerance if goal_tolerance > 0.0 else config.docking.arrival_radius
    return (batch, np.where(np.isfinite(total), total, np.inf),
            arrival_estimate(carried, cycle.goal, radius, config))


def judge_turns(plan: Plan, state, cycle, goal_tolerance: float = 0.0) -> Plan | None:
    """The cheapest of :func:`turn_trajectories` when, over the horizon lengthened by
    ``stall.judge_beyond``, it costs less than ``plan`` (:func:`judged`); None otherwise.
    With ``stall.judge_sooner`` only the turns whose arrival estimate is sooner than the
    plan's compete. The turn comes back as planned over the horizon and costed over it, as
    every plan is."""
    config = cycle.config
    batch, total, arrival = judged(plan, state, cycle, goal_tolerance)
    sooner = ""
    if config.stall.judge_sooner:
        total[1:] = np.where(arrival[1:] < arrival[0], total[1:], np.inf)
    best = 1 + int(np.argmin(total[1:]))
    if not total[best] < total[0]:
        return None
    if config.stall.judge_sooner:
        sooner = f", arriving by {arrival[best]:.2f} s against {arrival[0]:.2f} s"
    chosen = batch[best]
    cost = evaluate(chosen, cycle.world, cycle.goal, config)
    duration = lengthened(config, config.stall.judge_beyond).horizon.duration
    message = (f"stalled; judged over {duration:g} s, turning in place "
               f"{_turn_named(best - 1, chosen, plan)}, then heading on (exact cost "
               f"{total[best]:.3f}{sooner}) is cheaper than the plan ({total[0]:.3f}); it "
               f"replaced: {plan.message}")
    return _replaced(plan, chosen, cost, message, "turning", config)


def _turn_named(index: int, chosen: Trajectory, plan: Plan) -> str:
    """Which of :func:`turn_trajectories` row ``index`` is, in words (the plan's target has
    a row only when it is finite)."""
    if index == 0:
        return "toward the goal"
    if index == 1 and np.all(np.isfinite(plan.trajectory.target)):
        return "toward the plan's target"
    return "left" if chosen.omega[0] > 0 else "right"


def _replaced(plan: Plan, chosen: Trajectory, cost, message: str, status: str,
              config: PlannerConfig) -> Plan:
    """``plan`` replaced by the rung's ``chosen`` trajectory (its exact ``cost``), its first
    command the control (a stop where it is not finite; within the robot's declared limits,
    ``reverse_limit`` included)."""
    control = bounded_control(chosen.v[0], chosen.omega[0], config.robot)
    return dataclasses.replace(plan, x=chosen.z, fun=float(cost.total), success=True,
                               message=message, trajectory=chosen, control=control, cost=cost,
                               status=status)


def stands(plan: Plan, config: PlannerConfig) -> bool:
    """Whether ``plan`` gets less far than the stall window's least displacement over its
    whole horizon (it would stand, or all but)."""
    poses = plan.trajectory.poses
    path = float(np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T)))
    return path < config.stall.min_displacement


def threatened(plan: Plan, config: PlannerConfig, within: float = math.inf) -> bool:
    """Whether the robot expects to be struck on ``plan`` within ``within`` seconds (the
    horizon's end by default): the plan's survival then is below ``stall.back_up_threat``
    (never when that is 0)."""
    return _survival(plan, config, within) < config.stall.back_up_threat


def _survival(plan: Plan, config: PlannerConfig, within: float = math.inf) -> float:
    """The plan's survivability at the first step at or after ``within`` seconds, the
    horizon's end ``p^s_N`` when that is later."""
    survival = plan.cost.survivability
    steps = math.ceil(within / config.horizon.dt - 1e-9) if math.isfinite(within) else math.inf
    return float(survival[min(steps, len(survival) - 1)])


def arrival_time(plan: Plan, goal, goal_tolerance: float, config: PlannerConfig) -> float:
    """s: when a docked ``plan`` first comes within ``goal_tolerance`` of a fixed ``goal``
    with ``stall.threat_until_arrival`` (the task ends there); otherwise, or when it never
    does, infinity (the gate reads the horizon's end)."""
    if not (config.stall.threat_until_arrival and plan.status == "docked"):
        return math.inf
    step = docking.arrival_step(plan.trajectory.poses, goal, goal_tolerance)
    return math.inf if step is None else step * config.horizon.dt


def consider(plan: Plan, state, cycle, level: int, goal_tolerance: float = 0.0) -> Plan | None:
    """The rung's plan, or None (keep ``plan``). With the rung on: reverse trajectories when
    the plan stands and the ladder is at ``back_up_level`` or above or the plan is
    :func:`threatened`; forward dodges (``stall.dodge``) when it is threatened, standing or
    not; turns in place (``stall.turn_to_goal``, :func:`turn_trajectories`) when the ladder
    is at ``turn_level`` or above and the plan is not docked. A docked plan's threat is read
    at its :func:`arrival_time` (``goal_tolerance``: the fixed goal's, m). The cheapest of
    them by the exact cost replaces the plan if it is cheaper."""
    config = cycle.config
    stall = config.stall
    if stall.back_up <= 0.0:
        return None
    arrival = arrival_time(plan, cycle.goal, goal_tolerance, config)
    ways = Ways(state, config)
    cleared = clearest(plan, state, cycle, arrival, ways)
    if cleared is not None:
        return cleared
    threat = threatened(plan, config, arrival)
    stalled = level >= stall.back_up_level
    reverse = back_up_speed(config) > 0.0 and stands(plan, config) and (stalled or threat)
    dodge = stall.dodge and threatened(plan, config, min(stall.dodge_within, arrival))
    # A docked plan already heads for the goal, turning in place first where it must.
    turn = (level >= stall.turn_level and stall.turn_to_goal > 0.0
            and plan.status != "docked")
    if turn and stall.judge_beyond > 0.0 and plan.status in LAW_STATUSES \
            and level >= stall.judge_level:
        judged = judge_turns(plan, state, cycle, goal_tolerance)
        if judged is not None:
            return judged
        turn = False                    # the turns were judged, over the longer horizon
    sets = ([("reverse", ways.reverses)] if reverse else []) + (
        [("dodge", ways.dodges)] if dodge else []) + (
        [("turn", turn_trajectories(plan, state, cycle.goal, config))] if turn else [])
    if not sets:
        return None
    candidates = stacked([t for _, t in sets])
    costs = evaluate(candidates, cycle.world, cycle.goal, config)
    total = np.where(np.isfinite(costs.total), costs.total, np.inf)
    best = int(np.argmin(total))
    if not total[best] < plan.fun:
        return None
    chosen = candidates[best]
    ends = np.cumsum([len(t.z) for _, t in sets])
    which = int(np.searchsorted(ends, best, side="right"))      # the set it came from
    kind, first = sets[which][0], best - (int(ends[which - 1]) if which else 0)
    if kind == "turn":
        off = abs(float(docking.off_the_line(state.pose, cycle.goal)))
        why = f"stalled, facing {off:.2f} rad away from the goal"
        name = _turn_named(first, chosen, plan)
        what = (f"turning in place {name}, then heading to "
                f"{'it' if name.startswith('toward') else 'the goal'}")
    elif kind == "reverse" and stalled:
        why = "stalled and the plan stood"
    else:
        within = arrival if kind == "reverse" else min(stall.dodge_within, arrival)  # as read
        soon = f" within {within:g} s" if within < config.horizon.duration else ""
        why = (f"the plan {'stood' if stands(plan, config) else 'went'} where it expects to be "
               f"struck{soon} (survival {_survival(plan, config, within):.2f} < "
               f"{stall.back_up_threat:g})")
    if kind == "reverse":
        what = _reverse_named(first, config)
    elif kind == "dodge":
        what = _dodge_named(chosen)
    message = (f"{why} (exact cost {plan.fun:.3f}): {what} (exact cost {total[best]:.3f}); "
               f"it replaced: {plan.message}")
    status = {"reverse": "backing-up", "dodge": "dodging", "turn": "turning"}[kind]
    return _replaced(plan, chosen, costs[best], message, status, config)


def _reverse_named(index: int, config: PlannerConfig) -> str:
    """Row ``index`` of :func:`back_up_trajectories`, in words."""
    return (f"backing up {('straight', 'curving left', 'curving right')[index]} at "
            f"{back_up_speed(config):g} m/s")


def _dodge_named(chosen: Trajectory) -> str:
    """A dodge of :func:`dodge_trajectories`, in words."""
    return (f"dodging: turning {'left' if chosen.omega[0] > 0 else 'right'} at "
            f"{abs(float(chosen.omega[0])):.2f} rad/s, then ahead")


CLEARER = 1e-3
"""m: the clearest way replaces a doomed plan only if its gap is wider by more than this (a
millimetre, above round-off)."""


def stacked(trajectories) -> Trajectory:
    """One batch of ``trajectories`` (each a batch or a single trajectory), in order."""
    rows = [t if t.z.ndim == 2 else Trajectory(*(getattr(t, f.name)[None]
                                                for f in dataclasses.fields(Trajectory)))
            for t in trajectories]
    return Trajectory(*(np.concatenate([getattr(t, f.name) for t in rows])
                        for f in dataclasses.fields(Trajectory)))


class Ways:
    """This cycle's dodges and reverses from ``state``, each built once, when first read (a
    doomed plan that stays the clearest meets the same ways again in :func:`consider`)."""

    def __init__(self, state, config: PlannerConfig):
        self.state, self.config = state, config

    dodges = cached_property(lambda self: dodge_trajectories(self.state, self.config))
    reverses = cached_property(lambda self: back_up_trajectories(self.state, self.config))


def clearest(plan: Plan, state, cycle, arrival: float = math.inf,
             ways: Ways | None = None) -> Plan | None:
    """The clearest way out of a doomed ``plan``, or None (keep it; ``stall.doomed_below``).

    Doomed: the plan's survival over the next ``stall.clearance_within`` seconds (until
    ``arrival``, s, if that is sooner: a docked plan's :func:`arrival_time`, where the task
    ends, as :func:`consider` reads it) is below ``doomed_below``. Then the plan and this
    cycle's :class:`Ways` (``ways`` if already made) are set by their :func:`clearance` over
    the next ``clearance_within`` seconds instead of their cost, and the clearest replaces
    the plan when its gap is wider; all below 0, the least approaching (``stall.passive``)."""
    config = cycle.config
    stall = config.stall
    if not stall.doomed_below > 0.0:
        return None
    within = min(stall.clearance_within, arrival)
    survival = _survival(plan, config, within)
    if survival >= stall.doomed_below:
        return None
    ways = ways or Ways(state, config)
    dodges = ways.dodges
    reverses = [ways.reverses] if back_up_speed(config) > 0.0 else []   # a robot that reverses
    candidates = stacked([plan.trajectory, dodges, *reverses])
    gaps = clearance(candidates, cycle, stall.clearance_within)
    gaps = np.where(np.isnan(gaps), -np.inf, gaps)           # a gap not measured keeps nothing
    still = (stall.passive and not np.max(gaps) >= 0.0       # every way touches someone, the
             and clearance(candidates[:1], cycle, 0.0)[0] >= 0.0)    # start not yet: be still
    if still:                               # at the contact (passive.py), a stop put second
        candidates = stacked([candidates[:1], passive.stopping(state, config), candidates[1:]])
        gaps = np.insert(gaps, 1, clearance(candidates[1:2], cycle, stall.clearance_within))
        best = passive.least_approaching(candidates, gaps, cycle, stall.clearance_within)
        if best == 0:
            return None             # the plan is as still as any: the rung goes on by the cost
    else:
        best = int(np.argmax(gaps))
        if not gaps[best] > gaps[0] + CLEARER:
            return None
    chosen, way = candidates[best], best - 1 if still else best     # way: without the stop
    what = ("braking to a stop" if still and best == 1 else _dodge_named(chosen)
            if way <= len(dodges) else _reverse_named(way - 1 - len(dodges), config))
    how = (f"every way touches someone within {stall.clearance_within:g} s: the way that "
           f"drives least toward whoever it touches, {what}" if still else
           f"the clearest way over {stall.clearance_within:g} s, {what}")
    message = (f"the plan is doomed (survival {survival:.2f} < {stall.doomed_below:g} within "
               f"{within:g} s): {how}, keeps {gaps[best]:.2f} m against the plan's "
               f"{gaps[0]:.2f} m; it replaced: {plan.message}")
    cost = evaluate(chosen, cycle.world, cycle.goal, config)
    return _replaced(plan, chosen, cost, message, "clearing", config)
