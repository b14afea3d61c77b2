"""Navigation metrics: pure functions of a logged :class:`~dsmpepc_nlp.sim.episode.Episode`.

Every metric of a robot is measured over its *run*: the states from the start up to and
including the one at which its outcome was decided (afterwards it stands still).

Besides our own figures these are the crowd-navigation field's (CrowdNav; Francis et al. 2023):
success (any collision is a failure), collision split by who moved into whom
(:func:`collision_kind`: ``at-fault`` when the robot's own velocity had a component toward the
body it touched, ``struck`` when it was stopped or moving away), timeout, time to goal, path
length, SPL (:func:`spl`), minimum distance, discomfort and jerk.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.geometry import footprint_points
from ..core.world import World

DISCOMFORT_GAP = 0.2
"""A pedestrian closer than this (gap between footprint and pedestrian circle, m) is discomfort."""
AT_FAULT_SPEED = 0.01
"""At contact, a robot whose velocity toward the touched body exceeds this (m/s) is at fault;
at or below it the robot counts as stopped (our choice: above numerical noise, below any
deliberate creep)."""
COLLISION_KINDS = ("at-fault", "struck")
"""The two kinds of collision :func:`collision_kind` tells apart."""


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


def _bodies_at(episode, robot, k):
    """Centres (M, 2) and radii (M,) of every circular body but ``robot``'s at state ``k``."""
    centres = [episode.ped_positions[k]] if episode.ped_radii.size else []
    radii = [episode.ped_radii] if episode.ped_radii.size else []
    for j in range(episode.n_robots):
        if j != robot:
            fp = episode.footprint(j)
            centres.append(footprint_points(episode.states[j, k, :3], fp[:, :2]))
            radii.append(fp[:, 2])
    for parked in episode.meta.get("parked", []):
        fp = np.asarray(parked["footprint"], dtype=float)
        centres.append(footprint_points(np.asarray(parked["pose"], dtype=float), fp[:, :2]))
        radii.append(fp[:, 2])
    if not centres:
        return np.zeros((0, 2)), np.zeros(0)
    return np.concatenate(centres).reshape(-1, 2), np.concatenate(radii)


def _toward_map(grid, point) -> tuple:
    """Gap from ``point`` to the map and the unit direction toward the nearest obstacle."""
    world, h = World(grid), grid.resolution
    probe = point + np.array([[0, 0], [h, 0], [-h, 0], [0, h], [0, -h]], dtype=float)
    d = world.static_distance(probe)
    gradient = np.array([d[1] - d[2], d[3] - d[4]]) / (2 * h)
    norm = float(np.hypot(*gradient))
    return float(d[0]), (-gradient / norm if norm > 1e-12 else np.zeros(2))


def _contact_normals(before, here, centres_before, centres_here, radii):
    """Over one step of straight-line relative motion between every robot circle (``before``
    -> ``here``, (C, 2)) and every body (M, 2 -> M, 2; radii (M,) + the circles' (C,)):
    the smallest gap (C, M) and the unit direction (C, M, 2) from circle to body at the
    first touch (at the closest approach where they do not touch)."""
    a = centres_before[None, :, :] - before[:, None, :2]                  # (C, M, 2)
    d = (centres_here[None, :, :] - here[:, None, :2]) - a
    reach = before[:, 2][:, None] + radii[None, :]
    dd = np.maximum(np.sum(d * d, axis=-1), 1e-18)
    ad = np.sum(a * d, axis=-1)
    s_close = np.clip(-ad / dd, 0.0, 1.0)
    disc = ad**2 - dd * (np.sum(a * a, axis=-1) - reach**2)
    s_touch = np.clip((-ad - np.sqrt(np.maximum(disc, 0.0))) / dd, 0.0, 1.0)
    s = np.where(disc >= 0, np.minimum(s_touch, s_close), s_close)
    offset = a + s[..., None] * d
    gaps = np.linalg.norm(a + s_close[..., None] * d, axis=-1) - reach
    return gaps, offset / np.maximum(np.linalg.norm(offset, axis=-1, keepdims=True), 1e-12)


def contact_approach_speed(episode, robot: int) -> float:
    """Speed (m/s) of the robot toward the body it touched at its outcome; NaN if no collision.

    The touched body is the one the robot came closest to over the last step (a pedestrian,
    another robot, a parked robot), or the map if the robot overlaps it more at the outcome
    state. The direction toward a moving body is taken at the moment of first touch within
    the step (both moving in straight lines between their logged states), so a contact made
    and passed between two states is judged where it happened. The robot's velocity is that of
    its nearest footprint circle over the last step (the logged state at the outcome already
    has v = 0, the robot having stopped there), so turning counts too.
    """
    if episode.outcomes[robot] != "collision":
        return math.nan
    k = run_length(episode, robot) - 1
    fp = episode.footprint(robot)
    here = footprint_points(episode.states[robot, k, :3], fp[:, :2])            # (C, 2)
    if k > 0:
        before = footprint_points(episode.states[robot, k - 1, :3], fp[:, :2])
        velocity = (here - before) / (episode.times[k] - episode.times[k - 1])
    else:
        x, y, phi, v = episode.states[robot, 0, :4]
        before = here
        velocity = np.tile([v * math.cos(phi), v * math.sin(phi)], (len(here), 1))
    best_gap, best_dir, best_c = math.inf, np.zeros(2), 0
    centres, radii = _bodies_at(episode, robot, k)
    if radii.size:
        centres_before = _bodies_at(episode, robot, max(k - 1, 0))[0]
        gaps, directions = _contact_normals(np.column_stack([before, fp[:, 2]]), here,
                                            centres_before, centres, radii)
        c, m = np.unravel_index(int(np.argmin(gaps)), gaps.shape)
        best_gap, best_c, best_dir = float(gaps[c, m]), int(c), directions[c, m]
    grid = episode.grid
    if grid is not None:
        for c, point in enumerate(here):
            d, direction = _toward_map(grid, point)
            if d - fp[c, 2] < best_gap:
                best_gap, best_dir, best_c = d - fp[c, 2], direction, c
    return float(np.dot(velocity[best_c], best_dir))


