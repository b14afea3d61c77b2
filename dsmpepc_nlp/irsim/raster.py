"""Exact rasterisation: static shapes into an :class:`~dsmpepc_nlp.core.grid.OccupancyGrid`.

A cell is occupied when its square *overlaps* the shape, judged on the geometry, never on the
cell's centre alone (a centre test drops a wall lying on a cell edge and every obstacle thinner
than a cell):

- a shape with area (a polygon, a rectangle, a disc, a box of an image map) occupies the cells
  its interior shares a positive area with; a polygon edge lying exactly on a cell edge does
  not spill into the neighbouring cell;
- a shape without area (a line string, a point, a degenerate polygon) occupies every cell whose
  closed square it touches; a wall of no thickness lying exactly on a cell edge marks the cells
  on both sides of it, as neither side alone would hold it.

Floating-point noise is not geometry: overlaps thinner than :data:`EDGE_TOLERANCE` of a cell
are ignored, touches within it count. Discs are exact (centre and radius, not IR-SIM's polygon
of them); polygons and lines go through shapely (an IR-SIM dependency, imported when used).

The grid lies on a lattice anchored at an origin (IR-SIM's world offset); its extent covers the
world and every shape given; outside it everything is free, as for every ``OccupancyGrid``.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import InputError
from ..core.grid import OccupancyGrid

EDGE_TOLERANCE = 1e-9
"""Cells: overlaps thinner than this are rounding, touches within it are touches."""


class Lattice:
    """Cells of side ``resolution`` with cell ``[iy, ix]`` spanning ``origin + [ix, ix + 1] x
    [iy, iy + 1] * resolution``; ``shape`` is ``(ny, nx)``."""

    def __init__(self, origin, resolution: float, shape):
        self.origin = (float(origin[0]), float(origin[1]))
        self.resolution = float(resolution)
        self.shape = (int(shape[0]), int(shape[1]))

    @classmethod
    def covering(cls, bounds, anchor, resolution: float) -> Lattice:
        """The smallest lattice anchored at ``anchor`` (x, y) whose cells cover ``bounds``
        ``(xmin, ymin, xmax, ymax)``."""
        res = float(resolution)
        lo = [math.floor((bounds[i] - anchor[i]) / res + EDGE_TOLERANCE) for i in (0, 1)]
        hi = [math.ceil((bounds[i + 2] - anchor[i]) / res - EDGE_TOLERANCE) for i in (0, 1)]
        origin = (anchor[0] + lo[0] * res, anchor[1] + lo[1] * res)
        return cls(origin, res, (max(hi[1] - lo[1], 1), max(hi[0] - lo[0], 1)))

    def span(self, low: float, high: float, axis: int, closed: bool) -> tuple[int, int]:
        """First and last index along ``axis`` (0: x, 1: y) of the cells overlapping the open
        interval ``(low, high)`` (``closed``: touching ``[low, high]``), clipped; empty when
        first > last."""
        u = (low - self.origin[axis]) / self.resolution
        v = (high - self.origin[axis]) / self.resolution
        if closed:
            first, last = math.ceil(u - 1 - EDGE_TOLERANCE), math.floor(v + EDGE_TOLERANCE)
        else:
            first, last = math.floor(u + EDGE_TOLERANCE), math.ceil(v - EDGE_TOLERANCE) - 1
        size = self.shape[1 - axis]
        return max(first, 0), min(last, size - 1)

    def window(self, bounds, closed: bool = True):
        """Index ranges ``(ix0, ix1, iy0, iy1)`` (inclusive) of the cells near ``bounds``."""
        ix0, ix1 = self.span(bounds[0], bounds[2], 0, closed)
        iy0, iy1 = self.span(bounds[1], bounds[3], 1, closed)
        return ix0, ix1, iy0, iy1

    def cell_edges(self, ix0, ix1, iy0, iy1):
        """Lower and upper x (nx,) and y (ny,) edges of the cells in the index ranges."""
        ix, iy = np.arange(ix0, ix1 + 1), np.arange(iy0, iy1 + 1)
        res = self.resolution
        return (self.origin[0] + ix * res, self.origin[0] + (ix + 1) * res,
                self.origin[1] + iy * res, self.origin[1] + (iy + 1) * res)


def mark_disc(occupied, lattice: Lattice, centre, radius: float) -> None:
    """Mark the cells whose open square meets the open disc (exact)."""
    cx, cy = float(centre[0]), float(centre[1])
    r = float(radius)
    ix0, ix1, iy0, iy1 = lattice.window((cx - r, cy - r, cx + r, cy + r), closed=False)
    if ix0 > ix1 or iy0 > iy1:
        return
    x_lo, x_hi, y_lo, y_hi = lattice.cell_edges(ix0, ix1, iy0, iy1)
    dx = np.maximum.reduce([x_lo - cx, np.zeros_like(x_lo), cx - x_hi])
    dy = np.maximum.reduce([y_lo - cy, np.zeros_like(y_lo), cy - y_hi])
    gap = np.hypot(dx[None, :], dy[:, None])          # centre to the closed square, (ny, nx)
    occupied[iy0:iy1 + 1, ix0:ix1 + 1] |= gap < r - EDGE_TOLERANCE * lattice.resolution


def mark_boxes(occupied, lattice: Lattice, boxes) -> None:
    """Mark the cells overlapping any axis-aligned box ``(xmin, ymin, xmax, ymax)`` (rows of
    ``boxes``, (B, 4)) with positive area; a degenerate box (no width or height) marks the
    cells it touches. Exact, by index arithmetic."""
    boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
    if boxes.size == 0:
        return
    res, (x0, y0) = lattice.resolution, lattice.origin
    ny, nx = lattice.shape
    flat = (boxes[:, 2] - boxes[:, 0] <= EDGE_TOLERANCE * res) | \
        (boxes[:, 3] - boxes[:, 1] <= EDGE_TOLERANCE * res)
    u0, u1 = (boxes[:, 0] - x0) / res, (boxes[:, 2] - x0) / res
    v0, v1 = (boxes[:, 1] - y0) / res, (boxes[:, 3] - y0) / res
    tol = EDGE_TOLERANCE
    ix0 = np.where(flat, np.ceil(u0 - 1 - tol), np.floor(u0 + tol)).astype(np.int64)
    ix1 = np.where(flat, np.floor(u1 + tol), np.ceil(u1 - tol) - 1).astype(np.int64)
    iy0 = np.where(flat, np.ceil(v0 - 1 - tol), np.floor(v0 + tol)).astype(np.int64)
    iy1 = np.where(flat, np.floor(v1 + tol), np.ceil(v1 - tol) - 1).astype(np.int64)
    ix0, iy0 = np.maximum(ix0, 0), np.maximum(iy0, 0)
    ix1, iy1 = np.minimum(ix1, nx - 1), np.minimum(iy1, ny - 1)
    keep = (ix0 <= ix1) & (iy0 <= iy1)
    ix0, ix1, iy0, iy1 = ix0[keep], ix1[keep], iy0[keep], iy1[keep]
    counts = np.zeros((ny + 1, nx + 1), dtype=np.int64)     # 2-D difference array
    np.add.at(counts, (iy0, ix0), 1)
    np.add.at(counts, (iy0, ix1 + 1), -1)
    np.add.at(counts, (iy1 + 1, ix0), -1)
    np.add.at(counts, (iy1 + 1, ix1 + 1), 1)
    occupied |= np.cumsum(np.cumsum(counts, axis=0), axis=1)[:ny, :nx] > 0


def mark_geometry(occupied, lattice: Lattice, geometry, name: str = "shape") -> None:
    """Mark the cells a shapely geometry occupies (module docstring's rule): positive-area
    overlap for its areal parts, touching for its parts without area."""
    import shapely

    if geometry is None or geometry.is_empty:
        return
    parts = list(getattr(geometry, "geoms", [geometry]))
    if len(parts) > 1 or parts[0] is not geometry:
        for part in parts:
            mark_geometry(occupied, lattice, part, name)
        return
    if geometry.geom_type not in ("Polygon", "LineString", "LinearRing", "Point"):
        raise InputError(f"{name}: cannot rasterise a {geometry.geom_type}")
    res = lattice.resolution
    areal = geometry.geom_type == "Polygon" and geometry.area > (EDGE_TOLERANCE * res) ** 2
    if geometry.geom_type == "Polygon" and not areal:
        geometry = geometry.boundary                     # a polygon of no area is its outline
    ix0, ix1, iy0, iy1 = lattice.window(geometry.bounds, closed=True)
    if ix0 > ix1 or iy0 > iy1:
        return
    x_lo, x_hi, y_lo, y_hi = lattice.cell_edges(ix0, ix1, iy0, iy1)
    X0, Y0 = np.meshgrid(x_lo, y_lo)
    X1, Y1 = np.meshgrid(x_hi, y_hi)
    cells = shapely.box(X0, Y0, X1, Y1)
    shapely.prepare(geometry)
    if areal:
        near = shapely.intersects(geometry, cells)
        hit = np.zeros(cells.shape, dtype=bool)
        hit[near] = shapely.area(shapely.intersection(geometry, cells[near])) \
            > EDGE_TOLERANCE * res * res
    else:
        hit = shapely.distance(geometry, cells) <= EDGE_TOLERANCE * res
    occupied[iy0:iy1 + 1, ix0:ix1 + 1] |= hit


def image_boxes(grid, cell_size, offset, threshold: float = 50.0) -> np.ndarray:
    """Boxes (B, 4) of the occupied cells of an IR-SIM map grid.

    IR-SIM's grids (``env.get_map().grid``, from a PNG or a generator) are indexed
    ``[ix, iy]`` (x first, y growing upward after IR-SIM's own flip of the image), hold an
    occupancy of 0-100, and a cell counts as an obstacle above 50; ``cell_size`` is
    ``(x_reso, y_reso)``, which IR-SIM derives per axis from the world's size, so cells need not
    be square; ``offset`` is the world's lower-left corner.
    """
    grid = np.asarray(grid, dtype=float)
    ix, iy = np.nonzero(grid > threshold)
    rx, ry = float(cell_size[0]), float(cell_size[1])
    x0, y0 = float(offset[0]), float(offset[1])
    return np.column_stack([x0 + ix * rx, y0 + iy * ry, x0 + (ix + 1) * rx, y0 + (iy + 1) * ry])


def rasterise(lattice: Lattice, discs=(), geometries=(), boxes=None) -> OccupancyGrid:
    """An :class:`OccupancyGrid` on ``lattice`` of ``discs`` (``(centre, radius)`` pairs),
    ``geometries`` (``(name, shapely geometry)`` pairs) and axis-aligned ``boxes`` (B, 4)."""
    occupied = np.zeros(lattice.shape, dtype=bool)
    for centre, radius in discs:
        mark_disc(occupied, lattice, centre, radius)
    for name, geometry in geometries:
        mark_geometry(occupied, lattice, geometry, name)
    if boxes is not None:
        mark_boxes(occupied, lattice, boxes)
    return OccupancyGrid(occupied, lattice.resolution, lattice.origin)
