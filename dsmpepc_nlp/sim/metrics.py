"""Navigation metrics: pure functions of a logged :class:`~dsmpepc_nlp.simulate.Episode`.

Every metric of a robot is measured over its *run*: the states from the start up to and
including the one at which its outcome was decided (afterwards it stands still).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.geometry import footprint_points
from ..core.jsonio import json_clean
from ..core.world import World

DISCOMFORT_GAP = 0.2
"""A pedestrian closer than this (gap between footprint and pedestrian circle, m) is discomfort."""


def run_length(episode, robot: int) -> int:
    """Number of states in the robot's run (index of its outcome state + 1)."""
    t_end = episode.outcome_times[robot]
    if not math.isfinite(t_end):
        return episode.times.size
    return int(np.searchsorted(episode.times, t_end - 1e-9)) + 1


def path_length(episode, robot: int) -> float:
    """Length of the driven path, m."""
    xy = episode.states[robot, :run_length(episode, robot), :2]
    return float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=-1)))


def time_to_goal(episode, robot: int) -> float:
    """Time of a ``success``, s; NaN for any other outcome."""
    return float(episode.outcome_times[robot]) if episode.outcomes[robot] == "success" \
        else math.nan


def _points(episode, robot, stop):
    fp = episode.footprint(robot)
    return footprint_points(episode.states[robot, :stop, :3], fp[:, :2]), fp[:, 2]


def min_static_clearance(episode, robot: int) -> float:
    """Smallest gap between the footprint and the map over the run, m (inf without a map)."""
    grid = episode.grid
    if grid is None:
        return math.inf
    points, radii = _points(episode, robot, run_length(episode, robot))
    return float(np.min(World(grid).static_distance(points) - radii))


def _gaps(episode, robot, stop, pedestrians_only=False):
    """Per-state smallest gap to the pedestrians (and the other robots), (stop,)."""
    points, radii = _points(episode, robot, stop)                        # (T, C, 2), (C,)
    gaps = np.full(stop, np.inf)
    if episode.ped_radii.size:
        ped = episode.ped_positions[:stop]                                # (T, P, 2)
        d = np.linalg.norm(points[:, :, None, :] - ped[:, None, :, :], axis=-1)
        gaps = np.minimum(gaps, (d - radii[:, None] - episode.ped_radii).min(axis=(1, 2)))
    if pedestrians_only:
        return gaps
    for j in range(episode.n_robots):
        if j == robot:
            continue
        other, other_r = _points(episode, j, episode.times.size)
        d = np.linalg.norm(points[:, :, None, :] - other[:stop, None, :, :], axis=-1)
        gaps = np.minimum(gaps, (d - radii[:, None] - other_r).min(axis=(1, 2)))
    for parked in episode.meta.get("parked", []):
        fp = np.asarray(parked["footprint"], dtype=float)
        centres = footprint_points(np.asarray(parked["pose"], dtype=float), fp[:, :2])
        d = np.linalg.norm(points[:, :, None, :] - centres[None, None], axis=-1)
        gaps = np.minimum(gaps, (d - radii[:, None] - fp[:, 2]).min(axis=(1, 2)))
    return gaps


def min_dynamic_clearance(episode, robot: int) -> float:
    """Smallest gap to any pedestrian, other robot or parked robot over the run, m."""
    return float(np.min(_gaps(episode, robot, run_length(episode, robot))))


def discomfort(episode, robot: int, threshold: float = DISCOMFORT_GAP) -> float:
    """Share of the run's states with a pedestrian closer than ``threshold`` (gap, m)."""
    gaps = _gaps(episode, robot, run_length(episode, robot), pedestrians_only=True)
    return float(np.mean(gaps < threshold))


def smoothness(episode, robot: int) -> tuple:
    """``(mean |angular acceleration| rad/s^2, mean |linear jerk| m/s^3)`` over the run."""
    stop = run_length(episode, robot)
    v, omega = episode.states[robot, :stop, 3], episode.states[robot, :stop, 4]
    dt = episode.dt
    alpha = np.diff(omega) / dt
    jerk = np.diff(v, n=2) / dt**2
    return (float(np.mean(np.abs(alpha))) if alpha.size else 0.0,
            float(np.mean(np.abs(jerk))) if jerk.size else 0.0)


def following_distance(episode, robot: int) -> float:
    """Mean centre distance to the followed pedestrian, m; NaN for a fixed goal."""
    follow = episode.meta["follow"][robot]
    if follow is None:
        return math.nan
    stop = run_length(episode, robot)
    target = episode.ped_positions[:stop, int(follow[0])]
    return float(np.mean(np.linalg.norm(episode.states[robot, :stop, :2] - target, axis=-1)))


def plan_times(episode, robot: int) -> tuple:
    """``(median, 95th percentile)`` wall time of the robot's plans, s."""
    times = episode.plan_time[robot][episode.active[robot]]
    if times.size == 0:
        return (math.nan, math.nan)
    return (float(np.median(times)), float(np.percentile(times, 95)))


def robot_metrics(episode, robot: int) -> dict:
    """Every metric of one robot, as a flat JSON-able dict (NaN for "not applicable")."""
    alpha, jerk = smoothness(episode, robot)
    median, p95 = plan_times(episode, robot)
    statuses = episode.status_names(robot)
    return {
        "robot": episode.meta["robots"][robot],
        "outcome": episode.outcomes[robot],
        "outcome_time": float(episode.outcome_times[robot]),
        "time_to_goal": time_to_goal(episode, robot),
        "path_length": path_length(episode, robot),
        "min_static_clearance": min_static_clearance(episode, robot),
        "min_dynamic_clearance": min_dynamic_clearance(episode, robot),
        "discomfort": discomfort(episode, robot),
        "mean_angular_acceleration": alpha,
        "mean_linear_jerk": jerk,
        "following_distance": following_distance(episode, robot),
        "plan_time_median": median,
        "plan_time_p95": p95,
        "cycles": int(np.sum(episode.active[robot])),
        "nlp_plans": statuses.count("nlp"),
        "fallback_plans": statuses.count("sampling-fallback") + statuses.count("stopped"),
    }


def episode_metrics(episode) -> list:
    """:func:`robot_metrics` of every robot, in order."""
    return [robot_metrics(episode, i) for i in range(episode.n_robots)]


json_safe = json_clean
"""NaN and inf replaced by None, recursively: :func:`~dsmpepc_nlp.core.jsonio.json_clean`."""
