"""A prior static map under the local map: resampled once on the window's cell lattice, then cut
to each window (:class:`~.local_map.LocalMap`'s ``prior``)."""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import InputError, shown

MAX_PRIOR_CELLS = 10**8
"""Most cells of the prior resampled on the window's lattice (our choice: 100 MB)."""
_EDGE_SLACK = 1e-6
"""Overlaps thinner than this (cells) do not count: aligned maps round their edges."""


def prior_on_lattice(prior, resolution):
    """The prior resampled on the window's lattice: ``(occupied, start)``.

    ``occupied[j, i]`` is lattice cell ``start + (i, j)``: True when it overlaps an occupied
    prior cell (by more than a sliver), so a finer prior's thin wall is kept. The array spans
    every lattice cell that overlaps the prior: the prior's extent.
    """
    (ny, nx), step = prior.shape, prior.resolution
    spans = []
    for origin, cells in zip((float(c) for c in prior.origin), (nx, ny)):
        first = math.floor(origin / resolution + _EDGE_SLACK)
        end = math.ceil((origin + cells * step) / resolution - _EDGE_SLACK)
        edges = (np.arange(first, end + 1) * resolution - origin) / step
        low = np.clip(np.floor(edges[:-1] + _EDGE_SLACK), 0, cells).astype(np.intp)
        high = np.clip(np.ceil(edges[1:] - _EDGE_SLACK), 0, cells).astype(np.intp)
        spans.append((first, low, np.maximum(high, low)))
    (gx, x_low, x_high), (gy, y_low, y_high) = spans
    if x_low.size * y_low.size > MAX_PRIOR_CELLS:
        raise InputError(f"prior={shown(prior)}: expected at most {MAX_PRIOR_CELLS} cells of "
                         f"resolution={resolution:g} m over its extent")
    total = np.zeros((ny + 1, nx + 1), dtype=np.int32 if ny * nx < 2**31 else np.int64)
    np.cumsum(np.cumsum(prior.occupied, axis=0, dtype=total.dtype), axis=1, out=total[1:, 1:])
    count = (total[np.ix_(y_high, x_high)] - total[np.ix_(y_low, x_high)]
             - total[np.ix_(y_high, x_low)] + total[np.ix_(y_low, x_low)])
    return count > 0, np.array([gx, gy], dtype=np.int64)


def prior_window(lattice, corner, n):
    """``(occupied, covered)`` (n, n) of the prior on the window whose cell [0, 0] is lattice
    cell ``corner``; ``covered``: inside the prior's extent."""
    occupied_lattice, start = lattice
    occupied = np.zeros((n, n), dtype=bool)
    covered = np.zeros((n, n), dtype=bool)
    size = np.array(occupied_lattice.shape[::-1])
    low, high = np.maximum(corner, start), np.minimum(corner + n, start + size)
    if np.all(high > low):
        window = (slice(low[1] - corner[1], high[1] - corner[1]),
                  slice(low[0] - corner[0], high[0] - corner[0]))
        occupied[window] = occupied_lattice[low[1] - start[1]:high[1] - start[1],
                                            low[0] - start[0]:high[0] - start[0]]
        covered[window] = True
    return occupied, covered
