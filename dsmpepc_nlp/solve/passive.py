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
docs/method.md section 7.5.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.config import PlannerConfig
from ..core.control_law import Trajectory, rollout
from ..core.exact_cost import circle_gaps, exact_geometry
from ..core.geometry import footprint_points
from .starts import stop_z

STILL = 0.01
"""m/s: ways within this of the least approach are as still (a centimetre a second, above
round-off); the widest gap among them is taken."""


def clearance(trajectories: Trajectory, cycle, within: float) -> np.ndarray:
    """m, per trajectory of the batch: the smallest gap between its footprint and any object
    (the map; the people where the cost predicts them) over its first ``within`` seconds,
    the exact geometry's distance; inf with nothing around."""
    distance = exact_geometry(trajectories, cycle.world, cycle.goal, cycle.config).distance
    if distance.shape[-1] == 0:
        return np.full(len(trajectories), np.inf)
    steps = math.ceil(within / cycle.config.horizon.dt - 1e-9)
    return distance[:, :steps + 1].min(axis=(1, 2))


def stopping(state, config: PlannerConfig) -> Trajectory:
    """A batch of one from ``state``: the stop trajectory (:func:`.starts.stop_z`), speed and
    turn rate braked to zero within the robot's limits and held there."""
    return rollout(stop_z(config)[None, :], state, config)


def approach_at_contact(trajectories: Trajectory, cycle, within: float) -> np.ndarray:
    """m/s, per trajectory of the batch: its fastest approach at a contact over its first
    ``within`` seconds. At the first pose whose footprint overlaps each person (the people
    where the cost predicts them), the speed it arrives or leaves with along the line from
    the footprint's circle to the person's (what the contact's fault is read by; later poses
    are the prediction walking them through the robot); at the first pose that overlaps the
    map, the whole speed (a wall does not give way). 0 where it touches nothing or only moves
    away."""
    config, world = cycle.config, cycle.world
    steps = math.ceil(within / config.horizon.dt - 1e-9)
    poses = trajectories.poses[:, :steps + 1]
    n, s = poses.shape[:2]
    v = np.asarray(trajectories.v, dtype=float)
    arriving = np.concatenate([v[:, :1], v], axis=1)[:, :s]       # the start's from period 0
    leaving = np.concatenate([v, v[:, -1:]], axis=1)[:, :s]
    approach = np.zeros(n)
    if world.grid is not None:                           # the map's column comes first
        walls = exact_geometry(trajectories, world, cycle.goal, config).distance[:, :s, 0] < 0
        fast = np.maximum(np.abs(arriving), np.abs(leaving))[np.arange(n), walls.argmax(1)]
        approach = np.where(walls.any(axis=1), fast, 0.0)
    if world.obstacles:
        points = footprint_points(poses, config.robot.footprint)                    # (n,s,C,2)
        rel, gap = circle_gaps(world, config, points, np.arange(s) * config.horizon.dt)
        touching, length = gap < 0.0, np.linalg.norm(rel, axis=-1)               # (n,s,C,K)
        heading = np.stack([np.cos(poses[..., 2]), np.sin(poses[..., 2])], -1)     # (n,s,2)
        along = -np.einsum("nsckd,nsd->nsck", rel, heading) / np.maximum(length, 1e-12)
        toward = np.maximum(along * arriving[..., None, None], along * leaving[..., None, None])
        toward = np.where(touching, toward, -np.inf).max(axis=2)                   # (n,s,K)
        first = touching.any(axis=2).argmax(axis=1)[:, None]                       # (n,1,K)
        at_first = np.take_along_axis(toward, first, axis=1)[:, 0]                 # (n,K)
        approach = np.maximum(approach, at_first.max(axis=1, initial=0.0))
    return np.maximum(approach, 0.0)


def least_approaching(trajectories: Trajectory, gaps: np.ndarray, cycle, within: float) -> int:
    """The index of the way of ``trajectories`` least fast toward whoever it touches
    (:func:`approach_at_contact`, within :data:`STILL`), the widest of ``gaps`` among them,
    the first on a tie (the plan, put first)."""
    approach = approach_at_contact(trajectories, cycle, within)
    still = approach <= approach.min() + STILL
    return int(np.argmax(np.where(still, np.where(np.isnan(gaps), -np.inf, gaps), -np.inf)))
