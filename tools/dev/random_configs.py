"""Random robot shapes and settings through the public ``Planner.plan``: how long each call takes.

Every call builds a planner for a new random configuration (footprint of 1-3 circles, speed
limits, weights, uncertainties, ``s_ttc``, temperatures) in this one process, as a robot's
control loop that changes its configuration would, and plans once on a random scene (a small
map and a few pedestrians). With the default ``compile="background"`` a structure that is not
compiled yet is answered by the sampler while its library compiles in a child process; a
changed number compiles nothing. Prints one line per call and the summary.

Run from the repository root::

    python tools/dev/random_configs.py --calls 40 --seed 0
    python tools/dev/random_configs.py --calls 40 --seed 0 --json out/random_configs.json
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from dsmpepc_nlp import (
    DynamicObstacle,
    OccupancyGrid,
    Planner,
    PlannerConfig,
    RobotState,
    World,
)
from dsmpepc_nlp.core.config import RobotConfig
from dsmpepc_nlp.core.cost_config import CostConfig, SmoothingConfig


def random_config(rng) -> PlannerConfig:
    n_circles = int(rng.integers(1, 4))
    radius = float(rng.uniform(0.15, 0.35))
    spacing = float(rng.uniform(0.1, 0.3))
    footprint = tuple(((i - (n_circles - 1) / 2) * spacing, 0.0, radius)
                      for i in range(n_circles))
    robot = RobotConfig(v_limit=float(rng.uniform(0.5, 1.5)),
                        omega_limit=float(rng.uniform(1.0, 2.0)), footprint=footprint)
    cost = CostConfig(sigma_static=float(rng.uniform(0.03, 0.15)),
                      sigma_dynamic=float(rng.uniform(0.1, 0.3)),
                      s_ttc=float(rng.uniform(0.2, 0.8)), a=float(rng.uniform(0.3, 0.9)),
                      c_collision=float(rng.uniform(0.05, 0.3)))
    smoothing = SmoothingConfig().scaled(float(rng.uniform(0.5, 2.0)))
    return PlannerConfig(robot=robot, cost=cost, smoothing=smoothing)


def random_scene(rng):
    occupied = np.zeros((80, 80), dtype=bool)
    occupied[:, :2] = occupied[:, -2:] = occupied[:2, :] = occupied[-2:, :] = True
    for _ in range(4):
        x, y = rng.integers(10, 70, 2)
        occupied[y:y + 6, x:x + 6] = True
    occupied[36:44, 6:14] = False
    grid = OccupancyGrid(occupied, resolution=0.1, origin=(0.0, 0.0))
    people = [DynamicObstacle.pedestrian(tuple(rng.uniform(2.0, 6.0, 2)),
                                         tuple(rng.uniform(-0.6, 0.6, 2)))
              for _ in range(int(rng.integers(0, 6)))]
    return World(grid, people), RobotState(1.0, 4.0, 0.0), np.array([7.0, 4.0])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=None, help="also write the rows as JSON here")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    rows = []
    for i in range(args.calls):
        config = random_config(rng)
        world, state, goal = random_scene(rng)
        started = time.perf_counter()
        plan = Planner(config).plan(state, world, goal)
        seconds = time.perf_counter() - started
        rows.append({"call": i, "seconds": seconds, "status": plan.status,
                     "circles": len(config.robot.footprint),
                     "finite": bool(np.all(np.isfinite(plan.x)))})
        print(f"{i:3d} {1e3 * seconds:8.1f} ms  {plan.status:<20s} "
              f"{len(config.robot.footprint)} circles", flush=True)
    times = np.array([r["seconds"] for r in rows])
    statuses = {s: sum(r["status"] == s for r in rows) for s in sorted({r["status"] for r in rows})}
    summary = {"calls": len(rows), "max_s": float(times.max()),
               "median_s": float(np.median(times)), "over_0.5_s": int(np.sum(times > 0.5)),
               "statuses": statuses, "all_finite": all(r["finite"] for r in rows)}
    print(json.dumps(summary))
    if args.json:
        with open(args.json, "w") as handle:
            json.dump({"summary": summary, "rows": rows}, handle, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
