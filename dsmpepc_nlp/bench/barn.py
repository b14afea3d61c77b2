"""The BARN benchmark (Perille et al. 2020; The BARN Challenge): worlds, scenario, score, runner.

Geometry (``/work/shared/data/barn/FORMAT.md``): ``grid_N.npy`` is 30 x 30, 1 = a cylinder of
radius 0.075 m whose centre is at world ``(x, y) = (-4.425 + 0.15 r, 5.175 + 0.15 c)`` for cell
``(r, c)``; a containment box of 96 more cylinders closes the corridor behind the field; beyond
``y = 9.6`` the world is open. The robot starts at (-2.25, 3.0) facing +y and must get within 1 m
of (-2.25, 13.0) within 100 s; the first collision ends the run.

Rasterisation: every cylinder is drawn into an :class:`~dsmpepc_nlp.core.grid.OccupancyGrid` of
``resolution`` 0.05 m (default) as the cells whose square overlaps its disk. The grid's cell
centres are placed on the cylinder centres, so a cylinder becomes the 3 x 3 block of cells that is
its bounding square: exact along the axes, at most 0.031 m too large on the diagonals (the grid
never under-states an obstacle), and the bilinear signed distance adds at most half a cell.
That is well below the ~0.15 m a Jackal has on each side in the narrowest BARN passages
(C-space cells keep 2 free cells, 0.30 m, around the path), while the grid stays small
(110 x 320 cells with the 0.5 m margin around the field and the open area up to the goal), so the
signed distance and the navigation function cost milliseconds.

Robot: the challenge's Clearpath Jackal, 0.508 m long and 0.430 m wide, covered by three circles
of radius 0.231 m at x = -0.169, 0, +0.169 m along the body: each covers a 0.169 x 0.430 m slice
of the rectangle exactly (its half-diagonal). Speed limit 1.0 m/s by default (the Jackal allows
2.0 m/s; the score's reference speed is 2 m/s, so a run at 1 m/s scores at most about 0.45).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..core.config import PlannerConfig, RobotConfig, RobotState
from ..core.errors import InputError
from ..core.world import OccupancyGrid
from ..sim.metrics import episode_metrics
from ..sim.simulate import simulate
from ..sim.types import Agent, FixedGoal, Scenario
from ..viz import figures
from .params import config_meta, planner_config, robot_with, solver_of
from .results import ResultTable, keep_failure
from .runner import mean, outcome_rates, plan_time_summary, run_all

CELL = 0.15
"""BARN cell side and cylinder diameter, m."""
CYLINDER_RADIUS = 0.075
"""Radius of every BARN cylinder, m."""
GRID_SHAPE = (30, 30)
"""Shape of ``grid_N.npy``."""
ORIGIN_X, ORIGIN_Y = -4.425, 5.175
"""World position of the centre of the cylinder of cell (0, 0), m."""
FIELD_END_Y = 9.6
"""Beyond this y the world is open ground, m."""
START = (-2.25, 3.0, math.pi / 2)
"""Start pose (x m, y m, heading rad): run.py's INIT_POSITION."""
GOAL = (-2.25, 13.0)
"""Goal, m: the start plus run.py's relative GOAL_POSITION (0, 10)."""
SUCCESS_RADIUS = 1.0
"""Success radius, m."""
TIME_LIMIT = 100.0
"""Time limit, s."""
REFERENCE_SPEED = 2.0
"""Speed that turns the reference path length into ``optimal_time``, m/s."""
JACKAL_LENGTH, JACKAL_WIDTH = 0.508, 0.430
"""Clearpath Jackal body, m."""
DEFAULT_V_LIMIT = 1.0
"""Speed limit used for BARN runs unless told otherwise, m/s (our choice; the Jackal's is 2)."""
DEFAULT_RESOLUTION = 0.05
"""Cell side of the rasterised map, m (see the module docstring)."""
MAP_MARGIN = 0.5
"""Free margin drawn around the field so the signed distance is exact near it, m."""
TEST_WORLDS = tuple(range(0, 300, 6))
"""The challenge's local test protocol: worlds 0, 6, ..., 294."""
METRIC_NAMES = ("closest_distance", "avg_visibility", "dispersion", "char_dimension",
                "tortuosity")
"""The five difficulty metrics of ``metrics_N.npy``, in file order."""


# ---------------------------------------------------------------------------------------------
# geometry


def cell_to_world(rows, cols) -> np.ndarray:
    """Cylinder centre (x, y) (m) of grid cells ``(rows, cols)``; shape (..., 2)."""
    rows, cols = np.asarray(rows, dtype=float), np.asarray(cols, dtype=float)
    return np.stack([ORIGIN_X + CELL * rows, ORIGIN_Y + CELL * cols], axis=-1)


