"""The navigation function: shortest free-space path length to a goal, on a bounded window.

The values live on a window of the map's cell lattice (a table at cell centres + resolution +
origin, read by :func:`~dsmpepc_nlp.core.grid._interpolate`, like the signed distance). The
window never grows to the goal: it is the map plus a margin, or, when the goal lies outside that
and the robot's reach does too, a box of bounded size around the robot (joined with the map when
the union stays small). A goal outside the window is reached through the window's border: the
Dijkstra is seeded from the border cells on the sides facing the goal, each valued at its
straight-line distance to the goal, the way a local planner follows a global plan. So a goal
10 km away costs what a goal inside the map costs.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from .errors import finite_vector, positive_number
from .grid import OccupancyGrid, _interpolate, _points, _readonly

TILE_DIVISOR = 4
"""A robot box is ``near +- reach`` snapped outward to a lattice of ``reach / TILE_DIVISOR``: it
changes (and the values are recomputed) once per quarter of the reach travelled."""

UNION_FACTOR = 3
"""A robot box is joined with the map window when the union has at most this many robot boxes'
worth of cells beyond the map window's; otherwise the robot box alone is the window."""


def navigation_window(grid, goal, margin, near=None, reach=0.0):
    """Cell-index box ``(x0, y0, x1, y1)`` (half-open, in the map's cell lattice) of the window.

    Parameters
    ----------
    grid : OccupancyGrid
    goal : ndarray, shape (2,)
        Goal (m).
    margin : float
        Free margin (m) around the map.
    near : array_like, shape (2,), optional
        Where the robot is (m). Only used when the goal is outside the map window.
    reach : float
        How far (m) trajectories go from ``near``; the window then holds ``near +- reach``.

    Returns
    -------
    tuple of int
        The map occupies ``[0, nx) x [0, ny)``; a window may extend beyond it on any side.
    """
    res = grid.resolution
    ny, nx = grid.shape
    m = math.ceil(margin / res - 1e-9)
    base = (-m, -m, nx + m, ny + m)
    u, v = (np.asarray(goal, dtype=float) - grid.origin) / res
    if near is None or _contains(base, u, v):
        return base
    near_u, near_v = (np.asarray(near, dtype=float) - grid.origin) / res
    r = math.ceil(reach / res) + 1
    # Snapped to a lattice of `tile` cells, so the window changes once per tile of travel.
    tile = max(1, r // TILE_DIVISOR)
    x0 = (math.floor(near_u) - r) // tile * tile
    y0 = (math.floor(near_v) - r) // tile * tile
    box = (x0, y0, x0 + 2 * r + tile, y0 + 2 * r + tile)
    if base[0] <= box[0] and base[1] <= box[1] and box[2] <= base[2] and box[3] <= base[3]:
        return base
    union = (min(base[0], box[0]), min(base[1], box[1]), max(base[2], box[2]),
             max(base[3], box[3]))
    if _cells(union) <= _cells(base) + UNION_FACTOR * _cells(box):
        return union
    return box


def _contains(box, u, v):
    return box[0] <= u < box[2] and box[1] <= v < box[3]


def _cells(box):
    return (box[2] - box[0]) * (box[3] - box[1])


def _crop(grid, window):
    """The map's occupancy on ``window`` (free outside the map) as an OccupancyGrid."""
    x0, y0, x1, y1 = window
    ny, nx = grid.shape
    occ = np.zeros((y1 - y0, x1 - x0), dtype=bool)
    ax0, ay0, ax1, ay1 = max(x0, 0), max(y0, 0), min(x1, nx), min(y1, ny)
    if ax0 < ax1 and ay0 < ay1:
        occ[ay0 - y0:ay1 - y0, ax0 - x0:ax1 - x0] = grid.occupied[ay0:ay1, ax0:ax1]
    return OccupancyGrid.derived(occ, grid.resolution,
                                 grid.origin + grid.resolution * np.array([x0, y0]))


WINDOW_CACHE_SIZE = 8
"""Windows whose free cells and cell graph are kept per map (by window and inflation radius),
least recently used dropped."""


def _kept_window(grid, window, inflation_radius):
    """``(free, cells, fills)`` of ``window``: the free-cell mask (:func:`_free_cells`, (ny, nx)
    bool), the CSR parts of the graph between its free cells (:func:`_cell_graph`), both
    read-only, and a dict that :func:`_fill_unreached` keeps its last fill in.

    None of them depends on the goal, so all are kept on the map per (window, radius): a
    followed goal, which moves every cycle, rebuilds the navigation function on the same
    window, and the mask's signed distance and the graph were most of that rebuild.
    """
    kept = grid.__dict__.setdefault("_window_cells", OrderedDict())
    key = (window, inflation_radius)
    if key in kept:
        kept.move_to_end(key)
        return kept[key]
    free = _readonly(_free_cells(grid, window, inflation_radius))
    kept[key] = free, _cell_graph(free, grid.resolution), {}
    while len(kept) > WINDOW_CACHE_SIZE:
        kept.popitem(last=False)
    return kept[key]


def _fill_unreached(dist, reached, res, fills=None):
    """``dist`` with each unreached cell given the value of the nearest reached cell plus the
    Euclidean distance to it. The nearest cells depend only on ``reached``, which a followed
    goal seldom changes (the blocked cells and any pocket cut off from the goal), so with
    ``fills`` (a window's dict, :func:`_kept_window`) the last distance transform is kept there
    and reused while ``reached`` is the same: the same values, without the transform."""
    last = None if fills is None else fills.get("last")
    if last is not None and np.array_equal(last[0], reached):
        _, gap, near_y, near_x = last
    else:
        from scipy import ndimage

        gap, (near_y, near_x) = ndimage.distance_transform_edt(~reached, return_indices=True)
        if fills is not None:
            fills["last"] = (_readonly(reached.copy()), *map(_readonly, (gap, near_y, near_x)))
    return np.where(reached, dist, dist[near_y, near_x] + gap * res)


def _free_cells(grid, window, inflation_radius):
    """Cells of ``window`` whose signed distance exceeds ``inflation_radius``, (ny, nx) bool.

    Only the map and the ring of cells within ``inflation_radius`` of it can be blocked, so the
    signed distance is computed there alone: a large window around a far robot costs no more.
    """
    k = math.ceil(inflation_radius / grid.resolution) + 1
    ny, nx = grid.shape
    x0, y0, x1, y1 = window
    near_map = (max(x0, -k), max(y0, -k), min(x1, nx + k), min(y1, ny + k))
    free = np.ones((y1 - y0, x1 - x0), dtype=bool)
    if near_map[0] < near_map[2] and near_map[1] < near_map[3]:
        part = _crop(grid, near_map).signed_distance > inflation_radius
        free[near_map[1] - y0:near_map[3] - y0, near_map[0] - x0:near_map[2] - x0] = part
    return free


_STEPS = ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))


