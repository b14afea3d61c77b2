"""The signed distance of a grid made from a previous one: only what the changes can reach.

A grid built by :meth:`~.grid.OccupancyGrid.updated_from` is its previous grid moved by whole
cells with some cells changed. Its signed distance is the previous one where nothing can have
changed it, and recomputed exactly elsewhere: the same values, to the bit, as a computation
from scratch (:attr:`~.grid.OccupancyGrid.signed_distance`), by the same floating-point
operations on the same integers.

The distance from a free cell's centre to the nearest occupied square, squared and in half
cells, is an integer computed separably (:mod:`._distance_kernels`): per column the nearest
occupied cell (recomputed whole, a fraction of a millisecond), then per row the nearest over
the columns. A row whose column distances on the columns both grids hold are the same as before
keeps its values, but for the cells at its ends whose nearest column scrolled out (found by
walking in from that end while a departed column is still as near as the old value) and those
a column that scrolled in is nearer to (likewise): these runs are recomputed. Any other row is
recomputed whole, by an exact lower envelope (integer parabolas, breakpoints compared as
fractions). Inside obstacles, the distance to the nearest free square (or the world outside
the grid) is recomputed on every occupied cell, walking out from it, a few steps for the thin
obstacles a lidar marks; by rows when the obstacles are thick.

The loops are compiled (numba, :mod:`._distance_kernels`); without numba, or with
``DSMPEPC_NO_COMPILE=1``, :func:`updated_signed_distance` declines and the grid computes its
signed distance from scratch: the same values, at the full cost.
"""

from __future__ import annotations

import numpy as np

from .compile_cache import optional_numba_module

FREE_BUDGET = 4
"""Steps per cell that walking out from the occupied cells to the free ones may take before
the distances inside obstacles are computed by rows instead (thick obstacles)."""
SHIFT_TOLERANCE = 1e-6
"""Origins whose offset is within this many cells of whole cells count as on one lattice."""


def kernels():
    """The compiled kernels, or None when compiling is off (``DSMPEPC_NO_COMPILE``) or
    impossible."""
    return optional_numba_module(f"{__package__}._distance_kernels")


def lattice_shift(old_origin, new_origin, resolution):
    """Whole cells ``(sx, sy)`` from ``old_origin`` to ``new_origin`` (m): new cell ``(x, y)``
    is old cell ``(x + sx, y + sy)``; None when the offset is not whole cells."""
    offset = (np.asarray(new_origin, dtype=float) - np.asarray(old_origin, dtype=float))
    offset = offset / resolution
    whole = np.rint(offset)
    if not np.all(np.abs(offset - whole) <= SHIFT_TOLERANCE) or np.any(np.abs(whole) > 2**40):
        return None
    return int(whole[0]), int(whole[1])


def overlap(new_shape, old_shape, shift):
    """``(new_part, old_part)``: slices of the cells both grids hold, or None when none."""
    sx, sy = shift
    (ny, nx), (oy, ox) = new_shape, old_shape
    x0, x1 = max(0, -sx), min(nx, ox - sx)
    y0, y1 = max(0, -sy), min(ny, oy - sy)
    if x0 >= x1 or y0 >= y1:
        return None
    return (np.s_[y0:y1, x0:x1], np.s_[y0 + sy:y1 + sy, x0 + sx:x1 + sx])


def moved(old, new_shape, parts, fill):
    """``old`` (a previous grid's table) on the new grid's cells, ``fill`` where it has none."""
    table = np.empty(new_shape, dtype=old.dtype)
    table[parts[0]] = old[parts[1]]
    rows, columns = parts[0]
    table[:rows.start] = fill
    table[rows.stop:] = fill
    table[rows, :columns.start] = fill
    table[rows, columns.stop:] = fill
    return table


def squares_of(grid, module):
    """``(table, columns)`` of ``grid``: the squared half-cell distances (int64, (ny, nx)) from
    each cell centre to the nearest occupied square, and to the nearest occupied cell of its
    column (:func:`._distance_kernels.column_squares`). Kept on the grid by an update, else read
    back exactly from its signed distance (``0.5 sqrt(n) * resolution`` with integer ``n``:
    rounding recovers ``n``)."""
    kept = grid.__dict__.get("_squares")
    if kept is not None:
        return kept
    half = 2.0 * grid.signed_distance / grid.resolution
    occ = grid.occupied
    table = np.where(occ, 0, np.rint(half * half).astype(np.int64))
    columns = np.empty(occ.shape, dtype=np.int64)
    module.column_squares(occ, True, columns)
    return table, columns


def updated_signed_distance(grid, previous):
    """The signed distance of ``grid`` (m, (ny, nx), read-only) updated from that of
    ``previous``, or None when this cannot be done (no compiled kernels, ``previous``'s not
    computed, not on one lattice, the new grid without an occupied cell, no cell shared); the
    caller then computes it from scratch. Keeps its squared distances on ``grid``, for the
    grid made from it next."""
    module = kernels()
    if module is None or "signed_distance" not in previous.__dict__:
        return None
    if previous.resolution != grid.resolution:
        return None
    shift = lattice_shift(previous.origin, grid.origin, grid.resolution)
    occ = grid.occupied
    if shift is None or not occ.any():
        return None
    parts = overlap(occ.shape, previous.shape, shift)
    if parts is None:
        return None
    old_table, old_columns = squares_of(previous, module)
    columns = np.empty(occ.shape, dtype=np.int64)
    module.column_squares(occ, True, columns)
    table = np.empty(occ.shape, dtype=np.int64)
    signed = moved(previous.signed_distance, occ.shape, parts, 0.0)
    module.update_rows(occ, columns, old_columns, old_table, shift[0], shift[1],
                       grid.resolution, table, signed)
    if not module.to_free(occ, grid.resolution, signed, FREE_BUDGET * occ.size):
        free_columns = np.empty(occ.shape, dtype=np.int64)
        module.column_squares(occ, False, free_columns)
        module.to_free_rows(occ, free_columns, grid.resolution, signed)
    for part in (table, columns, signed):
        part.setflags(write=False)
    grid.__dict__["_squares"] = (table, columns)
    return signed