def scorer_cell_to_world(rows, cols) -> np.ndarray:
    """The challenge scorer's own (approximate) mapping, used only for the path length."""
    rows, cols = np.asarray(rows, dtype=float), np.asarray(cols, dtype=float)
    return np.stack([0.15 * rows - 4.575, 0.15 * cols + 5.075], axis=-1)


def containment_centres() -> np.ndarray:
    """The 96 containment cylinders (m): back wall at y = 0.075 and two side walls, (96, 2)."""
    xs = ORIGIN_X + CELL * np.arange(30)
    ys = 0.225 + CELL * np.arange(33)
    back = np.stack([xs, np.full(30, 0.075)], axis=1)
    left = np.stack([np.full(33, ORIGIN_X), ys], axis=1)
    right = np.stack([np.full(33, ORIGIN_X + CELL * 29), ys], axis=1)
    return np.concatenate([back, left, right])


def cylinder_centres(grid: np.ndarray) -> np.ndarray:
    """Centres (m) of the field's cylinders plus the containment box, (n, 2)."""
    rows, cols = np.nonzero(np.asarray(grid))
    return np.concatenate([cell_to_world(rows, cols), containment_centres()])


def rasterise(centres, radius=CYLINDER_RADIUS, resolution=DEFAULT_RESOLUTION,
              bounds=(-4.5 - MAP_MARGIN, 0.0 - MAP_MARGIN, 0.0 + MAP_MARGIN,
                      GOAL[1] + 2.0)) -> OccupancyGrid:
    """Disks of ``radius`` at ``centres`` as the cells whose square overlaps a disk.

    ``bounds = (xmin, ymin, xmax, ymax)`` (m) are snapped outward to whole cells; the grid
    origin is ``(xmin, ymin)``.
    """
    xmin, ymin, xmax, ymax = (float(b) for b in bounds)
    nx = int(math.ceil((xmax - xmin) / resolution - 1e-9))
    ny = int(math.ceil((ymax - ymin) / resolution - 1e-9))
    occupied = np.zeros((ny, nx), dtype=bool)
    reach = int(math.ceil(radius / resolution)) + 1
    half = resolution / 2
    for cx, cy in np.asarray(centres, dtype=float).reshape(-1, 2):
        ix0 = int(math.floor((cx - xmin) / resolution))
        iy0 = int(math.floor((cy - ymin) / resolution))
        ix = np.arange(ix0 - reach, ix0 + reach + 1)
        iy = np.arange(iy0 - reach, iy0 + reach + 1)
        ix, iy = ix[(ix >= 0) & (ix < nx)], iy[(iy >= 0) & (iy < ny)]
        gx = xmin + (ix + 0.5) * resolution
        gy = ymin + (iy + 0.5) * resolution
        # Distance from the disk centre to the nearest point of each cell square.
        dx = np.maximum(np.abs(gx - cx) - half, 0.0)
        dy = np.maximum(np.abs(gy - cy) - half, 0.0)
        hit = dx[None, :] ** 2 + dy[:, None] ** 2 < radius**2 - 1e-12
        occupied[np.ix_(iy, ix)] |= hit
    return OccupancyGrid(occupied, resolution, (xmin, ymin))


def jackal_robot(v_limit: float = DEFAULT_V_LIMIT, **changes) -> RobotConfig:
    """The Jackal as three circles covering its 0.508 x 0.430 m rectangle (module docstring)."""
    slice_ = JACKAL_LENGTH / 3
    radius = math.hypot(slice_ / 2, JACKAL_WIDTH / 2)
    footprint = tuple((dx, 0.0, radius) for dx in (-slice_, 0.0, slice_))
    return RobotConfig(v_limit=v_limit, footprint=footprint, **changes)


# ---------------------------------------------------------------------------------------------
# files


def _load_npy(path: Path, what: str) -> np.ndarray:
    try:
        return np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise InputError(f"{what} file {str(path)!r}: does not exist") from None
    except (OSError, ValueError) as exc:
        raise InputError(f"{what} file {str(path)!r}: not a NumPy .npy array ({exc})") from None


def load_grid(path) -> np.ndarray:
    """``grid_N.npy``: a (30, 30) array of 0/1; ValueError naming the file otherwise."""
    path = Path(path)
    grid = _load_npy(path, "BARN grid")
    if grid.shape != GRID_SHAPE:
        raise InputError(f"BARN grid file {str(path)!r}: shape {grid.shape}: expected {GRID_SHAPE}")
    if not np.issubdtype(grid.dtype, np.number) or not np.all((grid == 0) | (grid == 1)):
        raise InputError(f"BARN grid file {str(path)!r}: values must be 0 or 1 "
                         f"(dtype {grid.dtype})")
    return grid.astype(np.int64)


