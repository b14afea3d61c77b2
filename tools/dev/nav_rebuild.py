"""What a moving goal's navigation function costs a cycle: a rebuild with the map's window kept
(the package's way) against one on a fresh copy of the map (nothing kept), side by side.

Walks ``--goals`` goals 3 cm a step across a built-in scenario's map (the way a followed person
moves the goal of the hall's follower), builds the navigation function of each both ways,
alternated, through the public ``World.navigation`` (a plan's own call, with its window
margin), and prints the medians and whether the values agree to the bit::

    python tools/dev/nav_rebuild.py                 # the hall's map, 40 goals
    python tools/dev/nav_rebuild.py --scenario l-corridor --goals 80

It once also split a build from nothing into its parts (the window's free cells, their graph,
the rest: docs/experiments/2026-11-28-a-followers-plan-time.md) by calling private functions of
the navigation module; it uses the package's public names only now, so it prints no parts.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from dsmpepc_nlp.core.grid import OccupancyGrid
from dsmpepc_nlp.core.world import World
from dsmpepc_nlp.sim.scenario import load_scenario


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="hall")
    parser.add_argument("--goals", type=int, default=40)
    parser.add_argument("--radius", type=float, default=0.3, help="inflation radius, m")
    args = parser.parse_args(argv)

    grid = load_scenario(args.scenario).grid
    if grid is None:
        raise SystemExit(f"{args.scenario} has no map")
    x0, y0, x1, y1 = grid.bounds
    start = np.array([x0 + 0.3 * (x1 - x0), y0 + 0.5 * (y1 - y0)])
    goals = [start + 0.03 * k * np.array([1.0, 0.3]) for k in range(args.goals)]

    def fresh():
        return World(OccupancyGrid(grid.occupied, grid.resolution, grid.origin))

    World(grid).navigation(goals[0], args.radius)    # the map's window kept, as after a cycle
    kept_s, fresh_s, same = [], [], True
    for goal in goals:
        world = World(grid)                          # a new world: no navigation function cached
        started = time.perf_counter()
        kept = world.navigation(goal, args.radius).values
        kept_s.append(time.perf_counter() - started)
        other = fresh()
        started = time.perf_counter()
        cold = other.navigation(goal, args.radius).values
        fresh_s.append(time.perf_counter() - started)
        same &= bool(np.array_equal(kept, cold))

    cold_ms, kept_ms = 1e3 * float(np.median(fresh_s)), 1e3 * float(np.median(kept_s))
    print(f"{args.scenario}, {args.goals} goals: a build with the window kept {kept_ms:.1f} ms, "
          f"from nothing {cold_ms:.1f} ms ({cold_ms / kept_ms:.2f}x); values the same: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