def _cell_graph(free, res):
    """CSR parts ``(indptr, indices, data)`` of the 8-connected free cells' rows (``indptr``
    of length ny * nx + 1), read-only.

    Edges of ``res`` and ``res * sqrt(2)``; no diagonal past a blocked cell. Built row by row
    in CSR order directly (no COO sort), since it is the larger part of a window's cost.
    """
    ny, nx = free.shape
    n = ny * nx
    padded = np.pad(free, 1, constant_values=False)
    index = np.pad(np.arange(n).reshape(ny, nx), 1, constant_values=-1)
    masks, neighbours = [], []
    for dy, dx in _STEPS:
        ok = free & padded[1 + dy:1 + dy + ny, 1 + dx:1 + dx + nx]
        if dy and dx:
            ok &= padded[1 + dy:1 + dy + ny, 1:1 + nx] & padded[1:1 + ny, 1 + dx:1 + dx + nx]
        masks.append(ok)
        neighbours.append(index[1 + dy:1 + dy + ny, 1 + dx:1 + dx + nx])
    mask = np.stack(masks, -1).reshape(n, 8)
    neighbour = np.stack(neighbours, -1).reshape(n, 8)
    length = np.array([res * math.sqrt(2.0) if dy and dx else res for dy, dx in _STEPS])
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(mask.sum(axis=1), out=indptr[1:])
    return (_readonly(indptr), _readonly(neighbour[mask]),
            _readonly(np.broadcast_to(length, (n, 8))[mask]))


