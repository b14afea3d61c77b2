"""The cells a beam passes through: exact grid traversal, as numpy and as a numba kernel.

Coordinates are in cells of a square window of ``n`` by ``n`` cells: cell ``(ix, iy)`` is the
unit square ``[ix, ix + 1) x [iy, iy + 1)``. A beam is the segment from the sensor
``(u0, v0)`` to its end ``(u1, v1)``; its cells are the start cell and, for every grid line
the segment crosses strictly between its ends, the cell it enters there (the method of
Amanatides and Woo, with each crossing computed from the start rather than accumulated).
Every cell whose interior the segment passes through is found, whatever the step: no cell is
skipped, and a corner passed exactly diagonally enters the diagonal cell only.

A point on a cell boundary belongs to the cell the beam is heading into: along an axis the
beam walks down, ``ceil(a) - 1`` instead of ``floor(a)``.

Both paths compute every value with the same operations in the same order, so they set the
same cells bit for bit (a test holds them to it); ``DSMPEPC_NO_COMPILE=1`` (or numba missing)
keeps the numpy path.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..core.compile_cache import optional_numba_module


def traverse(u0, v0, u1, v1, exclude, n) -> np.ndarray:
    """Mask of the window's cells that any beam passes through.

    Parameters
    ----------
    u0, v0 : float
        The sensor (cells), inside the window.
    u1, v1 : ndarray of float, shape (m,)
        Each beam's end (cells), clipped to the window ``[0, n]``.
    exclude : ndarray of int64, shape (m,)
        A linear cell index ``iy * n + ix`` per beam that this beam does not set (its hit
        cell), or -1.
    n : int
        Cells a side.

    Returns
    -------
    ndarray of bool, shape (n * n,)
        Flat, row ``iy`` after row: ``mask.reshape(n, n)[iy, ix]``. Cells outside the window
        are left out.
    """
    u1 = np.ascontiguousarray(u1, dtype=float)
    v1 = np.ascontiguousarray(v1, dtype=float)
    exclude = np.ascontiguousarray(exclude, dtype=np.int64)
    mask = np.zeros(n * n, dtype=bool)
    kernel = _compiled_kernel()
    if kernel is not None:
        kernel(float(u0), float(v0), u1, v1, exclude, int(n), mask)
    else:
        traverse_numpy(float(u0), float(v0), u1, v1, exclude, int(n), mask)
    return mask


def window_fraction(u0, v0, du, dv, n) -> np.ndarray:
    """Largest ``t`` in [0, 1] with ``(u0, v0) + t (du, dv)`` in the window ``[0, n]^2``, for a
    start inside it (cells)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        tu = np.where(du > 0, (n - u0) / du, np.where(du < 0, -u0 / du, np.inf))
        tv = np.where(dv > 0, (n - v0) / dv, np.where(dv < 0, -v0 / dv, np.inf))
    return np.minimum(1.0, np.minimum(tu, tv))


def cell_index(u, v, n) -> np.ndarray:
    """Linear index ``iy * n + ix`` of the cells holding points ``(u, v)`` (cells), -1 outside
    the window."""
    ix, iy = np.floor(u), np.floor(v)
    inside = (ix >= 0) & (ix < n) & (iy >= 0) & (iy < n)
    return np.where(inside, iy * n + ix, -1.0).astype(np.int64)


# ---------------------------------------------------------------------------------------------
# numpy


def _line_crossings(a0, a1):
    """First grid line and number of lines crossed strictly between ``a0`` and ``a1``."""
    forward = a1 > a0
    backward = a1 < a0
    first = np.where(forward, math.floor(a0) + 1.0, np.floor(a1) + 1.0)
    last = np.where(forward, np.ceil(a1) - 1.0, math.ceil(a0) - 1.0)
    count = np.where(forward | backward, np.maximum(last - first + 1.0, 0.0), 0.0)
    return first, count.astype(np.intp)


def _entered_cells(a0, b0, da, db, first, count):
    """At each crossing of a line of axis ``a``: the beam, and the cell entered (a, b)."""
    beam = np.repeat(np.arange(count.size), count)
    start = np.cumsum(count) - count
    line = first[beam] + (np.arange(beam.size) - start[beam])
    da_b, db_b = da[beam], db[beam]
    t = (line - a0) / da_b
    b = b0 + t * db_b
    cell_b = np.where(db_b >= 0.0, np.floor(b), np.ceil(b) - 1.0)
    cell_a = np.where(da_b > 0.0, line, line - 1.0)
    return beam, cell_a, cell_b


def traverse_numpy(u0, v0, u1, v1, exclude, n, mask) -> None:
    """The traversal (see :func:`traverse`) vectorised over every crossing: sets ``mask``."""
    du = u1 - u0
    dv = v1 - v0
    beams = np.arange(u1.size)
    start_u = np.where(du >= 0.0, math.floor(u0), math.ceil(u0) - 1.0)
    start_v = np.where(dv >= 0.0, math.floor(v0), math.ceil(v0) - 1.0)
    beam_u, cross_u, other_v = _entered_cells(u0, v0, du, dv, *_line_crossings(u0, u1))
    beam_v, cross_v, other_u = _entered_cells(v0, u0, dv, du, *_line_crossings(v0, v1))
    beam = np.concatenate([beams, beam_u, beam_v])
    ix = np.concatenate([start_u, cross_u, other_u])
    iy = np.concatenate([start_v, other_v, cross_v])
    inside = (ix >= 0.0) & (ix < n) & (iy >= 0.0) & (iy < n)
    linear = iy[inside].astype(np.int64) * n + ix[inside].astype(np.int64)
    mask[linear[linear != exclude[beam[inside]]]] = True


# ---------------------------------------------------------------------------------------------
# numba


@functools.lru_cache(maxsize=1)
def _compiled_kernel():
    """The numba-compiled traversal (:mod:`._raycast_kernel`, cached on disk beside the other
    compiled kernels), or None (compiling off, no numba, the cache not writable)."""
    module = optional_numba_module(f"{__package__}._raycast_kernel")
    return None if module is None else module.traverse_loops


def warm_up() -> bool:
    """Run the compiled traversal once, so that its code is loaded (or compiled) now and not in
    a robot's first update; False on the numpy path."""
    if _compiled_kernel() is None:
        return False
    traverse(0.5, 0.5, np.array([2.5]), np.array([1.5]), np.array([-1]), 3)
    return True
