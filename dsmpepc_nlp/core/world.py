"""Static map (occupancy grid, signed distance, navigation function) and dynamic obstacles."""

from __future__ import annotations

import functools
import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from .errors import InputError, finite_vector, positive_number
from .geometry import body_to_world
from .mapfile import read_map, write_map

FAR = 1e3
"""Signed distance (m) reported everywhere on a grid without any occupied cell."""

_NAV_CACHE_SIZE = 16  # navigation functions kept per world; moving goals would grow it forever


# ---------------------------------------------------------------------------------------------
# validation helpers


def _points(name, points):
    arr = np.asarray(points, dtype=float)
    if arr.ndim < 1 or arr.shape[-1] != 2:
        raise InputError(f"{name} has shape {arr.shape}: expected (..., 2)")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} contains non-finite values: expected finite coordinates (m)")
    return arr


def _readonly(arr):
    arr.setflags(write=False)
    return arr


def _interpolate(table, resolution, origin, points):
    """Bilinear interpolation of ``table`` (ny, nx) between cell centres at ``points`` (..., 2).

    Points outside the cell-centre box are clamped to it. Returns the interpolated value at the
    clamped point and the distance (m) from each point to its clamped point, both shape (...).
    """
    ny, nx = table.shape
    u = (points[..., 0] - origin[0]) / resolution - 0.5
    v = (points[..., 1] - origin[1]) / resolution - 0.5
    uc = np.clip(u, 0.0, nx - 1)
    vc = np.clip(v, 0.0, ny - 1)
    outside = resolution * np.hypot(u - uc, v - vc)
    ix0 = np.minimum(np.floor(uc).astype(np.intp), max(nx - 2, 0))
    iy0 = np.minimum(np.floor(vc).astype(np.intp), max(ny - 2, 0))
    ix1 = np.minimum(ix0 + 1, nx - 1)
    iy1 = np.minimum(iy0 + 1, ny - 1)
    fx = uc - ix0
    fy = vc - iy0
    bottom = (1.0 - fx) * table[iy0, ix0] + fx * table[iy0, ix1]
    top = (1.0 - fx) * table[iy1, ix0] + fx * table[iy1, ix1]
    return (1.0 - fy) * bottom + fy * top, outside


# ---------------------------------------------------------------------------------------------
# occupancy grid


