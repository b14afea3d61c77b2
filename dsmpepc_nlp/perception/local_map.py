"""A rolling local occupancy map built from 2D lidar scans, read by the planner as a grid.

The window is a fixed square of cells centred on the sensor; it rolls with it in whole cells
of a lattice anchored at the world origin (cell ``(gx, gy)`` is the square
``[gx, gx + 1) x [gy, gy + 1) * resolution``), so memory is a fixed set of arrays, whatever
the travel. Cells that scroll out are forgotten; cells that scroll in start unknown.

Each cell is unknown, free or occupied. A scan first clears every cell each beam passes
through, from the sensor to its hit (the hit cell left out), or to ``raytrace_max_range`` for
a beam with no return, then marks the cell of every hit within ``obstacle_max_range``: mark
after clear, as Nav2's obstacle layer does, so one beam's clearing never erases another beam's
mark of the same scan. A later scan that sees through a marked cell clears it (a moved
obstacle). With ``decay`` a mark not re-observed within that time is forgotten (unknown again).

The prior (a static map) is merged under the observations as Nav2's layered costmap merges
its static layer: by maximum. A prior-occupied cell reads occupied whatever the sensor says
(clearing never removes it: a wrong static map is fixed in the map, not by the lidar); a
prior-free cell reads as the observations say, and as free if never observed (``unknown``
applies only outside the prior). What the sensor has seen is the sensor's alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import RESOLUTION_RANGE, InputError, number_in, positive_number, shown
from ..core.grid import OccupancyGrid
from ..core.world import warm_up_map_updates
from . import raycast
from .prior import prior_on_lattice, prior_window
from .raycast import cell_index, traverse, window_fraction
from .scan import LaserScan
from .sensed_grid import SensedGrid, mask_at

UNKNOWN, FREE, OCCUPIED = 0, 1, 2
"""A cell's state in :attr:`LocalMap._state` (int8)."""
MAX_CELLS = 4096
"""Most cells a side of the window (our choice: 16.8 M cells, ~34 MB of state)."""
_UNKNOWN_POLICIES = ("free", "occupied")
MARK_BEYOND = 0.01
"""How far beyond a return (m) the local map marks it (:class:`LocalMapConfig`). Chosen on
BARN's even worlds under ``lidar`` (the same 148 of 150 arrive as with 0.0, 0.1 s sooner);
held out, the odd worlds: 148 against 147, 0.17 s sooner
(docs/experiments/2026-12-06-marks-beyond-the-return.md)."""


@dataclass(frozen=True)
class LocalMapConfig:
    """How the local map is built; validated on construction.

    Parameters
    ----------
    size : float
        Side (m) of the square window. Default 20.0 (our choice: 10 m each way, more than a
        planning horizon at walking speed). The window has ``round(size / resolution)`` cells
        a side (:attr:`cells`), between 3 and :data:`MAX_CELLS`.
    resolution : float
        Cell side (m). Default 0.05 (Nav2's local costmap in its default parameters).
    obstacle_max_range : float
        Hits farther than this (m) are not marked. Default 25.0 (our choice: a 2D lidar's
        range, beyond the window; Nav2 obstacle layer's default 2.5 m is for depth cameras).
    raytrace_max_range : float
        Beams clear up to this distance (m), also beams with no return (``+inf``). Default
        30.0 (our choice, beyond the window; Nav2's default 3.0 m is for depth cameras).
    unknown : {"free", "occupied"}
        How cells never observed (and outside the prior) reach the planner. Default "free":
        the BARN probe showed that works.
    decay : float or None
        A mark not re-observed within this time (s) is forgotten. Default None: marks stay
        until a beam clears them, as in Nav2's obstacle layer.
    mark_beyond : float
        A return marks the cell this far (m) beyond it along its beam, at most one cell. A
        return lies on a surface; where the surface runs along a cell edge, range noise puts
        half the returns in the free cell before it, and marking that cell narrows every gap by
        a cell. Default :data:`MARK_BEYOND`, 0.01 m (our choice: ten times a UST-10's range
        noise, a fifth of a 0.05 m cell; a surface covering less than that of its cell is not
        marked there). 0.0 marks the cell of the return, as Nav2's obstacle layer does.
    """

    size: float = 20.0
    resolution: float = 0.05
    obstacle_max_range: float = 25.0
    raytrace_max_range: float = 30.0
    unknown: str = "free"
    decay: float | None = None
    mark_beyond: float = MARK_BEYOND

    def __post_init__(self):
        put = object.__setattr__  # frozen: the checked values are set once, here
        put(self, "size", positive_number("size", self.size))
        put(self, "resolution", number_in("resolution", self.resolution, *RESOLUTION_RANGE))
        for name in ("obstacle_max_range", "raytrace_max_range"):
            put(self, name, positive_number(name, getattr(self, name)))
        if self.unknown not in _UNKNOWN_POLICIES:
            raise InputError(f"unknown={shown(self.unknown)}: expected one of "
                             f"{', '.join(map(repr, _UNKNOWN_POLICIES))}")
        if self.decay is not None:
            put(self, "decay", positive_number("decay", self.decay))
        put(self, "mark_beyond", number_in("mark_beyond", self.mark_beyond, 0.0,
                                           self.resolution))
        cells = self.size / self.resolution
        if not 3 <= round(cells) <= MAX_CELLS:
            raise InputError(f"size={shown(self.size)}: expected between 3 and {MAX_CELLS} "
                             f"cells of resolution={self.resolution:g} m a side, got {cells:g}")

    @property
    def cells(self) -> int:
        """Cells a side of the window."""
        return int(round(self.size / self.resolution))


