"""Heavy situations through the public ``Planner.plan``: is every plan back by its time budget?

Draws heavy situations (40-200 people round the robot, a noisy 20 x 20 m grid, a one- or
four-circle robot, half of them stalled so that the recovery stages run), plans each with the
IPOPT and the fast method, under the default budget and without one, and prints per row the
plans, median, p99 and maximum wall time, how many plans ran out of their budget and how many
came back later than the budget plus 10 ms. ``--load`` keeps a second process busy on another
core meanwhile (a robot's other work).

Run from the repository root::

    python tools/dev/deadline_check.py --situations 30 --load
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import multiprocessing
import time

import numpy as np

from dsmpepc_nlp import DynamicObstacle, OccupancyGrid, Planner, PlannerConfig, RobotState, World
from dsmpepc_nlp.core.config import RobotConfig
from dsmpepc_nlp.core.deadline import budget_seconds
from dsmpepc_nlp.core.solver_config import SolverConfig

LATE = 0.010
"""s: a plan later than its budget by more than this is late."""


def situation(rng, k: int):
    """One heavy situation: (config, state, world, goal)."""
    footprint = ((0.0, 0.0, 0.3),) if k % 2 == 0 else \
        tuple((x, 0.0, 0.2) for x in (-0.3, -0.1, 0.1, 0.3))
    config = dataclasses.replace(PlannerConfig(), robot=RobotConfig(footprint=footprint))
    occupied = rng.random((200, 200)) < 0.01                 # 20 x 20 m, 1 % noise
    occupied[:, :2] = occupied[:, -2:] = occupied[:2, :] = occupied[-2:, :] = True
    start = rng.uniform(6.0, 14.0, 2)
    ix, iy = (start / 0.1).astype(int)
    occupied[iy - 8:iy + 9, ix - 8:ix + 9] = False           # the robot starts clear
    n_people = int(rng.integers(40, 201))
    people = []
    while len(people) < n_people:
        p = rng.uniform(0.5, 19.5, 2)
        if np.hypot(*(p - start)) > 1.2:
            people.append(DynamicObstacle.pedestrian(p, rng.uniform(-1.2, 1.2, 2), 0.3))
    world = World(OccupancyGrid.from_array(occupied, 0.1), people)
    state = RobotState(*start, rng.uniform(-math.pi, math.pi), rng.uniform(0.0, 0.8), 0.0)
    goal = rng.uniform(1.0, 19.0, 2)
    return config, state, world, goal


def _busy(stop):
    x = 0.0
    while not stop.is_set():
        x = math.sin(x) + 1.0


def run(situations: int, seed: int, plans_each: int) -> list:
    rng = np.random.default_rng(seed)
    drawn = [situation(rng, k) for k in range(situations)]
    rows = []
    for name in ("nlp", "fast"):
        for budget in ("auto", None):
            times, cut, late = [], 0, 0
            planners = {}
            for config, state, world, goal in drawn:
                key = config.robot.footprint
                if key not in planners:
                    planners[key] = Planner(config, dataclasses.replace(
                        SolverConfig.named(name), time_budget=budget))
                    planners[key].prepare(12)
                planner = planners[key]
                planner.reset()
                seconds = budget_seconds(budget, config.horizon.dt)
                for _ in range(plans_each):     # later plans meet a stalled ladder
                    plan = planner.plan(state, world, goal)
                    times.append(plan.wall_time)
                    cut += bool(plan.cut)
                    late += plan.wall_time > seconds + LATE
            t = np.array(times) * 1e3
            rows.append({"solver": name, "budget": "none" if budget is None else budget,
                         "plans": len(t), "median_ms": float(np.median(t)),
                         "p99_ms": float(np.percentile(t, 99)), "max_ms": float(t.max()),
                         "out_of_time": cut, "late": late})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--situations", type=int, default=30)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plans", type=int, default=3, help="plans per situation")
    parser.add_argument("--load", action="store_true", help="a busy process meanwhile")
    args = parser.parse_args(argv)
    stop = multiprocessing.Event()
    busy = multiprocessing.Process(target=_busy, args=(stop,), daemon=True) if args.load \
        else None
    if busy is not None:
        busy.start()
    started = time.perf_counter()
    try:
        rows = run(args.situations, args.seed, args.plans)
    finally:
        stop.set()
    print(f"{'solver':6s} {'budget':6s} {'plans':>5s} {'median':>7s} {'p99':>7s} {'max':>7s} "
          f"{'out of time':>11s} {'late':>5s}   (ms; late: > budget + {LATE * 1e3:.0f} ms)")
    for r in rows:
        print(f"{r['solver']:6s} {str(r['budget']):6s} {r['plans']:5d} {r['median_ms']:7.1f} "
              f"{r['p99_ms']:7.1f} {r['max_ms']:7.1f} {r['out_of_time']:11d} {r['late']:5d}")
    print(f"({time.perf_counter() - started:.0f} s{', a busy process beside' if busy else ''})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
