"""A simulated robot's senses under a :class:`~.sensing.SensingProfile`: what it believes of the
world each cycle, and what its plant executes of a command.

:class:`Senses` is one robot's: :meth:`Senses.perceive` turns the truth (its pose, the map, the
people, the other robots) into the state and the :class:`~dsmpepc_nlp.core.world.World` the
planner is given, through the product's own perception (:mod:`dsmpepc_nlp.perception`): a
simulated lidar scan into the local map, simulated detections into the tracker.
:meth:`Senses.execute` is the plant. Every draw comes from the generator it is built with.

Frames. With localisation error the robot believes itself at ``pose + error``; everything it
senses relative to itself (scans, detections, the other robots' shared poses) is placed
relative to that belief, so the believed world is the true one moved by the error's rigid
motion (:meth:`Senses.to_believed`). The goal stays where the task put it: a drifted robot
heads for it in its own frame, as a real one does.
"""

from __future__ import annotations

import collections
import math

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.world import DynamicObstacle, World
from ..perception import Detections, LaserScan, LocalMap, LocalMapConfig, PeopleTracker
from ..perception.scan import returns_off_objects
from .sensing import SensingProfile


def circle_ranges(origin, headings, centres, radii) -> np.ndarray:
    """m, per heading: the distance from ``origin`` (2,) along each of ``headings`` (B,) to the
    first of the circles ``centres`` (C, 2), ``radii`` (C,) it enters; inf where none. A ray
    starting inside a circle has range 0."""
    headings = np.asarray(headings, dtype=float)
    if len(radii) == 0:
        return np.full(headings.shape, np.inf)
    direction = np.stack([np.cos(headings), np.sin(headings)], axis=-1)           # (B, 2)
    rel = np.asarray(centres, dtype=float) - np.asarray(origin, dtype=float)       # (C, 2)
    along = direction @ rel.T                                                       # (B, C)
    across2 = np.sum(rel**2, axis=1)[None, :] - along**2
    radii2 = np.asarray(radii, dtype=float)[None, :] ** 2
    with np.errstate(invalid="ignore"):
        entry = along - np.sqrt(radii2 - across2)
    inside = np.sum(rel**2, axis=1)[None, :] <= radii2
    hit = (across2 <= radii2) & ((entry >= 0.0) | inside)
    return np.where(hit, np.where(inside, 0.0, entry), np.inf).min(axis=1)


