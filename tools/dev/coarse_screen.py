"""A coarser rollout as the NLP screen's ranking: what a point costs, and what the ranking loses.

docs/experiments/2026-11-28-univ-wandering-and-crosscheck-states.md ("The cross-check's states, the
screen's size and cheaper starts") found that only a denser screen closes the cross-check's misses,
and that a dense screen of exact points costs too much of the plan; it named a screen several times
cheaper a point (rank by a coarser cost, cost exactly only the best) as what would close the target.
This tool measures that idea.

It replays the sampling episode of ``dsmpepc crosscheck SCENARIO`` (seed 0, DS-MPEPC, the
product's defaults), and at every ``--every``-th cycle costs the same ``--points`` box points
(the screen's Sobol sequence, another seed) with the exact kernel under the product's horizon
and under the same horizon at a coarser step (``--dt``; as many steps as cover the horizon's
duration). For each step it prints the median time of a batch (both cores, as the screen
runs), its ratio to the exact one's, and how often the exact best of the ``--keep`` points
the coarse cost ranks first is more than 0.01 (the cross-check's tolerance) above the exact
best of all the points::

    python tools/dev/coarse_screen.py t-corridor
    python tools/dev/coarse_screen.py hall --dt 0.4 0.5 1.0 --points 4096 --keep 64 --every 7
    python tools/dev/coarse_screen.py hall --cycles 13 23 42     # cycles the NLP misses
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time

os.environ.setdefault("DSMPEPC_COMPILE", "wait")

import numpy as np  # noqa: E402

from dsmpepc_nlp import PlannerConfig, SolverConfig  # noqa: E402
from dsmpepc_nlp.core.config import HorizonConfig  # noqa: E402
from dsmpepc_nlp.solve.exact.cycle import Cycle  # noqa: E402
from dsmpepc_nlp.solve.exact.evaluator import evaluate_batch  # noqa: E402
from dsmpepc_nlp.solve.optimize.starts import box_samples  # noqa: E402

TOLERANCE = 0.01
"""The cross-check's tolerance on the exact cost (``dsmpepc crosscheck``)."""


def coarse_config(config: PlannerConfig, dt: float) -> PlannerConfig:
    """``config`` with the horizon stepped at ``dt``: as many steps as cover its duration."""
    steps = max(1, math.ceil(config.horizon.duration / dt - 1e-9))
    return dataclasses.replace(config, horizon=HorizonConfig(dt=dt, n_steps=steps))


def measure(cycles, config: PlannerConfig, dts, points: int, keep: int, seed: int = 7) -> dict:
    """Per step in ``dts`` (the horizon's own first): ``ms`` (the batch times, s), ``gaps``
    (per cycle, the exact best of the ``keep`` points the step ranks first minus the exact best
    of all) and ``steps`` (the horizon's steps)."""
    z = box_samples(config, points, seed)
    configs = {config.horizon.dt: config}
    configs.update({dt: coarse_config(config, dt) for dt in dts if dt not in configs})
    state, world, goal = cycles[0]
    for each in configs.values():                       # load and warm the kernel
        evaluate_batch(z[:8], Cycle.prepare(state, world, goal, each))
    found = {dt: {"seconds": [], "gaps": [], "steps": c.horizon.n_steps}
             for dt, c in configs.items()}
    for state, world, goal in cycles:
        totals = {}
        for dt, each in configs.items():
            cycle = Cycle.prepare(state, world, goal, each)
            started = time.perf_counter()
            total = evaluate_batch(z, cycle).costs.total
            found[dt]["seconds"].append(time.perf_counter() - started)
            totals[dt] = np.where(np.isfinite(total), total, np.inf)
        exact = totals[config.horizon.dt]
        for dt, total in totals.items():
            ranked = np.argsort(total, kind="stable")[:keep]
            found[dt]["gaps"].append(float(exact[ranked].min() - exact.min()))
    return found


def table(found: dict, own_dt: float, points: int, keep: int) -> str:
    """The figures of :func:`measure` as text, a line per step."""
    base = np.median(found[own_dt]["seconds"])
    lines = [f"{points} points a batch; the exact best of the first {keep} by each ranking"]
    for dt, row in found.items():
        seconds, gaps = np.median(row["seconds"]), np.asarray(row["gaps"])
        lines.append(f"dt {dt:g} s ({row['steps']} steps): {1e3 * seconds:.1f} ms a batch "
                     f"({seconds / base:.2f}x the exact), best lost by over {TOLERANCE:g} in "
                     f"{int(np.sum(gaps > TOLERANCE))} of {len(gaps)} cycles "
                     f"(largest {gaps.max():.4f})")
    return "\n".join(lines)


def main(argv=None) -> int:
    from dsmpepc_nlp.sim.scenario import load_scenario
    from dsmpepc_nlp.sim.simulate import simulate

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--dt", type=float, nargs="+", default=[0.4, 0.5, 1.0])
    parser.add_argument("--points", type=int, default=4096)
    parser.add_argument("--keep", type=int, default=64)
    parser.add_argument("--every", type=int, default=7)
    parser.add_argument("--cycles", type=int, nargs="+", default=None,
                        help="measure at these cycles (e.g. the misses crosscheck_starts.py "
                             "lists) instead of every --every-th")
    args = parser.parse_args(argv)
    episode = simulate(load_scenario(args.scenario), PlannerConfig.variant("ds-mpepc"),
                       SolverConfig.sampling(), np.random.default_rng(0),
                       record_trajectories=False)
    config = dataclasses.replace(PlannerConfig.variant("ds-mpepc"), robot=episode.config().robot)
    every = episode.planning_inputs(0)
    if args.cycles is None:
        cycles, which = every[::args.every], f"every {args.every}th"
    else:
        cycles, which = [every[k] for k in args.cycles], "those given"
    found = measure(cycles, config, args.dt, args.points, args.keep)
    print(f"{args.scenario}, {len(cycles)} cycles ({which})")
    print(table(found, config.horizon.dt, args.points, args.keep))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
