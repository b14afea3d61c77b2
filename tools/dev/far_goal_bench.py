"""What a far goal costs: the first plan on a fresh small map, goal inside it vs far away.

The navigation function lives on a bounded window (``core/navigation.py``), so a goal 10 km
away should cost about what a goal inside the map costs. This times the first plan (the
navigation function is built in it) and the navigation function alone, alternating the goals,
and reports medians, ratios and the traced memory peak of a plan.

Run from the repository root::

    python tools/dev/far_goal_bench.py              # 7 repetitions
    python tools/dev/far_goal_bench.py --reps 15
"""

from __future__ import annotations

import argparse
import statistics
import time
import tracemalloc

import numpy as np

from dsmpepc_nlp import OccupancyGrid, Planner, PlannerConfig, SolverConfig, World
from dsmpepc_nlp.core.config import RobotState

GOALS = {"inside": (1.9, 1.9), "100 m": (100.0, 100.0), "10 km": (1.0e4, 1.0e4)}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=7)
    args = parser.parse_args(argv)
    occupied = np.zeros((40, 40), dtype=bool)          # 2 x 2 m at 0.05 m, a short wall
    occupied[30:32, 10:30] = True
    grid = OccupancyGrid(occupied, 0.05)
    config = PlannerConfig()
    planner = Planner(config, SolverConfig.sampling())
    state = RobotState(0.3, 0.3, 0.0)
    planner.plan(state, World(grid), GOALS["inside"], dock=False)   # warm-up
    plans = {k: [] for k in GOALS}
    navs = {k: [] for k in GOALS}
    peaks = {k: [] for k in GOALS}
    for _ in range(args.reps):
        for name, goal in GOALS.items():
            planner.reset()
            tracemalloc.start()
            started = time.perf_counter()
            planner.plan(state, World(grid), goal, dock=False)      # fresh world: NF built
            plans[name].append(time.perf_counter() - started)
            peaks[name].append(tracemalloc.get_traced_memory()[1] / 1e6)
            tracemalloc.stop()
            started = time.perf_counter()
            World(grid).navigation(goal, config.robot.inflation_radius, near=(state.x, state.y),
                                   reach=config.reach)
            navs[name].append(time.perf_counter() - started)
    base = statistics.median(plans["inside"])
    for name in GOALS:
        plan = statistics.median(plans[name])
        print(f"{name:7s} first plan {plan * 1e3:7.1f} ms (x{plan / base:.2f}, "
              f"{(plan - base) * 1e3:+6.1f} ms)  navigation function "
              f"{statistics.median(navs[name]) * 1e3:6.1f} ms  traced peak "
              f"{statistics.median(peaks[name]):6.1f} MB")


if __name__ == "__main__":
    main()