def load_path(path) -> np.ndarray:
    """``path_N.npy``: (n, 2) integer (row, col) cells, n >= 2; ValueError otherwise."""
    path = Path(path)
    cells = _load_npy(path, "BARN path")
    if cells.ndim != 2 or cells.shape[1] != 2 or cells.shape[0] < 2 \
            or not np.issubdtype(cells.dtype, np.number) or not np.all(np.isfinite(cells)):
        raise InputError(f"BARN path file {str(path)!r}: shape {cells.shape}, dtype "
                         f"{cells.dtype}: expected (n, 2) finite (row, col) with n >= 2")
    return cells


def load_metrics(path) -> np.ndarray | None:
    """``metrics_N.npy``: the five difficulty metrics, or None when the file is absent."""
    path = Path(path)
    if not path.exists():
        return None
    values = _load_npy(path, "BARN metrics")
    if values.shape != (len(METRIC_NAMES),):
        raise InputError(f"BARN metrics file {str(path)!r}: shape {values.shape}: expected (5,)")
    return values.astype(float)


def reference_path_length(cells) -> float:
    """The scorer's path length (m): start + path cells (scorer mapping) + goal, summed."""
    points = np.concatenate([[START[:2]], scorer_cell_to_world(cells[:, 0], cells[:, 1]),
                             [GOAL]])
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


def score(success: bool, actual_time: float, path_length: float, low: float = 2.0) -> float:
    """Challenge score ``1[success] * T_opt / clip(t, low T_opt, 8 T_opt)``, T_opt = L / 2 m/s:
    ``low`` 2 since 2024 (at most 0.5), 4 before (at most 0.25, ``score_2020`` in the table)."""
    if not success:
        return 0.0
    optimal = path_length / REFERENCE_SPEED
    return float(optimal / np.clip(actual_time, low * optimal, 8 * optimal))


@dataclass(frozen=True)
class BarnWorld:
    """One BARN world: its index, the obstacle grid, the rasterised map and reference data."""

    index: int
    grid: np.ndarray
    occupancy: OccupancyGrid
    path_length: float
    metrics: np.ndarray | None


def world_files(data_dir, index: int) -> dict:
    """Paths of world ``index`` in a BARN folder (``grid_files/``, ``path_files/``, ...)."""
    data_dir = Path(data_dir)
    return {"grid": data_dir / "grid_files" / f"grid_{index}.npy",
            "path": data_dir / "path_files" / f"path_{index}.npy",
            "metrics": data_dir / "metrics_files" / f"metrics_{index}.npy"}


def load_world(data_dir, index: int, resolution: float = DEFAULT_RESOLUTION) -> BarnWorld:
    """World ``index`` of the BARN folder ``data_dir``, rasterised at ``resolution`` (m)."""
    files = world_files(data_dir, index)
    grid = load_grid(files["grid"])
    length = reference_path_length(load_path(files["path"]))
    metrics = load_metrics(files["metrics"])
    occupancy = rasterise(cylinder_centres(grid), CYLINDER_RADIUS, resolution)
    return BarnWorld(index, grid, occupancy, length, metrics)


def scenario(world: BarnWorld, robot: RobotConfig | None = None, time_limit=TIME_LIMIT):
    """The challenge run on ``world`` as a :class:`~dsmpepc_nlp.sim.types.Scenario`."""
    agent = Agent("jackal", RobotState(*START), FixedGoal(GOAL, SUCCESS_RADIUS),
                  robot=robot or jackal_robot())
    return Scenario(name=f"barn-{world.index}", agents=(agent,), grid=world.occupancy,
                    duration=float(time_limit), description="BARN Challenge world")


# ---------------------------------------------------------------------------------------------
# runner


@dataclass(frozen=True)
class BarnSettings:
    """Everything a BARN run depends on besides the world index (stored with the results)."""

    data: str
    variant: str = "ds-mpepc"
    solver: str = "nlp"
    v_limit: float = DEFAULT_V_LIMIT
    resolution: float = DEFAULT_RESOLUTION
    time_limit: float = TIME_LIMIT
    n_samples: int | None = None
    overrides: tuple = ()
    """``(name, value)`` pairs replacing configuration fields, as for ``sweep --param``
    (``sigma_static`` for a cost field, ``part.field`` for another part)."""
    preset: str = "product"
    """``product`` or ``paper`` (:data:`~dsmpepc_nlp.bench.params.PRESETS`)."""
    sensing: str = "oracle"
    """What the robot senses (``--sensing``): a built-in profile or a profile file
    (:mod:`dsmpepc_nlp.sim.sensing`); ``oracle``, the truth, by default."""
    time_budget: float | str | None = "auto"
    """Each plan's time budget (``--time-budget``; ``SolverConfig.time_budget``)."""

    def meta(self) -> dict:
        return {"benchmark": "barn", "variant": self.variant, "solver": self.solver,
                "v_limit": self.v_limit, "resolution": self.resolution,
                "time_limit": self.time_limit, "n_samples": self.n_samples,
                **config_meta(self.preset, self.overrides, self.sensing, self.time_budget)}

    def config(self) -> PlannerConfig:
        """The variant under the preset with the Jackal body and the overrides."""
        config = planner_config(self, self.variant)
        return replace(config, robot=robot_with(jackal_robot(self.v_limit), self.overrides))


