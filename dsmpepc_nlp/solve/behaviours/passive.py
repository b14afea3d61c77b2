"""Passive safety, the doomed plan's last word: where every way touches someone, drive at no one.

The back-up rung's last resort (``backup.clearest``) sets a doomed plan's ways by the gap each
keeps over the next ``stall.clearance_within`` seconds (:func:`clearance`). When every way, the
plan's own included, is predicted to touch someone within them (and the robot touches no one
yet), the widest of those gaps is only the shallowest overlap, and it is often a dodge that
drives on into a walker the prediction has wrong. A robot cannot then promise no contact. It
can promise not to be the one that closes it: Fraichard's *passive motion safety* (T.
Fraichard, "A Short Paper About Motion Safety", ICRA 2007) asks it to be at rest should a
contact come; ours asks a little less, that it move toward no one it touches (moving away
counts as still, which keeps the ways out a stop gives up). Of the ways, braking to a stop
(:func:`stopping`) among them, the ones least fast toward whoever they touch
(:func:`approach_at_contact`) are kept and the widest gap among them is taken. Already in
contact, the rung opens the gap as before. ``StallConfig.passive`` (on by default);
docs/method.md section 7.5. Every gap is measured through the plan's evaluator
(:meth:`~dsmpepc_nlp.solve.exact.evaluator.Evaluator.geometry` and
:meth:`~dsmpepc_nlp.solve.exact.evaluator.Evaluator.circle_gaps`).
"""

from __future__ import annotations

import math

import numpy as np

from ...core.config import PlannerConfig
from ...core.control_law import Trajectory, rollout
from ...core.geometry import footprint_points
from ..exact.evaluator import Evaluator
from ..optimize.starts import stop_z

STILL = 0.01
"""m/s: ways within this of the least approach are as still (a centimetre a second, above
round-off); the widest gap among them is taken."""


def clearance(trajectories: Trajectory, evaluator: Evaluator, within: float) -> np.ndarray:
    """m, per trajectory of the batch: the smallest gap between its footprint and any object
    (the map; the people where the cost predicts them) over its first ``within`` seconds,
    the exact geometry's distance (``evaluator.geometry``, the plan's cycle); inf with
    nothing around."""
    distance = evaluator.geometry(trajectories).distance
    if distance.shape[-1] == 0:
        return np.full(len(trajectories), np.inf)
    steps = math.ceil(within / evaluator.cycle.config.horizon.dt - 1e-9)
    return distance[:, :steps + 1].min(axis=(1, 2))


def stopping(state, config: PlannerConfig) -> Trajectory:
    """A batch of one from ``state``: the stop trajectory (:func:`.starts.stop_z`), speed and
    turn rate braked to zero within the robot's limits and held there."""
    return rollout(stop_z(config)[None, :], state, config)


def approach_at_contact(trajectories: Trajectory, evaluator: Evaluator,
                        within: float) -> np.ndarray:
    """m/s, per trajectory of the batch: its fastest approach at a contact over its first
    ``within`` seconds. At the first pose whose footprint overlaps each person (the people
    where the cost predicts them), the velocity its overlapping footprint circle arrives or
    leaves with (:func:`circle_velocities`), along the line from that circle to the person's
    (what the contact's fault is read by; later poses are the prediction walking them through
    the robot); at the first pose that overlaps the map, the whole speed of its fastest circle
    (a wall does not give way). 0 where it touches nothing or only moves away. Measured in
    the plan's cycle by its ``evaluator``."""
    config, world = evaluator.cycle.config, evaluator.cycle.world
    steps = math.ceil(within / config.horizon.dt - 1e-9)
    poses = trajectories.poses[:, :steps + 1]
    n, s = poses.shape[:2]
    points = footprint_points(poses, config.robot.footprint)                        # (n,s,C,2)
    arriving, leaving = circle_velocities(trajectories, points)                     # (n,s,C,2)
    approach = np.zeros(n)
    if world.grid is not None:                           # the map's column comes first
        walls = evaluator.geometry(trajectories).distance[:, :s, 0] < 0
        fast = np.maximum(np.linalg.norm(arriving, axis=-1),
                          np.linalg.norm(leaving, axis=-1)).max(axis=-1)              # (n,s)
        approach = np.where(walls.any(axis=1), fast[np.arange(n), walls.argmax(1)], 0.0)
    if world.obstacles:
        rel, gap = evaluator.circle_gaps(points, np.arange(s) * config.horizon.dt)
        touching = gap < 0.0                                                        # (n,s,C,K)
        toward_them = -rel / np.maximum(np.linalg.norm(rel, axis=-1), 1e-12)[..., None]
        toward = np.maximum(np.einsum("nscd,nsckd->nsck", arriving, toward_them),
                            np.einsum("nscd,nsckd->nsck", leaving, toward_them))
        toward = np.where(touching, toward, -np.inf).max(axis=2)                   # (n,s,K)
        first = touching.any(axis=2).argmax(axis=1)[:, None]                       # (n,1,K)
        at_first = np.take_along_axis(toward, first, axis=1)[:, 0]                 # (n,K)
        approach = np.maximum(approach, at_first.max(axis=1, initial=0.0))
    return np.maximum(approach, 0.0)


def circle_velocities(trajectories: Trajectory, points: np.ndarray) -> tuple:
    """``(arriving, leaving)``, m/s, each (n, s, C, 2): every footprint circle's velocity over
    the period that ends at each of the first ``s`` poses and the one that starts there (the
    start's arriving is its own first period's), for circle centres ``points`` (n, s, C, 2) at
    those poses: the speed along the heading plus the turn rate swinging the circle's offset
    from the reference point, so a turn in place moves a circle off the centre as the
    simulator's at-fault test reads it."""
    poses = trajectories.poses[:, :points.shape[1]]
    s = poses.shape[1]
    offset = points - poses[..., None, :2]                                          # (n,s,C,2)
    swing = np.stack([-offset[..., 1], offset[..., 0]], axis=-1)
    heading = np.stack([np.cos(poses[..., 2]), np.sin(poses[..., 2])], axis=-1)     # (n,s,2)

    def velocity(v, omega):                                                         # (n,s)
        return v[..., None, None] * heading[:, :, None, :] + omega[..., None, None] * swing

    v, omega = (np.asarray(a, dtype=float) for a in (trajectories.v, trajectories.omega))
    before = [np.concatenate([a[:, :1], a], axis=1)[:, :s] for a in (v, omega)]
    after = [np.concatenate([a, a[:, -1:]], axis=1)[:, :s] for a in (v, omega)]
    return velocity(*before), velocity(*after)


def least_approaching(trajectories: Trajectory, gaps: np.ndarray, evaluator: Evaluator,
                      within: float) -> int:
    """The index of the way of ``trajectories`` least fast toward whoever it touches
    (:func:`approach_at_contact`, within :data:`STILL`), the widest of ``gaps`` among them,
    the first on a tie (the plan, put first)."""
    approach = approach_at_contact(trajectories, evaluator, within)
    still = approach <= approach.min() + STILL
    return int(np.argmax(np.where(still, np.where(np.isnan(gaps), -np.inf, gaps), -np.inf)))
