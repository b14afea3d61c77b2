"""Scenario checks against the world: starts in free space (with and without start noise),
robot goals and pedestrian paths against the map.

Errors name the scenario file and the field path (``pedestrians[2].waypoints[1]``); things
that may be meant (a goal or a pedestrian beyond the map's edge: the map ends, the world does
not) are warnings that say so.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..core.config import RobotConfig
from ..core.errors import InputError
from ..core.geometry import footprint_points
from .types import FixedGoal


def _body(agent, pose):
    """World centres (C, 2) and radii (C,) of an agent's footprint at ``pose``."""
    circles = np.asarray((agent.robot or RobotConfig()).footprint, dtype=float)
    return footprint_points(np.asarray(pose, dtype=float), circles[:, :2]), circles[:, 2]


def _overlap(centres, radii, other_centres, other_radii) -> float:
    """How deep (m) two sets of circles overlap; <= 0 when they are apart."""
    gaps = np.linalg.norm(centres[:, None, :] - other_centres[None, :, :], axis=-1)
    return float(np.max(radii[:, None] + other_radii[None, :] - gaps))


def start_conflict(i, starts, agents, grid, parked, pedestrians) -> str:
    """What robot ``i``'s footprint at ``starts[i]`` (x, y, phi) overlaps at t = 0, or "".

    Checked against the map (the signed distance that decides a collision), robots ``0..i-1``
    at ``starts``, the parked robots and the pedestrians at t = 0: a start that is already a
    collision is an error, not an episode.
    """
    centres, radii = _body(agents[i], starts[i])
    if grid is not None:
        depth = float(np.max(radii - grid.distance(centres)))
        if depth > 0:
            return f"the footprint overlaps the map by {depth:.3f} m"
    for j in range(i):
        depth = _overlap(centres, radii, *_body(agents[j], starts[j]))
        if depth > 0:
            return f"overlaps robots[{j}] ({agents[j].name!r}) at t = 0 by {depth:.3f} m"
    for k, robot in enumerate(parked):
        circles = np.asarray(robot.footprint, dtype=float)
        other = footprint_points(np.asarray(robot.pose, dtype=float), circles[:, :2])
        depth = _overlap(centres, radii, other, circles[:, 2])
        if depth > 0:
            return f"overlaps parked_robots[{k}] by {depth:.3f} m"
    for k, person in enumerate(pedestrians):
        depth = _overlap(centres, radii, person.position(0.0)[None], np.array([person.radius]))
        if depth > 0:
            return f"overlaps pedestrians[{k}] at t = 0 by {depth:.3f} m"
    return ""


START_DRAWS = 100
"""Draws of one robot's start perturbation before a scenario's ``start_noise`` is rejected."""


def start_states(scenario, rng) -> list:
    """Start states ``[x, y, phi, v, omega]`` with ``scenario.start_noise`` applied.

    The noise (a Gaussian of standard deviation ``start_noise`` m on x and y, robot by robot)
    is applied BEFORE the free-space checks of :func:`start_conflict`: a draw that puts a
    robot's footprint into the map, an earlier robot, a parked robot or a pedestrian is drawn
    again, up to :data:`START_DRAWS` times, after which an InputError names the scenario, the
    robot and the noise. Without noise the starts are as written (the loader checked them).
    """
    noise = scenario.start_noise
    agents = scenario.agents
    starts = [a.start.pose for a in agents]
    for i, agent in enumerate(agents):
        if noise <= 0:
            continue
        for _ in range(START_DRAWS):
            dx, dy = rng.normal(0.0, noise, 2)
            starts[i] = (agent.start.x + dx, agent.start.y + dy, agent.start.phi)
            if not start_conflict(i, starts, agents, scenario.grid, scenario.parked,
                                  scenario.pedestrians):
                break
        else:
            raise InputError(f"scenario {scenario.name!r}: robots[{i}] ({agent.name!r}): no "
                             f"start in free space in {START_DRAWS} draws with start_noise = "
                             f"{noise} m")
    return [np.array([x, y, phi, a.start.v, a.start.omega], dtype=float)
            for (x, y, phi), a in zip(starts, agents)]


def check_against_map(r, grid, agents, pedestrians, duration) -> None:
    """Robot goals and pedestrian paths against the map.

    Errors (``r.fail``): a fixed goal, a pedestrian's start or one of its waypoints inside an
    obstacle of the map (the map's signed distance at the point decides). Warnings: a fixed
    goal or a pedestrian's start or waypoint outside the map's edges, and a pedestrian whose
    path (sampled every half cell over the scenario's ``duration``) walks through an obstacle.
    """
    for i, agent in enumerate(agents):
        if isinstance(agent.goal, FixedGoal):
            _point(r, grid, f"robots[{i}].goal.position", agent.goal.position, "a goal")
    for k, person in enumerate(pedestrians):
        where = f"pedestrians[{k}]"
        if person.times.size == 1:
            _point(r, grid, f"{where}.start", person.positions[0], "a pedestrian's start")
        else:
            for j, point in enumerate(person.positions):
                _point(r, grid, f"{where}.waypoints[{j}]", point, "a waypoint")
        crossing = _first_crossing(grid, person, duration)
        if crossing is not None:
            t, (x, y) = crossing
            _warn(r, where, f"walks through an obstacle of the map at t = {t:.1f} s, near "
                  f"({x:.2f}, {y:.2f}) m; give it waypoints around the obstacle")


def _point(r, grid, path, point, what) -> None:
    x, y = (float(c) for c in point)
    xmin, ymin, xmax, ymax = grid.bounds
    if not (xmin <= x <= xmax and ymin <= y <= ymax):
        _warn(r, path, f"[{x:g}, {y:g}] is outside the map (x in [{xmin:g}, {xmax:g}], y in "
              f"[{ymin:g}, {ymax:g}] m); allowed, but nothing there is mapped")
        return
    inside = float(grid.distance(np.array([x, y])))
    if inside < 0:
        r.fail(path, f"[{x:g}, {y:g}]: inside an obstacle of the map ({-inside:.3f} m deep); "
               f"{what} must be in free space")


def _first_crossing(grid, person, duration):
    """(t, position) where the pedestrian's centre is first inside an obstacle, or None."""
    speed = max(float(np.max(np.abs(np.diff(person.positions, axis=0)) /
                             np.diff(person.times)[:, None])) if person.times.size > 1 else 0.0,
                float(np.max(np.abs(person.velocity))))
    if speed == 0.0:
        return None
    steps = int(min(max(2.0, 2.0 * speed * duration / grid.resolution), 20_000))
    times = np.linspace(0.0, duration, steps + 1)
    points = np.array([person.position(t) for t in times])
    inside = np.flatnonzero(grid.distance(points) < 0)
    return None if inside.size == 0 else (float(times[inside[0]]), points[inside[0]])


def _warn(r, path, problem) -> None:
    warnings.warn(f"scenario {r.source}: {path}: {problem}", UserWarning, stacklevel=5)