def swept_contact_time(episode, robot: int) -> float:
    """Time of the state ending the first step in which the robot touched a pedestrian, s;
    NaN if it never did within its run.

    Within a step both bodies are taken to move in straight lines between their logged
    states, and contact is the closest approach of that relative motion (CrowdNav's check),
    so a contact that begins and ends between two states counts too.
    """
    stop = run_length(episode, robot)
    if stop < 2 or not episode.ped_radii.size:
        return math.nan
    points, radii = _points(episode, robot, stop)                        # (T, C, 2), (C,)
    ped = episode.ped_positions[:stop]                                    # (T, P, 2)
    rel = points[:, :, None, :] - ped[:, None, :, :]                      # (T, C, P, 2)
    start, move = rel[:-1], np.diff(rel, axis=0)
    denom = np.maximum(np.sum(move * move, axis=-1), 1e-18)
    s = np.clip(-np.sum(start * move, axis=-1) / denom, 0.0, 1.0)
    closest = np.linalg.norm(start + s[..., None] * move, axis=-1)         # (T-1, C, P)
    gaps = closest - radii[None, :, None] - episode.ped_radii[None, None, :]
    touched = np.flatnonzero(np.any(gaps < 0, axis=(1, 2)))
    return float(episode.times[touched[0] + 1]) if touched.size else math.nan


def collision_kind(episode, robot: int) -> str | None:
    """``"at-fault"``, ``"struck"`` or None (the outcome is not a collision).

    At fault: at contact the robot moved toward the touched body faster than
    :data:`AT_FAULT_SPEED` (:func:`contact_approach_speed`); struck: it was stopped or moving
    away, so the other body closed the gap.
    """
    speed = contact_approach_speed(episode, robot)
    if math.isnan(speed):
        return None
    return "at-fault" if speed > AT_FAULT_SPEED else "struck"


def shortest_path_length(episode, robot: int) -> float:
    """Shortest path from the start to the goal, m: the straight line without a map, the
    navigation function's value at the start (the robot's inflation) with one; NaN for a
    follow goal."""
    if episode.meta["goal_kinds"][robot] != "fixed":
        return math.nan
    start, goal = episode.states[robot, 0, :2], episode.goals[robot, 0]
    grid = episode.grid
    if grid is None:
        return float(np.hypot(*(goal - start)))
    inflation = float(np.max(episode.footprint(robot)[:, 2]))  # RobotConfig.inflation_radius
    return float(World(grid).navigation(goal, inflation).value(start))


def spl(episode, robot: int) -> float:
    """Success weighted by path length (Anderson et al. 2018): ``S * l / max(p, l)`` with ``S``
    1 for a success, ``l`` the :func:`shortest_path_length` and ``p`` the driven
    :func:`path_length`; NaN for a follow goal."""
    shortest = shortest_path_length(episode, robot)
    if math.isnan(shortest):
        return math.nan
    if episode.outcomes[robot] != "success":
        return 0.0
    return float(shortest / max(path_length(episode, robot), shortest, 1e-12))


def plan_times(episode, robot: int) -> tuple:
    """``(median, 95th percentile, 99th percentile, maximum)`` wall time of the robot's plans,
    s."""
    times = episode.plan_time[robot][episode.active[robot]]
    if times.size == 0:
        return (math.nan,) * 4
    return (float(np.median(times)), float(np.percentile(times, 95)),
            float(np.percentile(times, 99)), float(np.max(times)))


def plans_out_of_time(episode, robot: int) -> float:
    """How many of the robot's plans ran out of their time budget (NaN for a log written
    before it was recorded)."""
    if getattr(episode, "out_of_time", None) is None:
        return math.nan
    return float(np.sum(episode.out_of_time[robot][episode.active[robot]]))


def robot_metrics(episode, robot: int) -> dict:
    """Every metric of one robot, as a flat JSON-able dict (NaN for "not applicable")."""
    alpha, jerk = smoothness(episode, robot)
    median, p95, p99, longest = plan_times(episode, robot)
    statuses = episode.status_names(robot)
    return {
        "robot": episode.meta["robots"][robot],
        "outcome": episode.outcomes[robot],
        "outcome_time": float(episode.outcome_times[robot]),
        "collision_kind": collision_kind(episode, robot),
        "contact_approach_speed": contact_approach_speed(episode, robot),
        "spl": spl(episode, robot),
        "shortest_path_length": shortest_path_length(episode, robot),
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
        "plan_time_p99": p99,
        "plan_time_max": longest,
        "plans_out_of_time": plans_out_of_time(episode, robot),
        "cycles": int(np.sum(episode.active[robot])),
        "nlp_plans": statuses.count("nlp"),
        "fallback_plans": statuses.count("sampling-fallback") + statuses.count("stopped"),
    }


def episode_metrics(episode) -> list:
    """:func:`robot_metrics` of every robot, in order."""
    return [robot_metrics(episode, i) for i in range(episode.n_robots)]

