"""What a changed map costs a plan: a grid built from scratch vs one updated from the last.

A robot drives 0 to 0.2 m per scan (0 to 4 cells), turning slowly, through random cylinders
(BARN-like clutter, kept off a corridor along its path). A 720-beam, 270-degree lidar with
1 cm range noise and a 10 m range feeds a :class:`~dsmpepc_nlp.perception.LocalMap` (20 x 20 m
at 0.05 m: 400 x 400 cells). After each scan the planner's two map products are computed for
the map's occupancy, both ways, in alternating order:

* full: ``OccupancyGrid.derived(...)`` (what ``LocalMap.grid()`` hands out), its
  ``signed_distance``, and its ``NavigationFunction`` to the goal (inflation 0.3 m, the
  default robot's; window the map plus 2 m, as ``World.navigation`` asks);
* update: ``OccupancyGrid.updated_from(previous, ...)`` and the same two.

The goal lies 9 m ahead and moves 8 m on once the robot is within 2 m of it (a new goal has no
previous paths: those steps rebuild them and are counted). Prints the medians and 95th
percentiles (wall clock, ms; the update's thread CPU time too: a shared machine's wall clock
counts other processes' time) and the largest differences between the two ways::

    python tools/dev/bench_map_updates.py
    python tools/dev/bench_map_updates.py --steps 200 --json

``--first`` times a local map's first grid instead (each drive's first scan, one drive a
seed): from scratch, against the local map's own way (:meth:`SensedGrid.build` without a
previous grid: an update of an empty window)::

    python tools/dev/bench_map_updates.py --first --steps 20
    python tools/dev/bench_map_updates.py --first --steps 20 --density 0   # an open world
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from dsmpepc_nlp.core.grid import OccupancyGrid
from dsmpepc_nlp.core.navigation import NavigationFunction
from dsmpepc_nlp.perception import LaserScan, LocalMap, LocalMapConfig
from dsmpepc_nlp.perception.sensed_grid import SensedGrid

BEAMS = 720
FIELD_OF_VIEW = 1.5 * np.pi
"""270 degrees (rad)."""
LIDAR_RANGE = 10.0
"""Returns beyond this (m) are dropped: no return."""
INFLATION = 0.3
"""The navigation function's inflation radius (m): the default robot's largest circle."""
REACH = 5.0
"""How far a trajectory goes (m): the default planner's horizon times its speed limit."""


def cylinders(rng, density):
    """Cylinder centres (m) and radii (m) over the drive, none within 0.8 m of its corridor."""
    count = int(density * 100.0 * 60.0)
    centres = rng.uniform([-20.0, -30.0], [80.0, 30.0], (count, 2))
    radii = rng.uniform(0.1, 0.4, count)
    keep = np.abs(centres[:, 1] - 0.5 * np.sin(0.05 * centres[:, 0])) > radii + 0.8
    return centres[keep], radii[keep]


def ranges(pose, headings, centres, radii, rng):
    """Lidar ranges (m) from ``pose`` along ``headings`` to the cylinders, inf beyond range."""
    if not len(radii):
        return np.full(len(headings), np.inf)
    direction = np.stack([np.cos(headings), np.sin(headings)], -1)
    rel = centres - pose[:2]
    along = direction @ rel.T
    across2 = np.sum(rel ** 2, axis=1)[None] - along ** 2
    with np.errstate(invalid="ignore"):
        entry = along - np.sqrt(radii[None] ** 2 - across2)
    hit = (across2 <= radii[None] ** 2) & (entry >= 0.0)
    found = np.where(hit, entry, np.inf).min(axis=1) + rng.normal(0.0, 0.01, len(headings))
    return np.where(found > LIDAR_RANGE, np.inf, found)


def drive(steps, seed, density):
    """``(grid, pose)`` after each scan along a random drive."""
    rng = np.random.default_rng(seed)
    centres, radii = cylinders(rng, density)
    local_map = LocalMap(LocalMapConfig())
    angles = np.linspace(-FIELD_OF_VIEW / 2, FIELD_OF_VIEW / 2, BEAMS)
    x = 0.0
    for i in range(steps):
        x += rng.uniform(0.0, 0.2)
        pose = np.array([x, 0.5 * np.sin(0.05 * x), 0.3 * np.sin(0.03 * i)])
        scan = ranges(pose, pose[2] + angles, centres, radii, rng)
        local_map.update(LaserScan.from_angles(scan, angles, 0.1, 30.0, pose, 0.1 * i))
        yield local_map.grid(), pose