class OccupancyGrid:
    """Static occupancy grid. Immutable after construction.

    Parameters
    ----------
    occupied : array_like of bool or {0, 1}, shape (ny, nx)
        ``occupied[iy, ix]``; ``iy`` grows with world y and ``ix`` with world x. ny, nx >= 1.
    resolution : float
        Cell side (m), finite and > 0.
    origin : array_like, shape (2,)
        World (x, y) (m) of the lower-left corner of cell [0, 0]. Cell [iy, ix] has its centre at
        ``origin + (ix + 0.5, iy + 0.5) * resolution``.

    Notes
    -----
    Everything outside the grid counts as free space.
    """

    def __init__(self, occupied, resolution, origin=(0.0, 0.0)):
        arr = np.asarray(occupied)
        if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
            raise InputError(f"occupied has shape {arr.shape}: expected (ny, nx) with ny, nx >= 1")
        if arr.dtype != bool and (
            not np.issubdtype(arr.dtype, np.number) or not np.all((arr == 0) | (arr == 1))
        ):
            raise InputError(
                f"occupied has dtype {arr.dtype} and values other than 0/1: expected bool or 0/1"
            )
        self._occupied = _readonly(np.array(arr, dtype=bool))
        self._resolution = positive_number("resolution", resolution)
        self._origin = _readonly(finite_vector("origin", origin, 2))

    @classmethod
    def from_array(cls, occupied, resolution, origin=(0.0, 0.0)) -> OccupancyGrid:
        """Same as the constructor; see :class:`OccupancyGrid`."""
        return cls(occupied, resolution, origin)

    @property
    def occupied(self) -> np.ndarray:
        """Read-only bool array (ny, nx)."""
        return self._occupied

    @property
    def resolution(self) -> float:
        """Cell side (m)."""
        return self._resolution

    @property
    def origin(self) -> np.ndarray:
        """Read-only (2,) world position (m) of the lower-left corner of cell [0, 0]."""
        return self._origin

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx)."""
        return self._occupied.shape

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the grid's outer cell edges (m)."""
        ny, nx = self.shape
        x0, y0 = (float(c) for c in self._origin)
        return (x0, y0, x0 + nx * self._resolution, y0 + ny * self._resolution)

    def __repr__(self):
        return (
            f"OccupancyGrid(shape={self.shape}, resolution={self._resolution}, "
            f"origin={self._origin.tolist()}, occupied_cells={int(self._occupied.sum())})"
        )

    # -- signed distance -----------------------------------------------------------------------

    @functools.cached_property
    def signed_distance(self) -> np.ndarray:
        """Signed distance (m) at each cell centre, read-only (ny, nx).

        Positive in free space: the distance to the nearest occupied cell's boundary (a free cell
        next to an occupied one has ``0.5 * resolution``). Negative inside obstacles: minus the
        distance to the nearest free cell's boundary; cells outside the grid are free. ``FAR``
        everywhere when no cell is occupied.
        """
        occ = self._occupied
        if not occ.any():
            return _readonly(np.full(occ.shape, FAR))
        # One ring of free cells stands for the free world outside the grid.
        padded = np.pad(occ, 1, constant_values=False)
        to_occupied = ndimage.distance_transform_edt(~padded)[1:-1, 1:-1]
        to_free = ndimage.distance_transform_edt(padded)[1:-1, 1:-1]
        cells = np.where(occ, -(to_free - 0.5), to_occupied - 0.5)
        return _readonly(cells * self._resolution)

    def distance(self, points) -> np.ndarray:
        """Signed distance (m) to static structure at world points.

        Parameters
        ----------
        points : array_like, shape (..., 2)
            World positions (m).

        Returns
        -------
        ndarray, shape (...)
            Bilinear interpolation of :attr:`signed_distance` between cell centres. Outside the
            cell-centre box: the value at the clamped point plus the distance to it.

        Notes
        -----
        Beyond the map this is exact along the edge normal but overstates clearance obliquely
        (by up to 41 %, so it is only sqrt(2)-Lipschitz there); inside it is 1-Lipschitz up to
        half a cell. Keep the map large enough around where the robot drives.
        """
        pts = _points("points", points)
        inner, outside = _interpolate(self.signed_distance, self._resolution, self._origin, pts)
        return inner + outside

    def ray_distance(self, origins, headings, clearance, max_range) -> np.ndarray:
        """Free travel (m) along rays until the distance to static structure drops to ``clearance``.

        Sphere tracing: ``s += max(distance(p) - clearance, 0.25 * resolution)``, reporting ``s``
        at the first sample with ``distance <= clearance`` (so the answer may overshoot by up to
        a quarter cell on oblique approaches; it is exact head-on against a straight wall).

        Parameters
        ----------
        origins : array_like, shape (..., 2)
            Ray starts (m).
        headings : array_like, shape (...)
            Ray directions (rad).
        clearance : float or array_like broadcastable to (...)
            Distance (m) at which a ray counts as hitting, e.g. a footprint circle's radius.
        max_range : float
            Longest ray (m), finite and >= 0.

        Returns
        -------
        ndarray, shape (...)
            Hit distance (m); 0 when the origin is already within ``clearance``; ``inf`` when
            nothing is hit within ``max_range``.
        """
        orig = _points("origins", origins)
        head = np.asarray(headings, dtype=float)
        clear = np.asarray(clearance, dtype=float)
        max_range = positive_number("max_range", max_range, allow_zero=True)
        if not np.all(np.isfinite(head)):
            raise InputError("headings contains non-finite values: expected finite angles (rad)")
        if not np.all(np.isfinite(clear)):
            raise InputError("clearance contains non-finite values: expected finite distances (m)")
        try:
            shape = np.broadcast_shapes(orig.shape[:-1], head.shape, clear.shape)
        except ValueError:
            raise InputError(
                f"origins {orig.shape}, headings {head.shape} and clearance {clear.shape}: "
                "expected broadcastable shapes (..., 2), (...), (...)"
            ) from None
        start = np.broadcast_to(orig, shape + (2,)).reshape(-1, 2)
        direction = np.stack([np.cos(head), np.sin(head)], axis=-1)
        direction = np.broadcast_to(direction, shape + (2,)).reshape(-1, 2)
        clear = np.broadcast_to(clear, shape).reshape(-1)

        step_floor = 0.25 * self._resolution
        result = np.full(start.shape[0], np.inf)
        travel = np.zeros(start.shape[0])
        active = np.arange(start.shape[0])
        for _ in range(math.ceil(max_range / step_floor) + 1):
            if active.size == 0:
                break
            s = travel[active]
            d = self.distance(start[active] + s[:, None] * direction[active])
            hit = d <= clear[active] + 1e-9
            result[active[hit]] = s[hit]
            # A ray that was already checked at max_range is done; others stop at max_range once.
            step = np.maximum(d - clear[active], step_floor)
            alive = ~hit & (s < max_range)
            travel[active] = np.minimum(s + step, max_range)
            active = active[alive]
        return result.reshape(shape)

    # -- ROS map_server I/O --------------------------------------------------------------------

    @classmethod
    def from_yaml(cls, path) -> OccupancyGrid:
        """Load a ROS ``map_server`` map (YAML + PGM); see :func:`~dsmpepc_nlp.mapfile.read_map`.

        Raises
        ------
        InputError
            Naming the file and the field for unreadable YAML, missing or invalid fields, a
            missing image, or a truncated or non-PGM image.
        """
        return cls(*read_map(path))

    def to_yaml(self, path, image_name=None) -> None:
        """Write a ROS ``map_server`` YAML file and a binary PGM beside it, atomically.

        See :func:`~dsmpepc_nlp.mapfile.write_map`; ``image_name`` defaults to the YAML's stem
        + ".pgm".
        """
        write_map(path, self._occupied, self._resolution, self._origin, image_name)


