"""Docking's ways at each logged cycle: which of them would have passed its test, and by how much.

Reads a kept episode (a benchmark's ``--out``/episodes/*.npz, or ``dsmpepc run``'s), rebuilds
each cycle robot 0 planned in (its state, the people it saw, its goal, the run's planner
configuration and its goal's tolerance) and costs every way docking has, whether or not the
run's docking tried it: the straight way to the goal point (after a turn in place where the
goal lies more than ``docking.turn_in_place`` off the heading), each point of the goal's
region, and ``--curves`` of the law's curves to the goal (``docking.curves``). For each it
prints the survivability docking reads (until arrival) and how many pass
``docking.min_survival`` (a curve must also arrive within the horizon)::

    python tools/docking_ways.py OUT/episodes/EPISODE.npz --cycles 38 94 --every 2
    python tools/docking_ways.py OUT/episodes/EPISODE.npz --json

Cycles farther from the goal than the docking radius are left out (docking is not tried
there); the region and the curves are tried only within ``docking.radius``, as docking does.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math

import numpy as np

from dsmpepc_nlp.core.config import RobotState
from dsmpepc_nlp.sim.episode import Episode
from dsmpepc_nlp.solve.behaviours import docking
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator


def ways(episode: Episode, cycle: int, config, tolerance: float) -> dict | None:
    """Docking's ways at ``cycle`` (robot 0): the best survivability and the passing count of
    each kind; None beyond the docking radius."""
    x, y, phi, v, omega = (float(s) for s in episode.states[0, cycle])
    state, goal = RobotState(x, y, phi, v, omega), tuple(episode.goals[0, cycle])
    distance = math.hypot(goal[0] - x, goal[1] - y)
    if distance > docking.docking_radius(config) or distance == 0.0:
        return None
    evaluator = Evaluator(Cycle.prepare(state, episode.world_at(cycle), goal, config))

    def read(evaluations, points, arriving=False):
        readings = [(e, *docking.until_arrival(e, p, goal, tolerance, config))
                    for e, p in zip(evaluations, points)]
        passing = [e for e, step, s in readings
                   if docking.passes(e, step, s, config, arriving)]
        return {"best": max((s for _, _, s in readings), default=None), "passing": len(passing)}

    [(straight, how)] = docking.approaches(evaluator, [goal], config)
    row = {"cycle": cycle, "time": float(episode.times[cycle]), "distance": distance,
           "off_the_line": math.degrees(float(docking.off_the_line(state.pose, goal))),
           "straight": dict(read([straight], [goal]), turns_first=how.startswith("turning"))}
    near = distance <= config.docking.radius
    targets = docking.region_targets(state, goal, tolerance, config) if near else []
    row["region"] = read([e for e, _ in docking.approaches(evaluator, targets, config)],
                         targets)
    zs = docking.curve_z(state.pose, goal, config) if near else np.empty((0, 4))
    curves = evaluator.evaluate(zs) if len(zs) else None
    row["curves"] = read([curves[[i]] for i in range(len(zs))], [goal] * len(zs),
                         arriving=True)
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("episode")
    parser.add_argument("--cycles", type=int, nargs=2, metavar=("FIRST", "LAST"),
                        help="cycles FIRST to LAST (inclusive); default every planned cycle")
    parser.add_argument("--every", type=int, default=1)
    parser.add_argument("--curves", type=int, default=8, help="docking.curves to try")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    episode = Episode.load(args.episode)
    config = episode.config()
    config = dataclasses.replace(config, docking=dataclasses.replace(config.docking,
                                                                     curves=args.curves))
    tolerance = float(episode.meta["goal_tolerances"][0])
    planned = np.flatnonzero(episode.active[0])
    first, last = args.cycles if args.cycles else (int(planned[0]), int(planned[-1]))
    rows = [r for c in range(first, last + 1, args.every)
            if c < episode.active.shape[1] and episode.active[0, c]
            for r in [ways(episode, c, config, tolerance)] if r is not None]
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0

    def shown(kind):
        best = kind["best"]
        return f"{'-' if best is None else f'{best:.2f}'} ({kind['passing']} pass)"

    for r in rows:
        print(f"cycle {r['cycle']} (t = {r['time']:.1f} s, {r['distance']:.2f} m from the goal, "
              f"{r['off_the_line']:+.0f} deg off the heading): straight "
              f"{shown(r['straight'])}{', after a turn' if r['straight']['turns_first'] else ''}"
              f"; region {shown(r['region'])}; curves {shown(r['curves'])}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