def _timed(make, goal, pose):
    """``(grid, navigation, ms signed distance, ms navigation, cpu ms of both)``."""
    started, cpu = time.perf_counter(), time.thread_time()
    grid = make()
    _ = grid.signed_distance
    middle = time.perf_counter()
    nav = NavigationFunction(goal, grid, INFLATION, 2.0, pose[:2], REACH)
    ended = time.perf_counter()
    return (grid, nav, 1e3 * (middle - started), 1e3 * (ended - middle),
            1e3 * (time.thread_time() - cpu))


def changes(previous, grid):
    """``(shift, changed)``: whole cells the window moved (Chebyshev) and cells whose
    occupancy differs from the previous grid's at the same place (cells new to the window
    counted when occupied, cells gone when they were)."""
    sx, sy = np.rint((grid.origin - previous.origin) / grid.resolution).astype(int)
    before = np.zeros_like(grid.occupied)
    ny, nx = grid.shape
    part = np.s_[max(0, -sy):min(ny, ny - sy), max(0, -sx):min(nx, nx - sx)]
    ys, xs = part
    before[part] = previous.occupied[ys.start + sy:ys.stop + sy, xs.start + sx:xs.stop + sx]
    gone = int(previous.occupied.sum()) - int(before.sum())
    return max(abs(sx), abs(sy)), int(np.count_nonzero(before != grid.occupied)) + gone


def run(steps, warmup, seed, density) -> dict:
    """Both ways over the drive: per-step milliseconds and the largest differences."""
    rows, goal, previous, served = [], np.array([9.0, 0.0]), None, None
    worst_sd = worst_nav = 0.0
    for i, (grid, pose) in enumerate(drive(warmup + steps, seed, density)):
        new_goal = np.hypot(*(goal - pose[:2])) < 2.0
        if new_goal:
            goal = goal + [8.0, 0.0]
        args = (grid.occupied, grid.origin)
        ways = {"full": lambda a=args, r=grid.resolution: OccupancyGrid.derived(a[0], r, a[1])}
        if previous is not None:
            ways["update"] = lambda a=args, p=previous: OccupancyGrid.updated_from(p, *a)
        results = {}
        for name in (sorted(ways) if i % 2 else sorted(ways, reverse=True)):
            results[name] = _timed(ways[name], goal, pose)
        if "update" in results and i >= warmup:
            full, update = results["full"], results["update"]
            worst_sd = max(worst_sd, float(np.max(np.abs(full[0].signed_distance
                                                         - update[0].signed_distance))))
            worst_nav = max(worst_nav, float(np.max(np.abs(full[1].values - update[1].values))))
            rows.append((*full[2:4], *update[2:5], *changes(served, grid), new_goal))
        previous = results.get("update", results["full"])[0]
        served = grid
    return _summary(np.array(rows, dtype=float), worst_sd, worst_nav)


def run_first(steps, seed, density) -> dict:
    """A fresh drive's first grid, ``steps`` drives: from scratch and as the local map builds
    it, alternated; per-way milliseconds and the largest differences."""
    rows, worst_sd, worst_nav = [], 0.0, 0.0
    for i in range(steps):
        grid, pose = next(drive(1, seed + i, density))
        goal = pose[:2] + [9.0, 0.0]
        ways = {"full": lambda g=grid: OccupancyGrid.derived(g.occupied, g.resolution, g.origin),
                "first": lambda g=grid: SensedGrid.build(g.occupied, g.resolution, g.origin,
                                                        np.zeros(g.shape, dtype=bool))}
        results = {name: _timed(ways[name], goal, pose)
                   for name in (sorted(ways) if i % 2 else sorted(ways, reverse=True))}
        full, first = results["full"], results["first"]
        worst_sd = max(worst_sd, float(np.max(np.abs(full[0].signed_distance
                                                     - first[0].signed_distance))))
        worst_nav = max(worst_nav, float(np.max(np.abs(full[1].values - first[1].values))))
        rows.append((*full[2:4], *first[2:4], int(grid.occupied.sum())))
    full_sd, full_nav, sd, nav, marked = np.array(rows, dtype=float).T
    return {"drives": steps, "marked_cells": _stats(marked),
            "full_ms": {"signed_distance": _stats(full_sd), "navigation": _stats(full_nav),
                        "both": _stats(full_sd + full_nav)},
            "first_ms": {"signed_distance": _stats(sd), "navigation": _stats(nav),
                         "both": _stats(sd + nav)},
            "largest_difference_m": {"signed_distance": worst_sd, "navigation": worst_nav}}


