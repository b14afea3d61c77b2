"""A grid built from a sensor that also knows which of its cells the sensor has seen free.

:class:`SensedGrid` is an :class:`~dsmpepc_nlp.core.grid.OccupancyGrid` (the planner reads it
as any map) with one more question it can answer, :meth:`SensedGrid.is_seen_free`: whether a
beam has crossed the cell at a point. Unknown space is handed to the planner as free (or
occupied, ``LocalMapConfig.unknown``) for its costs and its navigation function; the moves
that the pose-following law cannot make (the stall ladder's reverses) ask this grid first and
are not offered into space no beam has crossed, such as the blind sector behind a 270-degree
lidar (:func:`dsmpepc_nlp.solve.behaviours.ways.reverses_seen`).
"""

from __future__ import annotations

import numpy as np

from ..core.grid import OccupancyGrid


class SensedGrid(OccupancyGrid):
    """An :class:`OccupancyGrid` with the mask of the cells a sensor has seen free.

    Built by :meth:`dsmpepc_nlp.perception.LocalMap.grid`; ``seen[iy, ix]`` is aligned with
    ``occupied``. The mask may grow while the occupancy stays the same (a beam crossing an
    unknown cell that was already handed out as free), so the local map refreshes it in place
    (:meth:`refresh`) rather than handing out a new grid whose signed distance and navigation
    function would be computed again.
    """

    @classmethod
    def build(cls, occupied, resolution, origin, seen, previous=None) -> SensedGrid:
        """The grid of ``occupied`` with the mask ``seen`` (copied), shape (ny, nx) each; with
        ``previous`` (the last grid handed out, same resolution), updated from it
        (:meth:`~dsmpepc_nlp.core.grid.OccupancyGrid.updated_from`: its signed distance and
        navigation functions repaired where the changes reach, not rebuilt). Without, it is
        updated from an empty window: the same values, but a first scan's few marks cost a
        repair rather than a whole distance transform, and the navigation function is found by
        the compiled shortest paths (on a 400 x 400 window about 15 ms against scipy's 90:
        ``python tools/dev/bench_map_updates.py --first``)."""
        if previous is None:
            previous = cls.derived(np.zeros(np.shape(occupied), dtype=bool), resolution, origin)
            _ = previous.signed_distance        # all free: no transform to run
        grid = cls.updated_from(previous, occupied, origin)
        grid._seen = np.array(seen, dtype=bool)
        if grid._seen.shape != grid.shape:
            raise ValueError(f"seen has shape {grid._seen.shape}: expected {grid.shape}")
        return grid

    def refresh(self, seen) -> None:
        """Replace the mask by ``seen`` (same shape), in place."""
        np.copyto(self._seen, np.asarray(seen, dtype=bool))

    @property
    def seen(self) -> np.ndarray:
        """Read-only copy of the mask, bool (ny, nx)."""
        seen = self._seen.copy()
        seen.setflags(write=False)
        return seen

    def is_seen_free(self, points) -> np.ndarray:
        """Whether a beam has crossed the cell at each of ``points`` (..., 2), bool (...);
        False outside the grid (never seen)."""
        return mask_at(self._seen, self.origin, self.resolution, points)


def mask_at(mask, origin, resolution, points) -> np.ndarray:
    """``mask[iy, ix]`` (bool, a grid's cells from ``origin`` at ``resolution``) at the cell
    of each world point of ``points`` (..., 2); False outside the grid or at a non-finite
    point."""
    pts = np.asarray(points, dtype=float)
    with np.errstate(invalid="ignore"):
        cells = np.floor((pts - origin) / resolution)
    ny, nx = mask.shape
    cells = np.where(np.isfinite(cells), cells, -1.0)
    inside = ((cells[..., 0] >= 0) & (cells[..., 0] < nx) & (cells[..., 1] >= 0)
              & (cells[..., 1] < ny))
    result = np.zeros(pts.shape[:-1], dtype=bool)
    index = cells[inside].astype(np.intp)
    result[inside] = mask[index[:, 1], index[:, 0]]
    return result


__all__ = ["SensedGrid", "mask_at"]
