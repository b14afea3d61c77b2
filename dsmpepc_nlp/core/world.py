"""What a plan sees: the static map and the dynamic obstacles (pedestrians, other robots).

The occupancy grid lives in :mod:`.grid` and the navigation function in :mod:`.navigation`;
both are re-exported here, so ``from dsmpepc_nlp.core.world import OccupancyGrid,
NavigationFunction, World, DynamicObstacle`` keeps working.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from .errors import InputError, finite_vector, positive_number
from .geometry import body_to_world
from .grid import FAR, OccupancyGrid, _interpolate, _points, _readonly
from .navigation import NavigationFunction, navigation_window

_NAV_CACHE_SIZE = 16  # navigation functions kept per world; moving goals would grow it forever
_NAV_MARGIN = 2.0  # free margin (m) of the navigation window around the map

__all__ = ["FAR", "DynamicObstacle", "NavigationFunction", "OccupancyGrid", "World",
           "_interpolate"]


# ---------------------------------------------------------------------------------------------
# dynamic obstacles


_KINDS = ("pedestrian", "robot")


@dataclass(frozen=True, eq=False)
class DynamicObstacle:
    """One moving object: a pedestrian (one circle) or another robot (its footprint circles).

    It moves at constant velocity. Equality and hashing are by identity (the fields are arrays).

    Attributes
    ----------
    centers : ndarray, shape (m, 2)
        World positions (m) of the object's circles at time 0, m >= 1.
    radii : ndarray, shape (m,)
        Circle radii (m), > 0.
    velocity : ndarray, shape (2,)
        Velocity (m/s), world frame.
    kind : str
        "pedestrian" or "robot".
    """

    centers: np.ndarray
    radii: np.ndarray
    velocity: np.ndarray
    kind: str = "pedestrian"

    def __post_init__(self):
        centers = np.array(self.centers, dtype=float)
        if centers.ndim != 2 or centers.shape[0] < 1 or centers.shape[1] != 2:
            raise InputError(f"centers has shape {centers.shape}: expected (m, 2) with m >= 1")
        if not np.all(np.isfinite(centers)):
            raise InputError(f"centers={centers.tolist()}: expected finite positions (m)")
        radii = np.array(self.radii, dtype=float)
        if radii.shape != (centers.shape[0],):
            raise InputError(f"radii has shape {radii.shape}: expected ({centers.shape[0]},)")
        if not np.all(np.isfinite(radii) & (radii > 0)):
            raise InputError(f"radii={radii.tolist()}: expected finite radii > 0 (m)")
        velocity = finite_vector("velocity", self.velocity, 2)
        if self.kind not in _KINDS:
            raise InputError(f"kind={self.kind!r}: expected one of {_KINDS}")
        object.__setattr__(self, "centers", _readonly(centers))
        object.__setattr__(self, "radii", _readonly(radii))
        object.__setattr__(self, "velocity", _readonly(velocity))

    @classmethod
    def pedestrian(cls, position, velocity, radius=0.3) -> DynamicObstacle:
        """A pedestrian: one circle of ``radius`` (m) at ``position`` (2,) (m).

        ``velocity`` (2,) is in m/s, world frame.
        """
        return cls(np.reshape(np.asarray(position, dtype=float), (1, -1)), [radius], velocity)

    @classmethod
    def robot(cls, pose, velocity, footprint) -> DynamicObstacle:
        """Another robot at ``pose`` (x, y, phi) (m, m, rad), ``velocity`` (2,) (m/s, world).

        ``footprint`` is a sequence of body-frame circles ``(cx, cy, radius)`` (m), shape (m, 3).
        """
        x, y, phi = finite_vector("pose", pose, 3)
        circles = np.array(footprint, dtype=float)
        if circles.ndim != 2 or circles.shape[0] < 1 or circles.shape[1] != 3:
            raise InputError(
                f"footprint has shape {circles.shape}: expected (m, 3) rows (cx, cy, radius)"
            )
        world = np.stack(body_to_world((x, y, phi), circles[:, 0], circles[:, 1]), axis=1)
        return cls(world, circles[:, 2], velocity, kind="robot")

    def predict(self, times) -> np.ndarray:
        """Circle centres (m) at ``times`` (T,) (s): shape (T, m, 2), constant velocity."""
        t = np.asarray(times, dtype=float)
        return self.centers + t[..., None, None] * self.velocity


# ---------------------------------------------------------------------------------------------
# world


def _short(value, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({type(value).__name__})"


class World:
    """What a plan sees: an optional static grid and dynamic obstacles at the current time.

    Parameters
    ----------
    grid : OccupancyGrid, optional
    obstacles : iterable of DynamicObstacle
    """

    def __init__(self, grid=None, obstacles=()):
        if grid is not None and not isinstance(grid, OccupancyGrid):
            shown = (f"a {type(grid).__name__} of shape {np.shape(grid)}"
                     if isinstance(grid, np.ndarray) else _short(grid))
            raise InputError(f"World(grid=...): got {shown}; expected an OccupancyGrid or "
                             "None (OccupancyGrid.from_array(occupied, resolution) makes one "
                             "from an array)")
        obstacles = tuple(obstacles)
        for i, obstacle in enumerate(obstacles):
            if not isinstance(obstacle, DynamicObstacle):
                raise InputError(f"World(obstacles=...)[{i}] = {_short(obstacle)}: expected a "
                                 "DynamicObstacle")
        self.grid = grid
        self.obstacles = obstacles
        self._navigation_cache = OrderedDict()
        self._stacked = None

    def with_obstacles(self, obstacles) -> World:
        """The same grid and navigation-function cache with new dynamic obstacles."""
        other = World(self.grid, obstacles)
        other._navigation_cache = self._navigation_cache
        return other

    def navigation(self, goal, inflation_radius, near=None, reach=0.0) -> NavigationFunction:
        """Navigation function to ``goal`` (2,) (m), obstacles inflated by ``inflation_radius`` (m).

        ``near`` (2,) (m) and ``reach`` (m): where the robot is and how far its trajectories go;
        with a goal outside the map they choose the window the values live on (see
        :func:`~dsmpepc_nlp.core.navigation.navigation_window`). Cached per (goal rounded to
        1e-9 m, inflation radius, window), shared with :meth:`with_obstacles` copies; the least
        recently used of more than 16 entries is dropped.
        """
        goal = finite_vector("goal", goal, 2)
        inflation_radius = positive_number("inflation_radius", inflation_radius, allow_zero=True)
        reach = positive_number("reach", reach, allow_zero=True)
        if near is not None:
            near = finite_vector("near", near, 2)
        window = None
        if self.grid is not None:
            window = navigation_window(self.grid, goal, _NAV_MARGIN, near, reach)
        key = (*np.round(goal, 9).tolist(), inflation_radius, window)
        cache = self._navigation_cache
        if key in cache:
            cache.move_to_end(key)
            return cache[key]
        nav = NavigationFunction(goal, self.grid, inflation_radius, _NAV_MARGIN, near, reach)
        cache[key] = nav
        while len(cache) > _NAV_CACHE_SIZE:
            cache.popitem(last=False)
        return nav

    def static_distance(self, points) -> np.ndarray:
        """Signed distance (m) to the grid at ``points`` (..., 2) -> (...); FAR without a grid."""
        if self.grid is not None:
            return self.grid.distance(points)
        return np.full(_points("points", points).shape[:-1], FAR)

    def static_ray_distance(self, origins, headings, clearance, max_range) -> np.ndarray:
        """:meth:`OccupancyGrid.ray_distance`; ``inf`` everywhere (shape (...)) without a grid."""
        if self.grid is not None:
            return self.grid.ray_distance(origins, headings, clearance, max_range)
        shape = np.broadcast_shapes(
            _points("origins", origins).shape[:-1], np.shape(headings), np.shape(clearance)
        )
        return np.full(shape, np.inf)

    def stacked_obstacles(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """All dynamic-obstacle circles, flattened (K circles; K may be 0). Read-only, cached.

        Returns
        -------
        centers : ndarray, shape (K, 2)
            Positions (m) at the current time.
        radii : ndarray, shape (K,)
            Radii (m).
        velocities : ndarray, shape (K, 2)
            Velocity (m/s) of each circle's object.
        owner : ndarray of int, shape (K,)
            Index into :attr:`obstacles` of each circle's object.
        """
        if self._stacked is None:
            obs = self.obstacles
            counts = [len(o.radii) for o in obs]
            centers = np.concatenate([o.centers for o in obs]) if obs else np.zeros((0, 2))
            radii = np.concatenate([o.radii for o in obs]) if obs else np.zeros(0)
            velocities = np.repeat(np.array([o.velocity for o in obs]).reshape(-1, 2), counts, 0)
            owner = np.repeat(np.arange(len(obs), dtype=np.intp), counts)
            self._stacked = tuple(_readonly(a) for a in (centers, radii, velocities, owner))
        return self._stacked


def warm_up_map_updates() -> bool:
    """Load (or compile) the kernels that update a grid's signed distance and navigation
    functions from a previous grid's (:meth:`OccupancyGrid.updated_from`) now, not in the
    first update (about a second, numba's import included, once per process); False where
    they are not compiled (``DSMPEPC_NO_COMPILE``, no numba)."""
    occ = np.zeros((8, 8), dtype=bool)
    occ[2, 5] = occ[5, 2] = True
    grid = OccupancyGrid.derived(occ, 0.1, (0.0, 0.0))
    _ = grid.signed_distance
    for shift in (1, 2):  # the second repairs the first's paths
        grid = OccupancyGrid.updated_from(grid, np.roll(occ, -shift, axis=1), (0.1 * shift, 0.0))
        _ = grid.signed_distance
        nav = NavigationFunction((0.45, 0.35), grid, 0.1)
    return "_paths" in nav.__dict__