def run_world(index: int, settings: BarnSettings, out_dir=None) -> dict:
    """Run one world; the result row (never raises: an exception becomes ``outcome = error``).
    An unsuccessful run's episode is kept in ``out_dir`` (:func:`~.results.keep_failure`)."""
    row = {"world": int(index), "variant": settings.variant, "solver": settings.solver}
    started = time.perf_counter()
    try:
        world = load_world(settings.data, index, settings.resolution)
        config = settings.config()
        robot = config.robot
        episode = simulate(scenario(world, robot, settings.time_limit), config,
                           solver_of(settings),
                           np.random.default_rng(index), record_trajectories=False,
                           sensing=settings.sensing)
        m = episode_metrics(episode)[0]
        success = m["outcome"] == "success"
        row.update(
            outcome=m["outcome"], time=m["outcome_time"],
            score=score(success, m["outcome_time"], world.path_length),
            score_2020=score(success, m["outcome_time"], world.path_length, low=4.0),
            path_length=m["path_length"], reference_path_length=world.path_length,
            min_static_clearance=m["min_static_clearance"],
            plan_time_median=m["plan_time_median"], plan_time_p95=m["plan_time_p95"],
            plan_time_p99=m["plan_time_p99"], plan_time_max=m["plan_time_max"],
            plans_out_of_time=m["plans_out_of_time"], fallback_plans=m["fallback_plans"],
            cycles=m["cycles"],
            episode_file=keep_failure(episode, out_dir, f"barn-{index}-{settings.variant}-"
                                                        f"{settings.solver}"))
        metrics = world.metrics
        for k, name in enumerate(METRIC_NAMES):
            row[name] = float(metrics[k]) if metrics is not None else None
    except Exception as exc:  # recorded, not dropped: the table says what failed
        row.update(outcome="error", score=0.0, score_2020=0.0,
                   message=f"{type(exc).__name__}: {exc}")
    row["wall_time"] = time.perf_counter() - started
    return row


def summarise(rows) -> dict:
    """Rates and means over result rows (``error`` rows count as failures); plan times:
    :func:`~dsmpepc_nlp.bench.runner.plan_time_summary` over the worlds."""
    return {"worlds": len(rows), **outcome_rates(r["outcome"] for r in rows),
            "mean_score": mean(rows, "score"),
            "mean_score_2020": mean(rows, "score_2020") if all("score_2020" in r for r in rows)
            else None,
            "mean_time_success": mean(rows, "time", lambda r: r["outcome"] == "success"),
            **plan_time_summary(rows)}


def run_benchmark(settings: BarnSettings, worlds, out_dir, *, workers: int | None = None,
                  scheduler=None, resume=False, overwrite=False,
                  progress=True) -> tuple[list, dict]:
    """Run ``worlds`` into ``out_dir/barn.{csv,json}`` (+ ``barn.png``); rows and summary.

    Worlds already in the table are skipped when ``resume`` is True. ``progress``: where the
    status line and bar go (True: stderr, a stream, or None: nowhere).
    """
    table = ResultTable(out_dir, "barn", ("world", "variant", "solver"), settings.meta(),
                        resume=resume, overwrite=overwrite)
    for w in worlds:  # fail early on a missing folder rather than inside every worker
        if not table.done((w, settings.variant, settings.solver)) \
                and not world_files(settings.data, w)["grid"].exists():
            raise InputError(f"BARN data {settings.data!r}: no grid_files/grid_{w}.npy")
    run_all(run_world, [(w, settings, str(out_dir)) for w in worlds], table, label="barn",
            key=lambda task: (task[0], settings.variant, settings.solver), workers=workers,
            scheduler=scheduler, progress=progress,
            describe=lambda row: f"world {row['world']}: {row['outcome']}")
    rows = [r for r in table.rows if r["variant"] == settings.variant
            and r["solver"] == settings.solver and r["world"] in set(worlds)]
    rows.sort(key=lambda r: r["world"])
    summary = summarise(rows)
    figures("results").outcome_figure(rows, Path(out_dir) / "barn.png",
                   title=f"BARN, {settings.variant} ({settings.solver}), "
                         f"success {summary['success_rate']:.2f}")
    return rows, summary
