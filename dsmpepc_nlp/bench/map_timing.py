"""Plan time on a map that changes every cycle, beside the same plans on the map known in advance
(``dsmpepc bench --lidar-map``).

The crowded demo scene's cycles (:func:`~dsmpepc_nlp.bench.scenes.demo_cycles`) are planned
twice, in turn, by two planners of the same configuration: once on the scene's own map, once on
a map a simulated lidar builds as the robot goes (the ``lidar`` profile's 720-beam scan from each
cycle's pose into the product's :class:`~dsmpepc_nlp.perception.LocalMap`, so the grid is a new
one every cycle, handed out as an update of the last). The people are the same in both. The
ratio of each pair (lidar over known) is the cost of planning on a changing map: the signed
distance and navigation function of each new grid, repaired from the last.
"""

from __future__ import annotations

import time

import numpy as np

from ..core.config import PlannerConfig
from ..core.solver_config import SolverConfig
from ..core.world import World
from ..sim.senses import Senses
from ..sim.sensing import BUILTIN_PROFILES
from .scenes import demo_cycles


def lidar_map_timing(n_cycles: int = 20, seed: int = 0, config: PlannerConfig | None = None,
                     solver: SolverConfig | None = None) -> dict:
    """Plan time (ms) on the known map and on a lidar map that changes every cycle, each
    cycle's two plans one after the other; medians, 95th percentiles and the median of the
    per-cycle ratios, the lidar map's cells that changed each cycle, and the outcome of
    ``prepare`` (neither planner compiles in a timed plan)."""
    from ..solve.planner import Planner

    config = PlannerConfig() if config is None else config
    solver = SolverConfig() if solver is None else solver
    cycles = demo_cycles(config, n_cycles, seed)
    senses = Senses(BUILTIN_PROFILES["lidar"], config, cycles[0][1].grid,
                    np.random.default_rng(seed))
    known, sensed = Planner(config, solver), Planner(config, solver)
    objects = max(len(world.obstacles) for _, world, _ in cycles)
    for planner in (known, sensed):
        planner.prepare(max_objects=objects)
    times, changed, last = {"known": [], "lidar": []}, [], None
    for k, (state, world, goal) in enumerate(cycles):
        pose = np.array([state.x, state.y, state.phi, state.v, state.omega])
        people = list(world.obstacles)
        grid = senses.mapped(k * config.horizon.dt, pose, pose,
                             np.concatenate([o.centers for o in people]).reshape(-1, 2),
                             np.concatenate([o.radii for o in people]), [], people)
        if last is not None:
            changed.append(_changed(last, grid))
        last = grid
        for name, planner, seen in (("known", known, world),
                                    ("lidar", sensed, World(grid, world.obstacles))):
            started = time.perf_counter()
            planner.plan(state, seen, goal)
            times[name].append(1e3 * (time.perf_counter() - started))
    ratios = np.array(times["lidar"]) / np.array(times["known"])
    return {"cycles": n_cycles,
            **{f"{name}_median_ms": float(np.median(t)) for name, t in times.items()},
            **{f"{name}_p95_ms": float(np.percentile(t, 95)) for name, t in times.items()},
            "ratio_median": float(np.median(ratios)),
            "ratio_of_medians": float(np.median(times["lidar"]) / np.median(times["known"])),
            "lidar_cells_changed_median": float(np.median(changed)) if changed
            else float("nan")}


def _changed(before, after) -> int:
    """Cells of ``after`` that differ from ``before``'s cell at the same world position (a
    cell that scrolled in counts as changed)."""
    shift = np.round((after.origin - before.origin) / after.resolution).astype(int)
    ny, nx = after.shape
    ys, xs = np.mgrid[0:ny, 0:nx]
    by, bx = ys + shift[1], xs + shift[0]
    inside = (by >= 0) & (by < before.shape[0]) & (bx >= 0) & (bx < before.shape[1])
    old = np.zeros((ny, nx), dtype=bool)
    old[inside] = before.occupied[by[inside], bx[inside]]
    return int(np.sum((after.occupied != old) | ~inside))


def format_lidar_table(result: dict) -> str:
    """The result of :func:`lidar_map_timing` as a few lines."""
    return "\n".join([
        f"plan on a lidar map that changes every cycle, {result['cycles']} cycles of the "
        "crowded demo scene (each cycle's two plans in turn)",
        f"  known map:  median {result['known_median_ms']:.1f} ms, p95 "
        f"{result['known_p95_ms']:.1f} ms",
        f"  lidar map:  median {result['lidar_median_ms']:.1f} ms, p95 "
        f"{result['lidar_p95_ms']:.1f} ms ({result['lidar_cells_changed_median']:.0f} cells "
        "changed a cycle, median)",
        f"  ratio lidar / known: {result['ratio_median']:.2f} (median of the cycles' ratios), "
        f"{result['ratio_of_medians']:.2f} (ratio of the medians)"])


__all__ = ["format_lidar_table", "lidar_map_timing"]
