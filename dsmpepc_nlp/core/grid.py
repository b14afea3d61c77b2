"""The static occupancy grid: its signed distance table, and the bilinear reader of such tables.

A table of values at cell centres plus a resolution and an origin, read by :func:`_interpolate`,
is the representation shared by the signed distance here and the navigation function
(:mod:`.navigation`); compiled evaluators read the same tables.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .errors import (
    MAX_COORDINATE,
    RESOLUTION_RANGE,
    InputError,
    finite_vector,
    number_in,
    positive_number,
)
from .mapfile import read_map, write_map

FAR = 1e3
"""A distance where nothing is, m: the signed distance everywhere on a grid without any
occupied cell, and the NLP's padding objects (``exp(-FAR^2/sigma^2)`` is exactly 0)."""


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


def _checked_occupancy(occupied):
    """``occupied`` as an array, checked: 2-D, not empty, bool or numbers 0 and 1."""
    arr = np.asarray(occupied)
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise InputError(f"occupied has shape {arr.shape}: expected (ny, nx) with ny, nx >= 1")
    if arr.dtype != bool and (
        not np.issubdtype(arr.dtype, np.number) or not np.all((arr == 0) | (arr == 1))
    ):
        raise InputError(
            f"occupied has dtype {arr.dtype} and values other than 0/1: expected bool or 0/1"
        )
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


def _distance_to_squares(marked):
    """Distance (cells) from each cell centre to the nearest square of a ``marked`` cell.

    The point of a unit square nearest to a lattice point is one of its 4 corners or, when the
    point is level with the square on one axis, one of its 4 edge midpoints. So on the lattice
    of half cells (centres at odd indices), marking every corner and edge midpoint of the marked
    squares and taking the Euclidean distance transform to them is exact, not the
    centre-to-centre transform minus half a cell (which overstates clearance off the axes by up
    to 0.21 cell). A marked cell's centre reads 0; no other cell's centre is ever marked.
    """
    ny, nx = marked.shape
    centres = np.zeros((2 * ny + 1, 2 * nx + 1), dtype=bool)
    centres[1::2, 1::2] = marked
    from scipy import ndimage  # here, not at the top: ~0.2 s of imports a map-less user skips

    features = ndimage.binary_dilation(centres, structure=np.ones((3, 3), dtype=bool))
    half_cells = ndimage.distance_transform_edt(~features)[1::2, 1::2]
    return 0.5 * half_cells


# ---------------------------------------------------------------------------------------------
# occupancy grid