def _rotation(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


class Senses:
    """One robot's senses and plant under ``profile`` (see the module docstring).

    Parameters
    ----------
    profile : SensingProfile
    config : PlannerConfig
        The robot's (its limits drive the plant; ``horizon.dt`` is the control period).
    grid : OccupancyGrid or None
        The true static map the lidar and the detector's occlusion see.
    rng : numpy.random.Generator
    """

    def __init__(self, profile: SensingProfile, config: PlannerConfig, grid, rng):
        self.profile, self.config, self.grid, self.rng = profile, config, grid, rng
        self.dt = config.horizon.dt
        self.error = np.zeros(3)                 # the localisation's drift: x, y, heading
        self.offset = np.zeros(3)                # drift plus this cycle's jitter
        self.local_map = None
        if profile.lidar is not None:
            lidar = profile.lidar
            self.local_map = LocalMap(LocalMapConfig(
                size=lidar.window, resolution=lidar.resolution, mark_beyond=lidar.mark_beyond,
                obstacle_max_range=lidar.range_max, raytrace_max_range=lidar.range_max))
            self.local_map.prepare()
        self.tracker = None if profile.detector is None else PeopleTracker(profile.tracker)
        self.pending = collections.deque()        # detections not yet handed over
        self.commands = collections.deque()       # commands not yet executed (the delay)
        self.counts = collections.Counter()

    # -- belief ------------------------------------------------------------------------------

    def perceive(self, t: float, state, people: tuple, others: list) -> tuple:
        """``(believed RobotState, believed World)`` at time ``t`` from the true ``state``
        (x, y, phi, v, omega), ``people`` ``(positions (P, 2), velocities (P, 2), radii
        (P,))`` and ``others`` (the other robots and parked robots as DynamicObstacles, whose
        poses robots share)."""
        state = np.asarray(state, dtype=float)
        self._localise()
        believed = state.copy()
        believed[:3] = state[:3] + self.offset
        positions, velocities, radii = (np.asarray(a, dtype=float) for a in people)
        moved = [self._moved(o, state) for o in others]
        if self.tracker is not None:
            walkers = self._tracked(t, state, positions, radii)
        else:
            walkers = [DynamicObstacle.pedestrian(self.to_believed(p, state),
                                                  _rotation(self.offset[2]) @ v, r)
                       for p, v, r in zip(positions, velocities, radii)]
        grid = self.grid
        if self.local_map is not None:
            grid = self.mapped(t, state, believed, positions, radii, others, walkers + moved)
        self.last_world = World(grid, walkers + moved)
        return RobotState(*(float(v) for v in believed)), self.last_world

    def to_believed(self, points, state) -> np.ndarray:
        """World ``points`` (..., 2) as the robot at the true ``state`` places them: relative to
        its believed pose (the error's rigid motion about the true position)."""
        points = np.asarray(points, dtype=float)
        rel = points - state[:2]
        return rel @ _rotation(self.offset[2]).T + state[:2] + self.offset[:2]

    def _localise(self) -> None:
        """This cycle's pose error: the drift's random walk and a fresh jitter."""
        loc = self.profile.localisation
        if loc is None:
            return
        step = math.sqrt(self.dt)
        self.error += self.rng.normal(0.0, 1.0, 3) * np.array(
            [loc.drift * step, loc.drift * step, loc.heading_drift * step])
        self.offset = self.error + self.rng.normal(0.0, 1.0, 3) * np.array(
            [loc.jitter, loc.jitter, loc.heading_jitter])

    def _moved(self, obstacle: DynamicObstacle, state) -> DynamicObstacle:
        """``obstacle`` in the believed frame."""
        if not np.any(self.offset):
            return obstacle
        return DynamicObstacle(self.to_believed(obstacle.centers, state), obstacle.radii,
                               _rotation(self.offset[2]) @ obstacle.velocity, obstacle.kind)

    # -- the lidar ---------------------------------------------------------------------------

    def scan_ranges(self, state, people_positions, people_radii, others) -> tuple:
        """``(sensor pose (3,), headings (B,), ranges (B,))`` of one true scan from ``state``:
        the map, the people and the other robots occlude; Gaussian range noise; inf beyond
        ``range_max``."""
        lidar = self.profile.lidar
        x, y, phi = state[:3]
        sensor = np.array([x + lidar.mount_x * math.cos(phi), y + lidar.mount_x * math.sin(phi),
                           phi])
        offsets = np.linspace(-lidar.fov / 2, lidar.fov / 2, lidar.beams)
        headings = phi + offsets
        ranges = np.full(lidar.beams, np.inf)
        if self.grid is not None:
            ranges = self.grid.ray_distance(sensor[:2], headings, 0.0, lidar.range_max)
        circles = [np.asarray(people_positions).reshape(-1, 2)] + [o.centers for o in others]
        circle_radii = [np.asarray(people_radii).reshape(-1)] + [o.radii for o in others]
        ranges = np.minimum(ranges, circle_ranges(sensor[:2], headings,
                                                  np.concatenate(circles),
                                                  np.concatenate(circle_radii)))
        ranges = ranges + self.rng.normal(0.0, lidar.range_noise, lidar.beams)
        ranges[ranges > lidar.range_max] = np.inf
        return sensor, offsets, ranges

    def mapped(self, t, state, believed, positions, radii, others, planned):
        """The local map after this cycle's scan, integrated at the believed sensor pose; the
        returns from objects the planner is given (``planned``) are left unmarked."""
        lidar = self.profile.lidar
        sensor, offsets, ranges = self.scan_ranges(state, positions, radii, others)
        pose = np.array([believed[0] + lidar.mount_x * math.cos(believed[2]),
                         believed[1] + lidar.mount_x * math.sin(believed[2]), believed[2]])
        kept = returns_off_objects(ranges, pose, offsets, planned, lidar.object_margin)
        self.counts["returns_on_objects"] += int(np.sum(np.isnan(kept) & ~np.isnan(ranges)))
        ranges = kept
        scan = LaserScan(ranges, float(-lidar.fov / 2), float(offsets[1] - offsets[0]),
                         lidar.range_min, lidar.range_max, pose=pose, stamp=float(t))
        self.local_map.update(scan)
        return self.local_map.grid()

    # -- the detector ------------------------------------------------------------------------

    def detect(self, state, positions, radii) -> tuple:
        """``(positions (n, 2), radii (n,))`` detected from the true ``state`` now, in the
        believed frame: people in range and view, not hidden by the map or a nearer person,
        each missed with ``miss_rate``, with position noise; plus false detections."""
        detector = self.profile.detector
        x, y, phi = state[:3]
        rel = positions.reshape(-1, 2) - np.array([x, y])
        distance = np.hypot(rel[:, 0], rel[:, 1])
        bearing = np.arctan2(rel[:, 1], rel[:, 0]) - phi
        bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi
        seen = (distance <= detector.range) & (np.abs(bearing) <= detector.fov / 2)
        seen &= ~self._occluded(state[:2], positions, radii, distance)
        seen &= self.rng.random(len(seen)) >= detector.miss_rate
        found = positions[seen] + self.rng.normal(0.0, detector.position_noise,
                                                  (int(seen.sum()), 2))
        n_false = int(self.rng.poisson(detector.false_rate))
        far = detector.range * np.sqrt(self.rng.random(n_false))
        angle = phi + self.rng.uniform(-detector.fov / 2, detector.fov / 2, n_false)
        ghosts = np.stack([x + far * np.cos(angle), y + far * np.sin(angle)], axis=1)
        self.counts["detections"] += int(seen.sum())
        self.counts["false_detections"] += n_false
        default = self.tracker.config.default_radius
        return (self.to_believed(np.concatenate([found, ghosts]), state),
                np.concatenate([radii[seen], np.full(n_false, default)]))

    def _occluded(self, origin, positions, radii, distance) -> np.ndarray:
        """Per person: whether the map or a nearer person hides the person's centre."""
        n = len(distance)
        hidden = np.zeros(n, dtype=bool)
        if n == 0:
            return hidden
        rel = positions - origin
        heading = np.arctan2(rel[:, 1], rel[:, 0])
        if self.grid is not None:
            wall = self.grid.ray_distance(origin, heading, 0.0, float(np.max(distance)))
            hidden |= wall < distance - radii
        for i in range(n):
            others = np.arange(n) != i
            blocked = circle_ranges(origin, heading[i:i + 1], positions[others],
                                    radii[others])[0]
            hidden[i] |= blocked < distance[i] - radii[i]
        return hidden

    def _tracked(self, t, state, positions, radii) -> list:
        """This cycle's detections queued, those old enough handed to the tracker, and its
        confirmed tracks predicted to ``t``."""
        latency = round(self.profile.detector.latency / self.dt)
        self.pending.append((t, *self.detect(state, positions, radii)))
        while self.pending and self.pending[0][0] <= t - latency * self.dt + 1e-9:
            stamp, found, found_radii = self.pending.popleft()
            self.tracker.update(Detections(found, stamp, radii=found_radii))
        return self.tracker.obstacles(now=t)

    # -- what it missed ----------------------------------------------------------------------

    def perceived(self, state, centres, radii, ped_pos, ped_radii) -> dict:
        """At a collision of the robot at the true ``state`` (footprint ``centres`` (C, 2),
        ``radii`` (C,)): what it touched (``map`` or ``person``) and whether that was in the
        world it believed at its last plan (``believed``): the map's touching cells occupied
        within a cell of where they are, the person within half a metre of a track. True for
        what the robot was told (the map without a lidar, people without a detector)."""
        world = getattr(self, "last_world", None)
        touched = {}
        if self.grid is not None and np.any(self.grid.distance(centres) < radii):
            touched["map"] = True
            if self.local_map is not None:
                believed = None if world is None else world.grid
                hit = centres[self.grid.distance(centres) < radii]
                touched["map"] = believed is not None and bool(np.any(believed.distance(
                    self.to_believed(hit, state)) < radii.max() + believed.resolution))
        gaps = np.linalg.norm(centres[:, None] - ped_pos.reshape(-1, 2)[None], axis=-1) \
            - radii[:, None] - np.asarray(ped_radii).reshape(-1)[None]
        for k in np.flatnonzero(np.any(gaps < 0.0, axis=0)):
            believed = True
            if self.tracker is not None:
                where = self.to_believed(ped_pos[k], state)
                centres_seen = [] if world is None else [
                    o.centers[0] for o in world.obstacles if o.kind == "pedestrian"]
                believed = bool(centres_seen) and float(np.min(np.linalg.norm(
                    np.array(centres_seen) - where, axis=1))) < ped_radii[k] + 0.5
            touched["person"] = touched.get("person", True) and believed
        return {"touched": sorted(touched), "believed": all(touched.values())}

    # -- the plant ---------------------------------------------------------------------------

    def execute(self, control, state) -> tuple:
        """``(v, omega)`` the robot at the true ``state`` executes this period for the plan's
        ``control``: the command of ``plant.delay`` periods ago, within the acceleration
        limits from the actual speed and turn rate, with relative noise (the command as given
        without a plant)."""
        plant = self.profile.plant
        if plant is None:
            return tuple(float(c) for c in control)
        self.commands.append(tuple(float(c) for c in control))
        if len(self.commands) <= plant.delay:
            v, omega = float(state[3]), float(state[4])       # the last command runs on
        else:
            v, omega = self.commands.popleft()
        robot = self.config.robot
        if plant.limits:
            v = min(max(v, state[3] - robot.accel_limit * self.dt),
                    state[3] + robot.accel_limit * self.dt)
            omega = min(max(omega, state[4] - robot.alpha_limit * self.dt),
                        state[4] + robot.alpha_limit * self.dt)
        v *= 1.0 + plant.noise * float(self.rng.normal())
        omega *= 1.0 + plant.noise * float(self.rng.normal())
        return float(v), float(omega)


__all__ = ["Senses", "circle_ranges"]