def report_first(result) -> str:
    """:func:`run_first`'s result as a table."""
    full, first = result["full_ms"], result["first_ms"]
    lines = [f"first grids of {result['drives']} drives, 400 x 400 cells at 0.05 m, marked "
             f"cells median {result['marked_cells']['median']:.0f}",
             f"{'ms (wall clock)':22s} {'full median':>11s} {'p95':>8s}   "
             f"{'first median':>12s} {'p95':>8s}"]
    for key, label in (("signed_distance", "signed distance"), ("navigation", "navigation"),
                       ("both", "both")):
        lines.append(f"{label:22s} {full[key]['median']:11.2f} {full[key]['p95']:8.2f}   "
                     f"{first[key]['median']:12.2f} {first[key]['p95']:8.2f}")
    worst = result["largest_difference_m"]
    lines.append(f"largest difference: signed distance {worst['signed_distance']:.3g} m, "
                 f"navigation function {worst['navigation']:.3g} m")
    return "\n".join(lines)


def _stats(values) -> dict:
    return {"median": float(np.median(values)), "p95": float(np.percentile(values, 95))}


def _summary(rows, worst_sd, worst_nav) -> dict:
    full_sd, full_nav, sd, nav, cpu, shift, changed, new_goal = rows.T
    return {
        "steps": len(rows), "cells": [400, 400], "new_goals": int(new_goal.sum()),
        "shift_cells": _stats(shift), "changed_cells": _stats(changed),
        "full_ms": {"signed_distance": _stats(full_sd), "navigation": _stats(full_nav),
                    "both": _stats(full_sd + full_nav)},
        "update_ms": {"signed_distance": _stats(sd), "navigation": _stats(nav),
                      "both": _stats(sd + nav), "both_cpu": _stats(cpu)},
        "largest_difference_m": {"signed_distance": worst_sd, "navigation": worst_nav},
    }


def report(result) -> str:
    """The result as a table."""
    def cell(stats):
        return f"{stats['median']:8.2f} {stats['p95']:8.2f}"

    full, update = result["full_ms"], result["update_ms"]
    lines = [f"{result['cells'][0]} x {result['cells'][1]} cells at 0.05 m, {result['steps']} "
             f"steps ({result['new_goals']} with a new goal); shift median "
             f"{result['shift_cells']['median']:.0f} cells, changed cells median "
             f"{result['changed_cells']['median']:.0f} (p95 "
             f"{result['changed_cells']['p95']:.0f})",
             f"{'ms (wall clock)':22s} {'full median':>11s} {'p95':>6s}   "
             f"{'update median':>13s} {'p95':>6s}"]
    for key, label in (("signed_distance", "signed distance"), ("navigation", "navigation"),
                       ("both", "both")):
        lines.append(f"{label:22s} {cell(full[key])}   {cell(update[key])}")
    lines.append(f"{'both, thread CPU time':22s} {'':17s}   {cell(update['both_cpu'])}")
    worst = result["largest_difference_m"]
    lines.append(f"largest difference: signed distance {worst['signed_distance']:.3g} m, "
                 f"navigation function {worst['navigation']:.3g} m")
    return "\n".join(lines)


def main(argv=None) -> None:
    """Run the benchmark and print its numbers."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=60, help="timed steps (default 60)")
    parser.add_argument("--warmup", type=int, default=5, help="untimed steps first (default 5)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--density", type=float, default=0.15,
                        help="cylinders per square metre (default 0.15)")
    parser.add_argument("--first", action="store_true",
                        help="time a local map's first grid, one drive a step")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    if args.first:
        result = run_first(args.steps, args.seed, args.density)
        print(json.dumps(result) if args.json else report_first(result))
        return
    result = run(args.steps, args.warmup, args.seed, args.density)
    print(json.dumps(result) if args.json else report(result))


if __name__ == "__main__":
    main()
