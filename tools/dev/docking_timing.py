"""What docking within the goal's region costs a plan: docking's time with and without it.

A robot 1 m from its goal with a person standing 0.8 m beside the goal (the straight way to
the goal point fails docking's test; a point of the 0.3 m region passes), facing the goal and
facing away from it (each region point then behind a turn in place). Times
:func:`~dsmpepc_nlp.solve.behaviours.docking.dock` over ``--plans`` fresh cycles each, the
median, with
``docking.region_points`` 0 and 8, side by side in one run::

    python tools/dev/docking_timing.py
    python tools/dev/docking_timing.py --plans 100 --json
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

from dsmpepc_nlp.core.config import DockingConfig, PlannerConfig, RobotState
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.solve.behaviours import docking
from dsmpepc_nlp.solve.exact import loader as exact
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator

GOAL = (3.0, 0.0)
TOLERANCE = 0.3
STATES = {"facing the goal": RobotState(2.0, 0.0, 0.0),
          "facing away": RobotState(2.0, 0.0, 3.1)}


def timed(state: RobotState, points: int, plans: int) -> dict:
    """Docking's median time (ms) over ``plans`` fresh cycles, and whether it docked."""
    world = World(obstacles=[DynamicObstacle.pedestrian((3.0, 0.8), (0.0, 0.0), 0.3)])
    config = PlannerConfig(docking=DockingConfig(region_points=points))
    times, docked = [], None
    for _ in range(plans):
        evaluator = Evaluator(Cycle.prepare(state, world, GOAL, config))
        started = time.perf_counter()
        docked = docking.dock(evaluator, config, TOLERANCE)
        times.append(time.perf_counter() - started)
    return {"median_ms": 1e3 * statistics.median(times), "docked": docked is not None}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plans", type=int, default=30)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    exact.kernel()           # the compiled kernel loaded first, as a running planner has it
    rows = [{"robot": name, "region_points": points, **timed(state, points, args.plans)}
            for name, state in STATES.items() for points in (0, 8)]
    if args.json:
        print(json.dumps(rows))
        return 0
    for row in rows:
        print(f"{row['robot']:16s} region_points {row['region_points']}: "
              f"{row['median_ms']:6.2f} ms, {'docked' if row['docked'] else 'not docked'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
