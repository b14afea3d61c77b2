"""What every trajectory could have done at one logged cycle: the exact cost's best of a batch of
samples against standing still.

Reads a kept episode (a benchmark's ``--out``/episodes/*.npz, or ``dsmpepc run``'s), rebuilds
the cycle the robot planned in (its state, the people it saw, its goal, the run's planner
configuration) and costs the stop trajectory, the named starts and ``--samples`` box samples
with the exact cost. Prints the lowest-cost trajectory and the one that keeps the highest
survivability at the horizon's end, beside the stop's. ``--set`` replaces a field of the run's
configuration (as the benchmarks' ``--set``), for example a wider box::

    python tools/dev/stuck_cycle.py OUT/episodes/EPISODE.npz --cycle 94
    python tools/dev/stuck_cycle.py OUT/episodes/EPISODE.npz --cycle 94 --set bounds.delta_max=3.1

``--cycle`` defaults to the last cycle the robot planned in; ``dsmpepc failures`` names each
failed run's stuck cycle (``cycle`` in its failures.json). The cycle is costed at the stall
ladder's level the robot planned it at (replayed from the logged positions; ``stall_level`` in
the output); ``--level K`` costs it at level K instead (0: the progress weight unraised, as
this tool did before 2026-11-29).
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from dsmpepc_nlp.bench.failure_report import stuck_config
from dsmpepc_nlp.bench.params import overrides, replaced
from dsmpepc_nlp.core.config import RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.sim.episode import Episode
from dsmpepc_nlp.solve.behaviours.stall import StallMonitor
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator
from dsmpepc_nlp.solve.optimize.sampling import SamplingPlanner
from dsmpepc_nlp.solve.optimize.starts import structured_starts


def costed(episode: Episode, cycle: int, config, n_samples: int = 4096, seed: int = 0):
    """The exact evaluation of the stop, the named starts and ``n_samples`` box samples at
    ``cycle`` (robot 0), and the stop's row in it."""
    x, y, phi, v, omega = (float(s) for s in episode.states[0, cycle])
    state, goal = RobotState(x, y, phi, v, omega), episode.goals[0, cycle]
    solver = SolverConfig.sampling(n_samples=n_samples, seed=seed)
    evaluation = SamplingPlanner(config, solver).search(
        Evaluator(Cycle.prepare(state, episode.world_at(cycle), goal, config), solver),
        structured_starts(state, goal, config))
    stop = int(np.flatnonzero(evaluation.z[:, 3] == 0.0)[0])
    return evaluation, stop


def row(evaluation, i: int, dt: float) -> dict:
    """Row ``i``'s z, exact cost and terms, survivability 1 s ahead and at the end."""
    costs = evaluation.costs
    survival = costs.survivability[i]
    return {"z": [round(float(v), 3) for v in evaluation.z[i]],
            "total": float(costs.total[i]),
            "terms": {k: float(t[i]) for k, t in costs.terms.items()},
            "survivability_1s": float(survival[min(round(1.0 / dt), len(survival) - 1)]),
            "survivability_end": float(survival[-1]),
            "min_distance": float(costs.min_distance[i])}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("episode")
    parser.add_argument("--cycle", type=int, default=None)
    parser.add_argument("--samples", type=int, default=4096)
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("--level", type=int, default=None,
                        help="the stall ladder's level to cost at (default: the robot's then)")
    args = parser.parse_args(argv)
    episode = Episode.load(args.episode)
    cycle = args.cycle
    if cycle is None:
        cycle = int(np.flatnonzero(episode.active[0])[-1])
    config = replaced(episode.config(), dict(overrides(args.set)))
    if args.level is None:
        config, level = stuck_config(episode, 0, cycle, config)
    else:
        level = args.level
        config = StallMonitor(config).config_for(level)
    evaluation, stop = costed(episode, cycle, config, args.samples)
    best = evaluation.best()
    survivor = int(np.argmax(evaluation.costs.survivability[:, -1]))
    dt = config.horizon.dt
    report = {"cycle": cycle, "time": float(episode.times[cycle]), "stall_level": level,
              "lowest_cost": row(evaluation, best, dt), "highest_end_survivability":
              row(evaluation, survivor, dt), "stop": row(evaluation, stop, dt),
              "best_is_stop": bool(evaluation.costs.total[best] >= evaluation.costs.total[stop])}
    print(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
