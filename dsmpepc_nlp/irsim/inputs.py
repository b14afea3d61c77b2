"""What the planner is given each cycle from an IR-SIM environment: the static map (exact, from
the world's shapes) and the moving objects (the truth), or what a lidar or a people detector
makes of them through the product's perception.

- :func:`oracle_grid`: the static obstacles rasterised exactly (:mod:`.raster`) over the world's
  extent; also the map the metrics measure clearance against.
- :class:`LidarInput`: IR-SIM's own 2D lidar scan of the robot into a
  :class:`~dsmpepc_nlp.perception.LocalMap`, no prior map. IR-SIM reports a beam without a hit
  at ``range_max`` and a return inside the blind zone at ``range_min``, both flagged invalid;
  they become ``inf`` (no return: clear the beam) and NaN (dropped). Returns on the moving
  objects the planner is given are dropped too, as in the product's simulator.
- :class:`TrackedInput`: the people's true positions with Gaussian noise, as detections into a
  :class:`~dsmpepc_nlp.perception.PeopleTracker`.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..core.errors import InputError
from ..core.world import DynamicObstacle
from ..perception import Detections, LaserScan, LocalMap, LocalMapConfig, PeopleTracker
from ..perception.scan import returns_off_objects
from ..sim.sensing import LidarSettings
from .raster import Lattice, image_boxes, rasterise
from .shapes import describe, static_part

OBJECT_MARGIN = 0.1
"""m: a lidar return within a given moving object's radius plus this is not marked into the
local map (the product simulator's ``LidarSettings.object_margin``)."""
LOCAL_MAP_RESOLUTION = 0.05
"""Cell side of the lidar's local map, m (Nav2's costmap default, as the product's lidar)."""
MAP_WINDOW = LidarSettings().window
"""Largest side of the local map, m: the product simulator's lidar window (20 m), so a long
lidar (the UST-10's 30 m) rebuilds the same map every cycle in both simulators."""
DETECTION_NOISE = 0.1
"""Standard deviation of a detected position per axis, m (the product's detector default)."""


def world_map(env):
    """IR-SIM's map of the world at its own grid resolution (``Map``: width, height,
    world_offset, grid, grid_resolution); never downsampled, its warnings silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # A resolution finer than any grid makes IR-SIM hand its grid back as it is.
        return env.get_map(resolution=1e-9)


def oracle_grid(env, resolution: float):
    """The static obstacles of ``env`` as an OccupancyGrid of ``resolution`` (m), exactly
    rasterised, on a lattice anchored at the world's offset, covering the world's extent and
    every static shape.

    Static: IR-SIM's ``static`` obstacles (no kinematics, or flagged) and its map grid;
    ``unobstructed`` ones (IR-SIM lets everything through them) are left out.
    """
    layout = world_map(env)
    x0, y0 = layout.world_offset
    bounds = [x0, y0, x0 + float(layout.width), y0 + float(layout.height)]
    discs, geometries, boxes = [], [], None
    for obj in env.obstacle_list:
        if not obj.static or obj.unobstructed:
            continue
        kind, part = static_part(obj)
        if kind == "disc":
            (cx, cy), r = part
            extent = (cx - r, cy - r, cx + r, cy + r)
            discs.append(part)
        elif kind == "geometry":
            extent = tuple(float(b) for b in part.bounds)
            geometries.append((describe(obj), part))
        else:
            continue
        bounds = [min(bounds[0], extent[0]), min(bounds[1], extent[1]),
                  max(bounds[2], extent[2]), max(bounds[3], extent[3])]
    if layout.grid is not None:
        boxes = image_boxes(layout.grid, layout.grid_resolution, layout.world_offset)
    lattice = Lattice.covering(bounds, (x0, y0), resolution)
    return rasterise(lattice, discs=discs, geometries=geometries, boxes=boxes)


def scan_ranges(scan: dict) -> np.ndarray:
    """IR-SIM's ``ranges`` with its invalid beams made ROS's: a miss (read at ``range_max``)
    ``inf``, a blind-zone return (read at ``range_min``) NaN."""
    ranges = np.array(scan["ranges"], dtype=float)
    valid = np.asarray(scan["valid"], dtype=bool)
    miss = ~valid & (ranges >= float(scan["range_max"]) - 1e-9)
    return np.where(valid, ranges, np.where(miss, np.inf, np.nan))


class LidarInput:
    """The robot's IR-SIM lidar into a rolling local map (module docstring)."""

    def __init__(self, robot):
        lidar = robot.lidar
        if lidar is None:
            raise InputError(f"{describe(robot)} has no lidar: --sensing lidar reads IR-SIM's "
                             "own scan (add sensors: [{name: lidar2d, ...}] to the robot)")
        self.robot, self.lidar = robot, lidar
        reach = float(lidar.range_max)
        size = min(max(2.0 * reach + 2.0, 4.0), MAP_WINDOW)
        self.local_map = LocalMap(LocalMapConfig(size=size, resolution=LOCAL_MAP_RESOLUTION,
                                                 obstacle_max_range=reach,
                                                 raytrace_max_range=reach))
        self.local_map.prepare()

    def grid(self, t: float, planned):
        """The local map after the scan IR-SIM took at its last step, at time ``t`` (s);
        returns on the ``planned`` moving obstacles are not marked."""
        scan = self.robot.get_lidar_scan()
        pose = np.asarray(self.lidar.lidar_origin, dtype=float).reshape(-1)[:3]
        angles = np.asarray(self.lidar.angle_list, dtype=float)
        ranges = returns_off_objects(scan_ranges(scan), pose, angles, planned, OBJECT_MARGIN)
        range_min = max(float(scan["range_min"]), 0.0)
        self.local_map.update(LaserScan.from_angles(ranges, angles, range_min,
                                                    float(scan["range_max"]), pose=pose,
                                                    stamp=float(t)))
        return self.local_map.grid()


class TrackedInput:
    """The pedestrians' true positions with Gaussian noise into a people tracker."""

    def __init__(self, seed=None, noise: float = DETECTION_NOISE):
        self.tracker = PeopleTracker()
        self.rng = np.random.default_rng(seed)
        self.noise = float(noise)

    def people(self, t: float, truth) -> list[DynamicObstacle]:
        """Tracked pedestrians at ``t`` (s) from the ``truth`` obstacles; other robots (kind
        ``robot``, whose poses robots share) pass through as they are."""
        walkers = [o for o in truth if o.kind == "pedestrian"]
        others = [o for o in truth if o.kind != "pedestrian"]
        positions = np.array([o.centers[0] for o in walkers]).reshape(-1, 2)
        radii = np.array([o.radii[0] for o in walkers], dtype=float)
        noisy = positions + self.rng.normal(0.0, self.noise, positions.shape)
        self.tracker.update(Detections(noisy, float(t), radii=radii))
        return self.tracker.obstacles(now=float(t)) + others


def measured_velocity(previous, now: tuple, fallback) -> np.ndarray:
    """World velocity (2,) from the position change since ``previous`` ``(t, xy)``, or
    ``fallback`` (IR-SIM's own velocity) when there is no earlier position."""
    t, xy = now
    if previous is None or not t > previous[0] + 1e-12:
        return np.asarray(fallback, dtype=float).reshape(-1)[:2]
    velocity = (xy - previous[1]) / (t - previous[0])
    return velocity if np.all(np.isfinite(velocity)) else np.zeros(2)

