"""The ways a robot can move that the pose-following law cannot make, for the back-up rung
(:mod:`.backup`) and its last resort (:mod:`.last_resort`): reverses within the robot's declared
``reverse_limit``, forward dodges, and turns in place each followed by the law; the batch
helpers and the words a plan's message names them by."""

from __future__ import annotations

import dataclasses
from functools import cached_property

import numpy as np

from ...core.config import PlannerConfig
from ...core.control_law import Trajectory, commanded
from ...core.geometry import footprint_points
from ..plan import Plan
from ..start_state import bounded_control
from . import docking

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



class Ways:
    """This cycle's dodges and reverses from ``state``, each built once, when first read (a
    doomed plan that stays the clearest meets the same ways again in :func:`.backup.moves`).

    With ``world`` given, :attr:`reverses` keeps only the reverses that stay in space the
    world's map has seen free (:func:`reverses_seen`; every one with a map that knows nothing
    of seeing), and :attr:`reverse_rows` says which of :func:`back_up_trajectories` they are.
    """

    def __init__(self, state, config: PlannerConfig, world=None):
        self.state, self.config, self.world = state, config, world

    dodges = cached_property(lambda self: dodge_trajectories(self.state, self.config))

    @cached_property
    def _reverses(self) -> tuple:
        every = back_up_trajectories(self.state, self.config)
        rows = np.flatnonzero(reverses_seen(every, self.world, self.config))
        return every[rows], rows

    reverses = property(lambda self: self._reverses[0])
    reverse_rows = property(lambda self: self._reverses[1])


def reverses_seen(trajectories: Trajectory, world, config: PlannerConfig) -> np.ndarray:
    """bool per trajectory of the batch: whether, at every pose it reaches while reversing,
    each footprint circle's centre and its rearmost point lie in cells the map has seen free
    (``world.grid.is_seen_free``, a :class:`~dsmpepc_nlp.perception.SensedGrid`). All True
    without a world or with a map that knows nothing of seeing (a map given in advance)."""
    check = getattr(getattr(world, "grid", None), "is_seen_free", None)
    n = len(trajectories.z)
    if check is None or n == 0:
        return np.ones(n, dtype=bool)
    circles = np.asarray(config.robot.footprint, dtype=float)
    poses = trajectories.poses[:, 1:]                                            # (n, N, 3)
    heading = np.stack([np.cos(poses[..., 2]), np.sin(poses[..., 2])], axis=-1)
    centres = footprint_points(poses, circles)                                  # (n, N, C, 2)
    rear = centres - circles[:, 2, None] * heading[..., None, :]
    seen = check(centres) & check(rear)                                          # (n, N, C)
    reversing = np.asarray(trajectories.v) < 0.0                                 # (n, N)
    return np.all(seen.all(axis=-1) | ~reversing, axis=1)



def turn_named(index: int, chosen: Trajectory, plan: Plan) -> str:
    """Which of :func:`turn_trajectories` row ``index`` is, in words (the plan's target has
    a row only when it is finite)."""
    if index == 0:
        return "toward the goal"
    if index == 1 and np.all(np.isfinite(plan.trajectory.target)):
        return "toward the plan's target"
    return "left" if chosen.omega[0] > 0 else "right"



def reverse_named(index: int, config: PlannerConfig) -> str:
    """Row ``index`` of :func:`back_up_trajectories`, in words."""
    return (f"backing up {('straight', 'curving left', 'curving right')[index]} at "
            f"{back_up_speed(config):g} m/s")


def dodge_named(chosen: Trajectory) -> str:
    """A dodge of :func:`dodge_trajectories`, in words."""
    return (f"dodging: turning {'left' if chosen.omega[0] > 0 else 'right'} at "
            f"{abs(float(chosen.omega[0])):.2f} rad/s, then ahead")



def replaced(plan: Plan, chosen: Trajectory, cost, message: str, status: str,
              config: PlannerConfig) -> Plan:
    """``plan`` replaced by the rung's ``chosen`` trajectory (its exact ``cost``), its first
    command the control (a stop where it is not finite; within the robot's declared limits,
    ``reverse_limit`` included)."""
    control = bounded_control(chosen.v[0], chosen.omega[0], config.robot)
    return dataclasses.replace(plan, x=chosen.z, fun=float(cost.total), success=True,
                               message=message, trajectory=chosen, control=control, cost=cost,
                               status=status)