class OccupancyGrid:
    """Static occupancy grid. Immutable after construction.

    Parameters
    ----------
    occupied : array_like of bool or {0, 1}, shape (ny, nx)
        ``occupied[iy, ix]``; ``iy`` grows with world y and ``ix`` with world x. ny, nx >= 1.
    resolution : float
        Cell side (m), in :data:`~dsmpepc_nlp.core.errors.RESOLUTION_RANGE`.
    origin : array_like, shape (2,)
        World (x, y) (m) of the lower-left corner of cell [0, 0], each within
        ``MAX_COORDINATE``. Cell [iy, ix] has its centre at
        ``origin + (ix + 0.5, iy + 0.5) * resolution``.

    Notes
    -----
    Everything outside the grid counts as free space.
    """

    def __init__(self, occupied, resolution, origin=(0.0, 0.0)):
        self._occupied = _readonly(np.array(_checked_occupancy(occupied), dtype=bool))
        self._resolution = number_in("resolution", resolution, *RESOLUTION_RANGE)
        self._origin = _readonly(finite_vector("origin", origin, 2, MAX_COORDINATE))

    @classmethod
    def derived(cls, occupied, resolution, origin) -> OccupancyGrid:
        """A grid the package derives from a checked one (a navigation window, a crop).

        ``MAX_COORDINATE`` bounds what a user gives; a window around a robot standing at that
        bound reaches past it by up to the robot's reach, so only finiteness is checked here.
        """
        grid = cls.__new__(cls)
        grid._occupied = _readonly(np.array(occupied, dtype=bool))
        grid._resolution = float(resolution)
        grid._origin = _readonly(finite_vector("origin", origin, 2))
        return grid

    @classmethod
    def from_array(cls, occupied, resolution, origin=(0.0, 0.0)) -> OccupancyGrid:
        """Same as the constructor; see :class:`OccupancyGrid`."""
        return cls(occupied, resolution, origin)

    @classmethod
    def updated_from(cls, previous, occupied, origin=None) -> OccupancyGrid:
        """A grid that is ``previous`` moved and changed: a rolling local map's next window.

        The values are those of a grid built from scratch; only the work differs. Its
        :attr:`signed_distance`, when ``previous``'s has been computed, is updated from it where
        the changes can reach (:mod:`.distance_update`); its navigation functions start from
        ``previous``'s for the same goal and inflation radius (:mod:`.navigation_update`).

        Parameters
        ----------
        previous : OccupancyGrid
            The grid this one follows. It is held (:attr:`previous`) until a grid is made
            from this one; its own previous grid is let go now, so no chain of grids is kept.
        occupied : array_like of bool or {0, 1}, shape (ny, nx)
            The new occupancy, any shape.
        origin : array_like, shape (2,), optional
            World (x, y) (m) of the new cell [0, 0]; ``previous``'s by default. An origin off
            ``previous``'s lattice (not whole cells away) gives a grid computed from scratch.

        Returns
        -------
        OccupancyGrid
            With ``previous``'s resolution; finite origins are accepted as for a grid the
            package derives (:meth:`derived`).
        """
        if not isinstance(previous, OccupancyGrid):
            raise InputError(f"previous={previous!r}: expected an OccupancyGrid")
        grid = cls.derived(_checked_occupancy(occupied), previous.resolution,
                           previous.origin if origin is None else origin)
        previous.__dict__.pop("_previous", None)
        grid._previous = previous
        grid._updated = True
        return grid

    @property
    def previous(self) -> OccupancyGrid | None:
        """The grid this one was updated from (:meth:`updated_from`), while it is held."""
        return self.__dict__.get("_previous")

    @property
    def is_update(self) -> bool:
        """Whether :meth:`updated_from` made this grid (its previous grid may be let go)."""
        return self.__dict__.get("_updated", False)

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

        Positive in free space: the Euclidean distance from the centre to the nearest occupied
        cell's square (an axis neighbour of an occupied cell has ``0.5 * resolution``, a diagonal
        neighbour ``sqrt(2)/2 * resolution``). Negative inside obstacles: minus the distance to
        the nearest free cell's square; cells outside the grid are free. ``FAR`` everywhere when
        no cell is occupied. Exact for the grid's geometry (see :func:`_distance_to_squares`).
        On a grid made by :meth:`updated_from`, updated from the previous grid's where the
        changes can reach (:mod:`.distance_update`): the same values, to the bit.
        """
        previous = self.__dict__.get("_previous")
        if previous is not None:
            from .distance_update import updated_signed_distance

            table = updated_signed_distance(self, previous)
            if table is not None:
                return table
        occ = self._occupied
        if not occ.any():
            return _readonly(np.full(occ.shape, FAR))
        # One ring of free cells stands for the free world outside the grid.
        padded = np.pad(occ, 1, constant_values=False)
        to_occupied = _distance_to_squares(padded)[1:-1, 1:-1]
        to_free = _distance_to_squares(~padded)[1:-1, 1:-1]
        return _readonly(np.where(occ, -to_free, to_occupied) * self._resolution)

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
        """Load a ROS ``map_server`` map (YAML + PGM).

        See :func:`~dsmpepc_nlp.core.mapfile.read_map`.

        Raises
        ------
        InputError
            Naming the file and the field for unreadable YAML, missing or invalid fields, a
            missing image, or a truncated or non-PGM image.
        """
        return cls(*read_map(path))

    def to_yaml(self, path, image_name=None) -> None:
        """Write a ROS ``map_server`` YAML file and a binary PGM beside it, atomically.

        See :func:`~dsmpepc_nlp.core.mapfile.write_map`; ``image_name`` defaults to the YAML's stem
        + ".pgm".
        """
        write_map(path, self._occupied, self._resolution, self._origin, image_name)
