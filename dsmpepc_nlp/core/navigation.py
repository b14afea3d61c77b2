"""The navigation function: shortest free-space path length to a goal, on a bounded window."""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from .errors import finite_vector, positive_number
from .grid import OccupancyGrid, _interpolate, _points, _readonly

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
