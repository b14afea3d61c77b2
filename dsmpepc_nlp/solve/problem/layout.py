"""The graph's parameter blocks: their sizes, names and shapes, and the packing of a prepared
cycle into them (numpy). One layout, in one file: the graph reads what these functions write."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ...core.config import PlannerConfig
from ...core.control_law import clamp_measured
from ...core.grid import FAR
from ...core.validation import check_integers
from . import parameters as settings_block

# FAR (core.grid's): the distance reported by padding objects and by a world without a map,
# m; exp(-FAR^2/sigma^2) is exactly 0.

FRAME_COLUMNS = 5
"""A table's frame: origin (x, y) of its lower-left cell corner, resolution, and the number of
valid columns and rows (the clamping box of the bilinear interpolation)."""

@dataclass(frozen=True)
class GraphSizes:
    """Fixed sizes of the parameter blocks; the graph is built once for them.

    Attributes
    ----------
    max_objects : int
        Dynamic objects the graph sees at every pose (those that come nearest to the robot's
        start over the horizon).
    circles_per_object : int
        Circles per object (a pedestrian uses 1; padding repeats its nearest circle).
    table_cells : int
        Side of the square window of the distance and navigation tables, cells. The window
        holds the whole map when it fits, else the part around the robot.
    ray_samples : int or None
        Samples of the distance table along the terminal ray (``ttc_range`` long, start
        included) from which the terminal static time to collision is read; None (default):
        :func:`ray_samples`, spaced by at most the smallest footprint radius.
    pose_objects : int or None
        Dynamic objects the graph sees at every pose of the horizon (the nearest of those the
        robot can reach: an object out of reach has ``1 - P_c == 1.0`` exactly, see
        ``cycle.CULL_SIGMAS``); None: ``max_objects``. The terminal time to collision always
        sees ``max_objects``. The solvers compile a few sizes and pick the smallest that holds
        the cycle's objects in reach (``SolverConfig.pose_object_buckets``).
    """

    max_objects: int = 12
    circles_per_object: int = 1
    table_cells: int = 256
    ray_samples: int | None = None
    pose_objects: int | None = None

    def __post_init__(self):
        check_integers(self, {"max_objects": 1, "circles_per_object": 1, "table_cells": 2,
                              "ray_samples": (2, None), "pose_objects": (0, None)})

    @property
    def k_pose(self) -> int:
        """Objects seen at every pose."""
        return self.max_objects if self.pose_objects is None else self.pose_objects


RAY_LADDER_BASE = 7
"""The terminal ray's sample counts are ``7 * 2^k``: the default ray (8 m, 0.3 m radius, 28
samples) is on the ladder, and every other range and footprint rounds up to one of a few
counts, so that they share compiled libraries (the count is structure)."""


def ray_samples(config: PlannerConfig, sizes: GraphSizes) -> int:
    """Samples along the terminal ray: ``sizes.ray_samples``, or (None) enough that they are
    at most the smallest footprint radius apart, rounded up to the ladder
    ``RAY_LADDER_BASE * 2^k``.

    A ray that crosses a wall spends at least a footprint diameter within a radius of it
    (gap <= 0), so samples a radius apart put at least two in contact: no wall is skipped,
    and the first crossing is interpolated between samples a radius apart. (A ray that only
    grazes a wall's inflated edge is missed at any finite count.) More samples buy no accuracy
    and cost gradient time (docs/experiments/2026-11-23-ipopt-options-and-ray-samples.md).
    """
    if sizes.ray_samples is not None:
        return sizes.ray_samples
    smallest = min(radius for _, _, radius in config.robot.footprint)
    needed = max(2, int(np.ceil(config.cost.ttc_range / smallest)) + 1)
    count = RAY_LADDER_BASE
    while count < needed:
        count *= 2
    return count


PARAMETER_NAMES = ("state", "goal", "obstacle_circles", "obstacle_velocities", "pose_circles",
                   "pose_velocities", "pose_mask", "map_frame", "map_table", "nav_frame",
                   "nav_table", "settings")
"""Named parameter inputs of :func:`build_cost_function`, in order."""


def parameter_shapes(config: PlannerConfig, sizes: GraphSizes) -> dict:
    """Shape of each parameter block (CasADi column-major)."""
    cells = sizes.table_cells * sizes.table_cells
    return {
        "state": (5, 1),
        "goal": (3, 1),
        "obstacle_circles": (sizes.max_objects * sizes.circles_per_object, 3),
        "obstacle_velocities": (sizes.max_objects, 2),
        "pose_circles": (sizes.k_pose * sizes.circles_per_object, 3),
        "pose_velocities": (sizes.k_pose, 2),
        "pose_mask": (config.horizon.n_steps + 1, sizes.k_pose),
        "map_frame": (FRAME_COLUMNS, 1),
        "map_table": (cells, 1),
        "nav_frame": (FRAME_COLUMNS, 1),
        "nav_table": (cells, 1),
        "settings": (len(settings_block.names(config)), 1),
    }


def resolved_sizes(config: PlannerConfig, sizes: GraphSizes) -> GraphSizes:
    """``sizes`` with its terminal ray's sample count resolved (:func:`ray_samples`): what a
    compiled library's key holds."""
    return dataclasses.replace(sizes, ray_samples=ray_samples(config, sizes))



# --- packing the world into parameters (numpy) ----------------------------------------------


def pack_obstacles(cycle, sizes: GraphSizes, k_max: int | None = None,
                   reach_only: bool = False):
    """``(circles, velocities, indices)`` of the ``k_max`` objects that come nearest to the
    robot's start.

    Returns ``circles`` ((K C_obj), 3: x, y, radius now), ``velocities`` (K, 2) and
    ``indices`` ((K C_obj,): each packed circle's index among the cycle's circles, -1 for
    padding); padding objects sit FAR away. ``k_max`` defaults to ``sizes.max_objects``; with
    ``reach_only`` only the objects the robot can reach within the horizon are candidates
    (``Cycle.in_reach``: the others change no bit of the collision probability).
    """
    k_max = sizes.max_objects if k_max is None else k_max
    c_obj = sizes.circles_per_object
    circles = np.tile([FAR, FAR, 0.1], (k_max * c_obj, 1))
    velocities = np.zeros((k_max, 2))
    indices = np.full(k_max * c_obj, -1)
    owner = cycle.owner
    if len(owner) == 0 or k_max == 0:
        return circles, velocities, indices
    position = np.array([cycle.state.x, cycle.state.y])
    gap = np.min(np.linalg.norm(cycle.predicted - position, axis=-1), axis=0) - cycle.radii
    n_obj = int(owner.max()) + 1
    per_object = np.full(n_obj, np.inf)
    np.minimum.at(per_object, owner, gap)
    candidates = np.argsort(per_object, kind="stable")
    if reach_only:
        reach = np.asarray(cycle.in_reach, dtype=bool)[:n_obj]
        candidates = candidates[reach[candidates]]
    count = np.bincount(owner, minlength=n_obj)
    chosen = candidates[count[candidates] > 0][:k_max]
    # Each object's circles nearest first (ties by index: a stable sort by owner, then gap),
    # the first c_obj of each chosen object; padding circles repeat the nearest one (the min
    # over circles is unchanged). Vectorised: a loop over objects was slower.
    order = np.lexsort((gap, owner))
    first = np.searchsorted(owner[order], chosen)
    column = np.arange(c_obj)
    near = order[first[:, None] + np.where(column < count[chosen][:, None], column, 0)]
    flat, m = near.reshape(-1), near.size
    circles[:m] = np.column_stack([cycle.centers[flat], cycle.radii[flat]])
    velocities[:len(chosen)] = cycle.velocities[near[:, 0]]
    indices[:m] = flat
    return circles, velocities, indices


def pose_mask(cycle, indices, circles_per_object: int) -> np.ndarray:
    """``(N+1, K)``: 1 where the packed object ``j`` may matter at pose ``k``, else 0.

    ``indices`` are the packed circles' indices among the cycle's (:func:`pack_obstacles`,
    -1 for padding); the graph moves them as the cycle predicts them (constant velocity). An
    object is 0 at a pose where ``Cycle.reach_bounds`` of every circle of it is at least
    its step's ``cycle.cull``: there ``1 - P_c`` is 1.0 exactly for every z in the box,
    so the graph skips it (the bound that leaves whole objects out of a cycle, per pose; in
    the crowded demo scene about 70 % of the pose-object pairs).
    """
    bounds = np.full((cycle.reach_bounds.shape[0], len(indices)), np.inf)
    real = indices >= 0
    bounds[:, real] = cycle.reach_bounds[:, indices[real]]
    per_object = bounds.reshape(len(bounds), -1, circles_per_object).min(axis=2)
    return (per_object < cycle.cull[:, None]).astype(float)


def objects_in_reach(cycle) -> int:
    """How many dynamic objects the robot can reach within the horizon this cycle."""
    return int(np.count_nonzero(cycle.in_reach))


def pack_table(table, resolution, origin, centre, cells: int) -> tuple:
    """``(frame, values)``: a window of ``cells`` x ``cells`` of ``table`` (ny, nx) around
    ``centre``, as the graph reads it (x fastest); the whole table when it fits."""
    ny, nx = table.shape
    u0 = int(np.clip(np.floor((centre[0] - origin[0]) / resolution) - cells // 2, 0,
                     max(nx - cells, 0)))
    v0 = int(np.clip(np.floor((centre[1] - origin[1]) / resolution) - cells // 2, 0,
                     max(ny - cells, 0)))
    window = table[v0:v0 + cells, u0:u0 + cells]
    values = np.zeros((cells, cells))
    values[:window.shape[0], :window.shape[1]] = window
    frame = np.array([origin[0] + u0 * resolution, origin[1] + v0 * resolution, resolution,
                      window.shape[1], window.shape[0]], dtype=float)
    return frame, values.reshape(-1)


def pack_parameters(cycle, sizes: GraphSizes) -> dict:
    """Every parameter block of :func:`build_cost_function` from a prepared ``Cycle``.

    Returns a dict over :data:`PARAMETER_NAMES` of numpy arrays shaped by
    :func:`parameter_shapes`. The measured ``(v, omega)`` is clamped to the limits.
    """
    state, config, cells = cycle.state, cycle.config, sizes.table_cells
    v0, omega0 = clamp_measured(state, config)
    circles, velocities, _ = pack_obstacles(cycle, sizes)
    pose_circles, pose_velocities, pose_indices = pack_obstacles(cycle, sizes, sizes.k_pose,
                                                                 reach_only=True)
    centre = (state.x, state.y)
    grid = cycle.world.grid
    if grid is None:
        map_frame = np.array([state.x - 1.0, state.y - 1.0, 1.0, 2.0, 2.0])
        map_table = np.full(cells * cells, FAR)
    else:
        map_frame, map_table = pack_table(grid.signed_distance, grid.resolution, grid.origin,
                                          centre, cells)
    nav = cycle.navigation
    if nav.values is None:
        nav_frame, nav_table, euclidean = map_frame, np.zeros(cells * cells), 1.0
    else:
        work = nav.working_grid
        nav_frame, nav_table = pack_table(nav.values, work.resolution, work.origin, centre,
                                          cells)
        euclidean = 0.0
    goal = np.asarray(cycle.goal, dtype=float).reshape(2)
    return {
        "state": np.array([state.x, state.y, state.phi, v0, omega0]),
        "goal": np.array([goal[0], goal[1], euclidean]),
        "obstacle_circles": circles,
        "obstacle_velocities": velocities,
        "pose_circles": pose_circles,
        "pose_velocities": pose_velocities,
        "pose_mask": pose_mask(cycle, pose_indices, sizes.circles_per_object),
        "map_frame": map_frame,
        "map_table": map_table,
        "nav_frame": nav_frame,
        "nav_table": nav_table,
        "settings": settings_block.values(config),
    }


def flatten_parameters(params: dict) -> np.ndarray:
    """The blocks as one vector, each column-major (CasADi's ``vec``), in PARAMETER_NAMES order:
    the flat ``p`` the solvers and the compiled functions take."""
    return np.concatenate([np.asarray(params[n], dtype=float).reshape(-1, order="F")
                           for n in PARAMETER_NAMES])


def is_finite_parameters(params: dict) -> bool:
    """True when every block is finite."""
    return all(np.all(np.isfinite(params[n])) for n in PARAMETER_NAMES)