def _shift(arr, shift, fill) -> None:
    """Scroll ``arr`` (ny, nx) in place by whole cells: ``new[j, i] = old[j + sy, i + sx]``;
    cells from outside get ``fill``."""
    sx, sy = int(shift[0]), int(shift[1])
    ny, nx = arr.shape
    if abs(sx) >= nx or abs(sy) >= ny:
        arr.fill(fill)
        return
    src_y, dst_y = slice(max(sy, 0), ny + min(sy, 0)), slice(max(-sy, 0), ny + min(-sy, 0))
    src_x, dst_x = slice(max(sx, 0), nx + min(sx, 0)), slice(max(-sx, 0), nx + min(-sx, 0))
    arr[dst_y, dst_x] = arr[src_y, src_x]  # numpy copies through a buffer where they overlap
    if sy:
        arr[slice(ny - sy, None) if sy > 0 else slice(None, -sy)] = fill
    if sx:
        arr[:, slice(nx - sx, None) if sx > 0 else slice(None, -sx)] = fill


class LocalMap:
    """The rolling window of what the lidar has seen around the robot (see the module).

    Parameters
    ----------
    config : LocalMapConfig, optional
        Defaults to ``LocalMapConfig()``.
    prior : OccupancyGrid, optional
        A static map merged under the observations (see the module for the policy). Any
        resolution and origin: a window cell is prior-occupied when it overlaps an occupied
        prior cell, and inside the prior's extent when it overlaps the prior at all.

    Notes
    -----
    Before the first update the window is centred on the world origin, every cell unknown.
    """

    def __init__(self, config=None, prior=None):
        config = LocalMapConfig() if config is None else config
        if not isinstance(config, LocalMapConfig):
            raise InputError(f"config={shown(config)}: expected a LocalMapConfig or None")
        if prior is not None and not isinstance(prior, OccupancyGrid):
            raise InputError(f"prior={shown(prior)}: expected an OccupancyGrid or None")
        self._config = config
        n = config.cells
        self._state = np.zeros((n, n), dtype=np.int8)
        self._seen_free = np.zeros((n, n), dtype=bool)
        self._mark_time = None if config.decay is None else np.full((n, n), -np.inf)
        self._corner = self._corner_for((0.0, 0.0))
        self._stamp = None
        self._version = 0
        self._prior = None if prior is None else prior_on_lattice(prior, config.resolution)
        self._prior_cache = None    # (corner, occupied, covered) of the window's prior
        self._served = None         # (version, corner, grid) of the last grid()

    # -- the window --------------------------------------------------------------------------

    @property
    def config(self) -> LocalMapConfig:
        """The configuration."""
        return self._config

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx) of the window: ``(config.cells, config.cells)``, always."""
        return self._state.shape

    @property
    def origin(self) -> np.ndarray:
        """World (x, y) (m) of the lower-left corner of the window's cell [0, 0]."""
        return self._corner * self._config.resolution

    @property
    def stamp(self) -> float | None:
        """Stamp (s) of the last update, None before the first."""
        return self._stamp

    def _corner_for(self, xy) -> np.ndarray:
        """Lattice index (gx, gy) of cell [0, 0] of the window centred on ``xy``."""
        cell = np.floor(np.asarray(xy, dtype=float) / self._config.resolution)
        return cell.astype(np.int64) - self._config.cells // 2

    def _roll_to(self, xy) -> None:
        corner = self._corner_for(xy)
        shift = corner - self._corner
        if not shift.any():
            return
        _shift(self._state, shift, UNKNOWN)
        _shift(self._seen_free, shift, False)
        if self._mark_time is not None:
            _shift(self._mark_time, shift, -np.inf)
        self._corner = corner

    # -- updating ----------------------------------------------------------------------------

    def prepare(self) -> bool:
        """Load (or compile) the compiled ray traversal and map updates now, not in the first
        update; False on the numpy path."""
        warm_up_map_updates()
        return raycast.warm_up()

    def update(self, scan: LaserScan) -> dict:
        """Roll the window to the sensor, forget stale marks, clear along the beams, mark hits.

        Parameters
        ----------
        scan : LaserScan
            Not earlier than the previous update's (equal stamps are accepted).

        Returns
        -------
        dict of str to int
            ``beams``, ``used``, the counts of :meth:`LaserScan.validity` (``hits``,
            ``no_return`` and the drops by reason), ``beyond_obstacle_range`` and
            ``outside_window`` (hits not marked), and the distinct cells ``cells_marked``,
            ``cells_cleared`` (set free, not marked by the same scan) and ``cells_forgotten``
            (by decay).

        Raises
        ------
        InputError
            ``scan`` not a LaserScan; ``stamp`` earlier than the previous update's.
        """
        if not isinstance(scan, LaserScan):
            raise InputError(f"scan={shown(scan)}: expected a LaserScan")
        if self._stamp is not None and scan.stamp < self._stamp:
            raise InputError(f"stamp={shown(scan.stamp)}: expected >= {self._stamp!r}, the "
                             "previous update's stamp (s)")
        valid, validity = scan.validity()
        counts = {"beams": scan.size, "used": int(np.count_nonzero(valid)), **validity}
        self._roll_to(scan.pose[:2])
        counts["cells_forgotten"] = self._decay(scan.stamp)
        marks, clear = self._observe(scan, valid, counts)
        state = self._state.reshape(-1)
        clear[marks] = False
        np.copyto(state, FREE, where=clear)
        self._seen_free.reshape(-1)[clear] = True
        state[marks] = OCCUPIED
        if self._mark_time is not None:
            self._mark_time.reshape(-1)[marks] = scan.stamp
        counts["cells_marked"] = int(marks.size)
        counts["cells_cleared"] = int(np.count_nonzero(clear))
        self._stamp = scan.stamp
        self._version += 1
        return counts

    def _decay(self, stamp) -> int:
        if self._mark_time is None:
            return 0
        stale = (self._state == OCCUPIED) & (stamp - self._mark_time > self._config.decay)
        np.copyto(self._state, UNKNOWN, where=stale)
        return int(np.count_nonzero(stale))

    def _observe(self, scan, valid, counts):
        """The linear indices of the cells marked (distinct) and the mask of cells cleared."""
        cfg, n = self._config, self._config.cells
        u0, v0 = (scan.pose[:2] - self.origin) / cfg.resolution
        angle = scan.pose[2] + scan.beam_angles()[valid]
        r = scan.ranges[valid]
        cos, sin = np.cos(angle), np.sin(angle)
        no_return = np.isposinf(r)
        reach = np.where(no_return, cfg.raytrace_max_range,
                         np.minimum(r, cfg.raytrace_max_range)) / cfg.resolution
        du, dv = cos * reach, sin * reach
        t = window_fraction(u0, v0, du, dv, n)
        u1, v1 = u0 + t * du, v0 + t * dv
        # Where the beam ends at its hit (t == 1: not cut by the window or the clearing range),
        # the end is the hit, computed alike: u0 + cos * (r / resolution).
        ends_at_hit = ~no_return & (r <= cfg.raytrace_max_range) & (t >= 1.0)
        exclude = np.where(ends_at_hit, cell_index(u1, v1, n), -1)
        clear = traverse(u0, v0, u1, v1, exclude, n)
        hit = ~no_return & (r <= cfg.obstacle_max_range)
        scaled = (r[hit] + cfg.mark_beyond) / cfg.resolution
        cells = cell_index(u0 + cos[hit] * scaled, v0 + sin[hit] * scaled, n)
        counts["beyond_obstacle_range"] = int(np.count_nonzero(~no_return & ~hit))
        counts["outside_window"] = int(np.count_nonzero(cells < 0))
        return np.unique(cells[cells >= 0]), clear

    # -- reading -----------------------------------------------------------------------------

    def _prior_arrays(self):
        """(occupied, covered) of the prior over the window, or None without a prior."""
        if self._prior is None:
            return None
        cache = self._prior_cache
        if cache is None or not np.array_equal(cache[0], self._corner):
            cache = (self._corner.copy(), *prior_window(self._prior, self._corner,
                                                         self._config.cells))
            self._prior_cache = cache
        return cache[1], cache[2]

    def _occupancy(self) -> np.ndarray:
        """What :meth:`grid` hands out: marks, unknown per the policy, and the prior."""
        occupied = self._state == OCCUPIED
        prior = self._prior_arrays()
        if self._config.unknown == "occupied":
            unseen = self._state == UNKNOWN
            occupied |= unseen if prior is None else unseen & ~prior[1]
        if prior is not None:
            occupied |= prior[0]
        return occupied

    def grid(self) -> SensedGrid:
        """The window as the planner's grid (``occupied[iy, ix]``, origin :attr:`origin`) with
        the cells seen free (:class:`~.sensed_grid.SensedGrid`); the last call's object when no
        cell it hands out has changed and the window did not roll."""
        served = self._served
        if served is not None and served[0] == self._version:
            return served[2]
        occupied = self._occupancy()
        if (served is not None and np.array_equal(served[1], self._corner)
                and np.array_equal(served[2].occupied, occupied)):
            grid = served[2]
            grid.refresh(self._seen_free)          # more seen, the same map: keep its caches
        else:
            grid = SensedGrid.build(occupied, self._config.resolution, self.origin,
                                    self._seen_free, None if served is None else served[2])
        self._served = (self._version, self._corner.copy(), grid)
        return grid

    def changed_cells(self) -> np.ndarray:
        """Cells of the window whose :meth:`grid` value differs from the last ``grid()``'s at
        the same world position, bool (ny, nx); cells that scrolled in since count as changed,
        and all are changed before the first ``grid()``. Compare ``grid().origin`` for the
        window's move; ``np.argwhere`` gives the ``[iy, ix]`` indices."""
        current = self._occupancy()
        if self._served is None:
            return np.ones_like(current)
        shift = self._corner - self._served[1]
        before = self._served[2].occupied.copy()
        seen_before = np.ones_like(current)
        _shift(before, shift, False)
        _shift(seen_before, shift, False)
        return ~seen_before | (current != before)

    def known(self) -> np.ndarray:
        """Cells the sensor has observed (free or occupied) and still remembers, bool (ny, nx)."""
        return self._state != UNKNOWN

    def seen_free(self) -> np.ndarray:
        """Cells a beam has passed through since they entered the window, bool (ny, nx); stays
        True when the cell is marked later."""
        return self._seen_free.copy()

    def is_seen_free(self, points) -> np.ndarray:
        """:meth:`seen_free` at world points (..., 2) -> bool (...); False outside the window."""
        pts = np.asarray(points, dtype=float)
        if pts.ndim < 1 or pts.shape[-1] != 2 or not np.all(np.isfinite(pts)):
            raise InputError(f"points={shown(points)}: expected finite world positions (m) of "
                             "shape (..., 2)")
        return mask_at(self._seen_free, self.origin, self._config.resolution, pts)