# ---------------------------------------------------------------------------------------------
# navigation function


class NavigationFunction:
    """Shortest free-space path length to a goal, interpolated.

    Built once per (grid, goal, inflation).

    Parameters
    ----------
    goal : array_like, shape (2,)
        Goal position (m).
    grid : OccupancyGrid, optional
        Static map. Without one the navigation function is the Euclidean distance to the goal.
    inflation_radius : float
        Obstacles grow by this much (m), e.g. the robot's radius; >= 0.
    margin : float
        The working grid is the map extended to hold the goal plus this much (m) around it; >= 0.

    Attributes
    ----------
    goal : ndarray, shape (2,)
    values : ndarray, shape (ny, nx), or None
        Path length (m) at working-grid cell centres; None without a grid.
    working_grid : OccupancyGrid or None
        The extended (not inflated) grid ``values`` lives on.

    Notes
    -----
    8-connected Dijkstra over cells whose signed distance exceeds ``inflation_radius``, with edges
    ``resolution`` and ``resolution * sqrt(2)`` and no diagonal past a blocked cell. The seeds are
    the 2x2 cells whose centres surround the goal if all are free, else the goal's cell, else
    (goal cell blocked) the nearest free cells; each is valued at its Euclidean distance to the
    goal, so ``value(goal)`` is at most ``resolution / sqrt(2)``. Unreached cells (inflated or
    enclosed) take the value of the nearest reached cell plus the Euclidean distance to it, so the
    function is finite everywhere and grows into obstacles. With no free cell at all it falls back
    to Euclidean distance.
    """

    def __init__(self, goal, grid=None, inflation_radius=0.0, margin=2.0):
        self.goal = _readonly(finite_vector("goal", goal, 2))
        self.inflation_radius = positive_number("inflation_radius", inflation_radius,
                                                allow_zero=True)
        margin = positive_number("margin", margin, allow_zero=True)
        if grid is not None and not isinstance(grid, OccupancyGrid):
            raise TypeError(f"grid={grid!r}: expected an OccupancyGrid or None")
        self.values = None
        self.working_grid = None
        if grid is not None:
            self.working_grid = self._extend(grid, margin)
            self.values = _readonly(self._solve())

    def _extend(self, grid, margin):
        res = grid.resolution
        xmin, ymin, xmax, ymax = grid.bounds
        gx, gy = self.goal

        def cells(gap):
            return max(0, math.ceil(gap / res - 1e-9))

        left, right = cells(xmin - (gx - margin)), cells(gx + margin - xmax)
        bottom, top = cells(ymin - (gy - margin)), cells(gy + margin - ymax)
        occ = np.pad(grid.occupied, ((bottom, top), (left, right)), constant_values=False)
        return OccupancyGrid(occ, res, grid.origin - res * np.array([left, bottom]))

    def _solve(self):
        work = self.working_grid
        res = work.resolution
        ny, nx = work.shape
        free = work.signed_distance > self.inflation_radius
        iy, ix = np.mgrid[0:ny, 0:nx]
        centres = work.origin + res * (np.stack([ix, iy], axis=-1) + 0.5)
        to_goal = np.hypot(*(centres - self.goal).transpose(2, 0, 1))
        if not free.any():
            return to_goal

        index = np.arange(ny * nx).reshape(ny, nx)
        rows, cols, weights = [], [], []

        def connect(a, b, ok, length):
            rows.append(a[ok])
            cols.append(b[ok])
            weights.append(np.full(int(ok.sum()), length))

        # right, up, up-right, up-left; both directions added below
        connect(index[:, :-1], index[:, 1:], free[:, :-1] & free[:, 1:], res)
        connect(index[:-1, :], index[1:, :], free[:-1, :] & free[1:, :], res)
        square = free[:-1, :-1] & free[:-1, 1:] & free[1:, :-1] & free[1:, 1:]
        diag = res * math.sqrt(2.0)
        connect(index[:-1, :-1], index[1:, 1:], square, diag)
        connect(index[:-1, 1:], index[1:, :-1], square, diag)

        # A virtual source (node ny*nx) feeds the seeds with their Euclidean distance to the goal;
        # edges are offset by res so no weight is zero (a zero would read as "no edge").
        # Seed the 2x2 cells whose centres surround the goal when all are free (the interpolation
        # stencil, so NF is near-Euclidean around the goal), else the goal cell alone.
        u, v = (self.goal - work.origin) / res
        gx = int(np.clip(math.floor(u), 0, nx - 1))
        gy = int(np.clip(math.floor(v), 0, ny - 1))
        sx = int(np.clip(math.floor(u - 0.5), 0, max(nx - 2, 0)))
        sy = int(np.clip(math.floor(v - 0.5), 0, max(ny - 2, 0)))
        stencil = np.s_[sy : sy + 2, sx : sx + 2]
        if free[stencil].all():
            seeds = index[stencil].ravel()
        elif free[gy, gx]:
            seeds = np.array([index[gy, gx]])
        else:
            candidates = np.where(free, to_goal, np.inf).ravel()
            seeds = np.flatnonzero(candidates <= candidates.min() + 1e-9 * res)
        source = ny * nx
        a = np.concatenate(rows)
        b = np.concatenate(cols)
        w = np.concatenate(weights)
        a_all = np.concatenate([a, b, np.full(seeds.size, source)])
        b_all = np.concatenate([b, a, seeds])
        w_all = np.concatenate([w, w, to_goal.ravel()[seeds] + res])
        graph = coo_matrix((w_all, (a_all, b_all)), shape=(source + 1, source + 1)).tocsr()
        dist = dijkstra(graph, directed=True, indices=source)[:-1].reshape(ny, nx) - res

        reached = np.isfinite(dist)
        if reached.all():
            return dist
        gap, (near_y, near_x) = ndimage.distance_transform_edt(~reached, return_indices=True)
        return np.where(reached, dist, dist[near_y, near_x] + gap * res)

    def value(self, points) -> np.ndarray:
        """Navigation function (m) at world points.

        Parameters
        ----------
        points : array_like, shape (..., 2)
            World positions (m).

        Returns
        -------
        ndarray, shape (...)
            Bilinear interpolation of :attr:`values` (outside the working grid: the clamped value
            plus the distance to the clamped point), or ``|p - goal|`` without a grid.
        """
        pts = _points("points", points)
        if self.values is None:
            return np.hypot(pts[..., 0] - self.goal[0], pts[..., 1] - self.goal[1])
        work = self.working_grid
        inner, outside = _interpolate(self.values, work.resolution, work.origin, pts)
        return inner + outside

    def gradient(self, points) -> np.ndarray:
        """Gradient (dimensionless, m/m) of :meth:`value` at world points.

        Parameters
        ----------
        points : array_like, shape (..., 2)
            World positions (m).

        Returns
        -------
        ndarray, shape (..., 2)
            Central differences of :meth:`value` with step ``resolution``; without a grid the exact
            ``(p - goal) / |p - goal|`` (0 at the goal).
        """
        pts = _points("points", points)
        if self.values is None:
            delta = pts - self.goal
            norm = np.linalg.norm(delta, axis=-1, keepdims=True)
            return np.divide(delta, norm, out=np.zeros_like(delta), where=norm > 0)
        h = self.working_grid.resolution
        dx = np.array([h, 0.0])
        dy = np.array([0.0, h])
        gx = (self.value(pts + dx) - self.value(pts - dx)) / (2 * h)
        gy = (self.value(pts + dy) - self.value(pts - dy)) / (2 * h)
        return np.stack([gx, gy], axis=-1)


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