def _grid_graph(cells, seeds, seed_weights):
    """CSR graph of the free cells (``cells``, :func:`_cell_graph`) plus a source node (the
    last) feeding the seeds."""
    cell_indptr, cell_indices, cell_data = cells
    n = cell_indptr.size - 1
    indptr = np.empty(n + 2, dtype=np.int64)
    indptr[:n + 1] = cell_indptr
    indptr[-1] = indptr[-2] + seeds.size
    indices = np.concatenate([cell_indices, seeds])
    data = np.concatenate([cell_data, seed_weights])
    from scipy.sparse import csr_matrix  # imported on first use (see grid.py)

    return csr_matrix((data, indices, indptr), shape=(n + 1, n + 1))


# ---------------------------------------------------------------------------------------------
# navigation function


class NavigationFunction:
    """Shortest free-space path length to a goal, interpolated.

    Built once per (grid, goal, inflation, window). On a grid made by
    :meth:`~.grid.OccupancyGrid.updated_from`, built by :mod:`.navigation_update` (from the
    previous grid's function for the same goal and inflation where it has one): the same
    values up to the rounding of the path sums.

    Parameters
    ----------
    goal : array_like, shape (2,)
        Goal position (m).
    grid : OccupancyGrid, optional
        Static map. Without one the navigation function is the Euclidean distance to the goal.
    inflation_radius : float
        Obstacles grow by this much (m), e.g. the robot's radius; >= 0.
    margin : float
        Free margin (m) of the window around the map; >= 0.
    near, reach : optional
        The robot's position (m) and how far its trajectories go (m): see
        :func:`navigation_window`. Without ``near`` the window is the map plus ``margin``.

    Attributes
    ----------
    goal : ndarray, shape (2,)
    values : ndarray, shape (ny, nx), or None
        Path length (m) at working-grid cell centres; None without a grid.
    working_grid : OccupancyGrid or None
        The window (not inflated) ``values`` lives on.

    Notes
    -----
    8-connected Dijkstra over cells whose signed distance exceeds ``inflation_radius``, with edges
    ``resolution`` and ``resolution * sqrt(2)`` and no diagonal past a blocked cell. With the goal
    in the window the seeds are the 2x2 cells whose centres surround the goal if all are free,
    else the goal's cell, else (goal cell blocked) the nearest free cells; each is valued at its
    Euclidean distance to the goal, so ``value(goal)`` is at most ``resolution / sqrt(2)``. With
    the goal outside the window the seeds are the free border cells on the sides facing the goal
    (else the free cells nearest the goal), each valued at its straight-line distance to the goal.
    Unreached cells (inflated or enclosed) take the value of the nearest reached cell plus the
    Euclidean distance to it, so the function is finite everywhere and grows into obstacles. With
    no free cell at all it falls back to Euclidean distance.
    """

    def __init__(self, goal, grid=None, inflation_radius=0.0, margin=2.0, near=None, reach=0.0):
        self.goal = _readonly(finite_vector("goal", goal, 2))
        self.inflation_radius = positive_number("inflation_radius", inflation_radius,
                                                allow_zero=True)
        margin = positive_number("margin", margin, allow_zero=True)
        reach = positive_number("reach", reach, allow_zero=True)
        if near is not None:
            near = finite_vector("near", near, 2)
        if grid is not None and not isinstance(grid, OccupancyGrid):
            raise TypeError(f"grid={grid!r}: expected an OccupancyGrid or None")
        self.values = None
        self.working_grid = None
        if grid is not None:
            window = navigation_window(grid, self.goal, margin, near, reach)
            self.working_grid = _crop(grid, window)
            values = None
            if grid.is_update:  # a grid made from a previous one: start from its paths
                from .navigation_update import updated_values

                values = updated_values(self, grid, window)
            if values is None:
                values = self._solve(*_kept_window(grid, window, self.inflation_radius))
            self.values = _readonly(values)

    def _solve(self, free, cells, fills=None):
        work = self.working_grid
        res = work.resolution
        ny, nx = work.shape
        # The cell centres' offsets from the goal along each axis, broadcast (no grid of them).
        dx = work.origin[0] + res * (np.arange(nx) + 0.5) - self.goal[0]
        dy = work.origin[1] + res * (np.arange(ny) + 0.5) - self.goal[1]
        to_goal = np.hypot(dx[None, :], dy[:, None])
        if not free.any():
            return to_goal

        # A virtual source (node ny*nx) feeds the seeds with their Euclidean distance to the goal;
        # edges are offset by res so no weight is zero (a zero would read as "no edge").
        index = np.arange(ny * nx).reshape(ny, nx)
        seeds = self._seeds(free, to_goal, index)
        graph = _grid_graph(cells, seeds, to_goal.ravel()[seeds] + res)
        from scipy.sparse.csgraph import dijkstra  # imported on first use (see grid.py)

        dist = dijkstra(graph, directed=True, indices=ny * nx)[:-1].reshape(ny, nx) - res

        reached = np.isfinite(dist)
        return dist if reached.all() else _fill_unreached(dist, reached, res, fills)

    def _seeds(self, free, to_goal, index):
        """Flat indices of the Dijkstra's seeds (see the class notes)."""
        work = self.working_grid
        ny, nx = free.shape
        u, v = (self.goal - work.origin) / work.resolution
        if 0.0 <= u < nx and 0.0 <= v < ny:
            # The 2x2 cells whose centres surround the goal (the interpolation stencil, so NF is
            # near-Euclidean around the goal) when all are free, else the goal cell alone.
            sx = int(np.clip(math.floor(u - 0.5), 0, max(nx - 2, 0)))
            sy = int(np.clip(math.floor(v - 0.5), 0, max(ny - 2, 0)))
            stencil = np.s_[sy : sy + 2, sx : sx + 2]
            if free[stencil].all():
                return index[stencil].ravel()
            if free[int(v), int(u)]:
                return np.array([index[int(v), int(u)]])
        else:
            facing = np.zeros_like(free)
            facing[:, 0] |= u < 0.0
            facing[:, -1] |= u >= nx
            facing[0, :] |= v < 0.0
            facing[-1, :] |= v >= ny
            if np.any(facing & free):
                return index[facing & free]
        candidates = np.where(free, to_goal, np.inf).ravel()
        return np.flatnonzero(candidates <= candidates.min() + 1e-9 * work.resolution)

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
            Central differences of :meth:`value` with step ``resolution``, blended within one
            ``resolution`` of the goal into ``(p - goal) / |p - goal|`` with the weight
            ``|p - goal| / resolution`` on the differences; without a grid that Euclidean
            gradient alone. 0 at the goal.

        Notes
        -----
        Within a step of the goal the central differences straddle the minimum and their
        direction is noise (measured: half of them more than 90 degrees off within 1 mm at
        0.05 m cells, so the heading term jumped to ``0.2 * pi`` beside the goal). There the
        values are the Euclidean distance to the goal by construction (the seeds), so its
        gradient is the limit; the blend keeps the gradient continuous.
        """
        pts = _points("points", points)
        delta = pts - self.goal
        norm = np.linalg.norm(delta, axis=-1, keepdims=True)
        euclid = np.divide(delta, norm, out=np.zeros_like(delta), where=norm > 0)
        if self.values is None:
            return euclid
        h = self.working_grid.resolution
        dx = np.array([h, 0.0])
        dy = np.array([0.0, h])
        gx = (self.value(pts + dx) - self.value(pts - dx)) / (2 * h)
        gy = (self.value(pts + dy) - self.value(pts - dy)) / (2 * h)
        weight = np.minimum(norm / h, 1.0)
        return weight * np.stack([gx, gy], axis=-1) + (1.0 - weight) * euclid
