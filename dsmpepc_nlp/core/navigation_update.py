"""Navigation functions on a grid made from a previous one: start from the previous paths.

On a grid built by :meth:`~.grid.OccupancyGrid.updated_from`, a navigation function is computed
here rather than by :meth:`~.navigation.NavigationFunction._solve` (scipy's Dijkstra on a
sparse graph, scipy's distance transform for the unreached cells), with the same values up to
the rounding of sums of the same edge lengths (1e-12 m, tested to 1e-9 m):

* the free cells come from the grid's (updated) signed distance and a ring of cells around the
  map (:func:`free_mask`), the same mask as :func:`~.navigation._free_cells` computes on a crop;
* when the previous grid holds a navigation function for the same goal and inflation radius
  whose window is on the same lattice and whose seeds are the same cells, its shortest paths
  are moved onto the new window and repaired (:func:`._path_kernels.update_paths`): the paths
  through cells that were blocked, lost an edge or left the window are cut and rebuilt, and
  shorter paths through cells that were freed or entered spread from them; otherwise the paths
  are computed anew on the grid (:func:`._path_kernels.shortest_paths`);
* the unreached cells take the nearest reached cell's value plus the distance to it, the
  nearest chosen as scipy chooses among equals (:func:`._path_kernels.nearest_reached`), kept
  from the previous function where no reached cell came or went near
  (:func:`._path_kernels.update_nearest`), or chosen by scipy itself when the unreached cells
  are too many to walk out from.

Without compiled kernels (``DSMPEPC_NO_COMPILE=1``, no numba) :func:`updated_values` declines
and the navigation function is computed as on any grid.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from . import distance_update
from .compile_cache import optional_numba_module
from .distance_update import lattice_shift, moved, overlap

KEPT_PER_GRID = 2
"""Navigation functions a grid keeps for the grid made from it (least recently made dropped)."""
SEED_TOLERANCE = 1e-12
"""Seeds whose values differ by more (m) count as other seeds: the paths are computed anew."""
PATH_TOLERANCE = 1e-10
"""Paths shorter by no more than this (m), plus 1e-13 of the seeds' values, are not rebuilt:
the same edges summed in another order (lengths that differ in fact differ by more than 1e-6
m on any window a map can have)."""
FILL_BUDGET = 16
"""Steps per cell that finding the unreached cells' nearest reached cells may take before
scipy's distance transform does it instead (large unreached regions)."""


def kernels():
    """The compiled kernels, or None when compiling is off or impossible."""
    return optional_numba_module(f"{__package__}._path_kernels")


def free_mask(grid, window, inflation_radius, module):
    """:func:`~.navigation._free_cells` of ``window`` from the grid's own signed distance, or
    None when the window does not hold the map and the ring of cells that can be blocked
    around it (then the crop's distances differ from the grid's near its edges); ``module``:
    :func:`.distance_update.kernels`'s."""
    res = grid.resolution
    k = math.ceil(inflation_radius / res) + 1
    ny, nx = grid.shape
    x0, y0, x1, y1 = window
    if not (x0 <= -k and y0 <= -k and x1 >= nx + k and y1 >= ny + k):
        return None
    free = np.ones((y1 - y0, x1 - x0), dtype=bool)
    free[-y0:ny - y0, -x0:nx - x0] = grid.signed_distance > inflation_radius
    module.block_ring(grid.occupied, k, res, inflation_radius, free, x0, y0)
    return free


def _seeds(nav, free):
    """``(seeds, values)``: the Dijkstra's seeds (flat) and their values (distance to the goal
    plus one cell), as :meth:`~.navigation.NavigationFunction._solve` makes them, the
    distances computed at the seeds alone when they are the cells round a goal in the
    window."""
    work = nav.working_grid
    res = work.resolution
    ny, nx = free.shape
    u, v = (nav.goal - work.origin) / res
    seeds = None
    if 0.0 <= u < nx and 0.0 <= v < ny:
        sx = int(np.clip(math.floor(u - 0.5), 0, max(nx - 2, 0)))
        sy = int(np.clip(math.floor(v - 0.5), 0, max(ny - 2, 0)))
        stencil = np.s_[sy:sy + 2, sx:sx + 2]
        if free[stencil].all():
            rows = np.arange(sy, min(sy + 2, ny))
            seeds = (rows[:, None] * nx + np.arange(sx, min(sx + 2, nx))).ravel()
        elif free[int(v), int(u)]:
            seeds = np.array([int(v) * nx + int(u)])
    if seeds is None:
        dx = work.origin[0] + res * (np.arange(nx) + 0.5) - nav.goal[0]
        dy = work.origin[1] + res * (np.arange(ny) + 0.5) - nav.goal[1]
        index = np.arange(ny * nx).reshape(ny, nx)
        seeds = nav._seeds(free, np.hypot(dx[None, :], dy[:, None]), index)
    iy, ix = np.divmod(seeds, nx)
    dx = work.origin[0] + res * (ix.astype(float) + 0.5) - nav.goal[0]
    dy = work.origin[1] + res * (iy.astype(float) + 0.5) - nav.goal[1]
    return seeds.astype(np.int64), np.hypot(dx, dy) + res