class World:
    """What a plan sees: an optional static grid and dynamic obstacles at the current time.

    Parameters
    ----------
    grid : OccupancyGrid, optional
    obstacles : iterable of DynamicObstacle
    """

    def __init__(self, grid=None, obstacles=()):
        if grid is not None and not isinstance(grid, OccupancyGrid):
            raise TypeError(f"grid={grid!r}: expected an OccupancyGrid or None")
        obstacles = tuple(obstacles)
        for i, obstacle in enumerate(obstacles):
            if not isinstance(obstacle, DynamicObstacle):
                raise TypeError(f"obstacles[{i}]={obstacle!r}: expected a DynamicObstacle")
        self.grid = grid
        self.obstacles = obstacles
        self._navigation_cache = OrderedDict()
        self._stacked = None

    def with_obstacles(self, obstacles) -> World:
        """The same grid and navigation-function cache with new dynamic obstacles."""
        other = World(self.grid, obstacles)
        other._navigation_cache = self._navigation_cache
        return other

    def navigation(self, goal, inflation_radius) -> NavigationFunction:
        """Navigation function to ``goal`` (2,) (m), obstacles inflated by ``inflation_radius`` (m).

        Cached per (goal rounded to 1e-9 m, inflation radius), shared with :meth:`with_obstacles`
        copies; the least recently used of more than 16 entries is dropped.
        """
        goal = finite_vector("goal", goal, 2)
        inflation_radius = positive_number("inflation_radius", inflation_radius, allow_zero=True)
        key = (*np.round(goal, 9).tolist(), inflation_radius)
        cache = self._navigation_cache
        if key in cache:
            cache.move_to_end(key)
            return cache[key]
        nav = NavigationFunction(goal, self.grid, inflation_radius)
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