def _previous_paths(nav, grid):
    """The path state of the previous grid's navigation function for the same goal and
    inflation radius, or None."""
    previous = grid.previous
    kept = None if previous is None else previous.__dict__.get("_navigation_kept")
    if not kept:
        return None
    old = kept.get((tuple(nav.goal.tolist()), nav.inflation_radius))
    return None if old is None else old.__dict__.get("_paths")


def _repaired(state, nav, free, seeds, seed_values, module):
    """``(values, step, fill)``: the previous paths moved onto the new window and repaired,
    and what :func:`_filled` starts from (the previous path lengths, offsets to the nearest
    reached cells, and the shift); None when the windows are not on one lattice, share no
    cell, or the seeds differ (a goal beyond the window is reached through its border, which
    moves with it)."""
    work = nav.working_grid
    shift = lattice_shift(state["origin"], work.origin, work.resolution)
    if shift is None:
        return None
    parts = overlap(free.shape, state["free"].shape, shift)
    if parts is None:
        return None
    old_nx = state["free"].shape[1]
    oy, ox = np.divmod(state["seeds"], old_nx)
    moved_seeds = (oy - shift[1]) * free.shape[1] + (ox - shift[0])
    order, old_order = np.argsort(seeds), np.argsort(moved_seeds)
    if (seeds.size != moved_seeds.size
            or not np.array_equal(seeds[order], moved_seeds[old_order])
            or np.max(np.abs(seed_values[order] - state["seed_values"][old_order]))
            > SEED_TOLERANCE):
        return None
    values = moved(state["values"], free.shape, parts, np.inf)
    step = moved(state["step"], free.shape, parts, np.int8(-1))
    changed = np.flatnonzero(moved(state["free"], free.shape, parts, False) != free)
    fill = (state["values"], state["near_dy"], state["near_dx"], *shift)
    res = work.resolution
    tol = PATH_TOLERANCE + 1e-13 * float(np.max(seed_values))
    module.update_paths(free, changed, _border(free.shape), res, res * math.sqrt(2.0), tol,
                        values, step)
    return values, step, fill


def _border(shape):
    """The flat indices of the border cells of a window of ``shape``."""
    ny, nx = shape
    rows, columns = np.arange(ny) * nx, np.arange(nx)
    return np.unique(np.concatenate([columns, rows[-1] + columns, rows, rows + nx - 1]))


def _filled(values, res, module, previous=None):
    """The navigation function from the path lengths ``values``, unreached cells filled, and
    the offsets ``(near_dy, near_dx)`` to their nearest reached cells; ``previous``: the
    previous path lengths and offsets and the shift to the new window, to start from."""
    budget = FILL_BUDGET * values.size
    near_dy = np.empty(values.shape, dtype=np.int32)
    near_dx = np.empty(values.shape, dtype=np.int32)
    if previous is not None:
        done = module.update_nearest(values, *previous, near_dy, near_dx, budget)
    else:
        done = module.nearest_reached(values, near_dy, near_dx, budget)
    if not done:
        from scipy import ndimage

        reached = values < np.inf
        _, (rows, columns) = ndimage.distance_transform_edt(~reached, return_indices=True)
        near_dy = np.where(reached, 0, rows - np.arange(values.shape[0])[:, None])
        near_dx = np.where(reached, 0, columns - np.arange(values.shape[1]))
        near_dy, near_dx = near_dy.astype(np.int32), near_dx.astype(np.int32)
    out = np.empty(values.shape)
    module.navigation_values(values, near_dy, near_dx, res, out)
    return out, near_dy, near_dx


def updated_values(nav, grid, window):
    """The values of ``nav`` (a NavigationFunction being built on ``grid``, an updated grid,
    its ``working_grid`` set to ``window``'s crop) as described in the module, or None when
    the compiled kernels are missing or the window does not hold the map's ring (then
    :meth:`~.navigation.NavigationFunction._solve` computes them)."""
    module, distances = kernels(), distance_update.kernels()
    if module is None or distances is None:
        return None
    free = free_mask(grid, window, nav.inflation_radius, distances)
    if free is None or not free.any():
        return None
    seeds, seed_values = _seeds(nav, free)
    state = _previous_paths(nav, grid)
    paths = None if state is None else _repaired(state, nav, free, seeds, seed_values, module)
    if paths is None:
        res = grid.resolution
        paths = (np.empty(free.shape), np.empty(free.shape, dtype=np.int8), None)
        module.shortest_paths(free, seeds, seed_values, res, res * math.sqrt(2.0), *paths[:2])
    values, near_dy, near_dx = _filled(paths[0], grid.resolution, module, paths[2])
    nav._paths = {"origin": nav.working_grid.origin, "free": free, "seeds": seeds,
                  "seed_values": seed_values, "values": paths[0], "step": paths[1],
                  "near_dy": near_dy, "near_dx": near_dx}
    kept = grid.__dict__.setdefault("_navigation_kept", OrderedDict())
    kept[(tuple(nav.goal.tolist()), nav.inflation_radius)] = nav
    while len(kept) > KEPT_PER_GRID:
        kept.popitem(last=False)
    return values

