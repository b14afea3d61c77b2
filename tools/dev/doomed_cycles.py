"""Which collisions of a benchmark came after a doomed plan, and how the cost saw its ways then.

Reads a benchmark's ``--out`` folder (``dsmpepc benchmark crowdnav``, ``crowd`` or ``barn``),
takes every run that ended in a collision and whose episode was kept (``OUT/episodes``), and
replays it plan by plan with a fresh planner of the run's configuration and solver, checking
that every replayed plan's z is the logged one (``replayed``). For each plan of the last
``--before`` seconds before the contact it reads the plan's survivability to the horizon's end
and over the next ``--within`` seconds, and the exact cost of the cheapest of the plan, the
back-up rung's 96 dodges and 3 reverses. A plan is doomed below ``--below``
(``stall.doomed_below``'s 0.05 by default). The summary counts the collisions that came after
a plan doomed by the horizon's end, after one doomed within the second, and after a plan the
last resort made (status ``clearing``: it acted, and the robot was struck all the same)::

    python tools/dev/doomed_cycles.py OUT
    python tools/dev/doomed_cycles.py OUT --before 1.25 --below 0.05 --json

The configuration is the one each episode logged; a field it does not name takes today's
default, so a run made before the last resort (``stall.doomed_below``) replays its own plans
only with ``--set stall.doomed_below=0`` (``replayed`` says whether it did).
docs/experiments/2026-11-29-last-resort-for-a-doomed-plan.md counted 67 of square invisible's 71
tuning collisions so.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from dsmpepc_nlp.bench.failure_report import read_tables
from dsmpepc_nlp.bench.params import named_solver, overrides, replaced
from dsmpepc_nlp.core.control_law import stacked
from dsmpepc_nlp.core.exact_cost import evaluate
from dsmpepc_nlp.core.solver_config import SOLVER_NAMES, SolverConfig
from dsmpepc_nlp.sim.episode import Episode
from dsmpepc_nlp.solve.behaviours import ways as moves
from dsmpepc_nlp.solve.planner import Planner

SOLVERS = {SolverConfig.named(name).method: name for name in SOLVER_NAMES}
"""The solver's name (``--solver``) of each method an episode logs (``ipopt``: ``nlp``)."""


def collision_episodes(out_dir) -> list:
    """``(label, path)`` of every run of ``out_dir``'s tables that ended in a collision and
    kept its episode."""
    found = []
    for stem, keys, rows in read_tables(out_dir):
        for row in rows:
            if row.get("outcome") == "collision" and row.get("episode_file"):
                label = " ".join(f"{k}={row.get(k)}" for k in keys)
                found.append((f"{stem} {label}", Path(out_dir) / row["episode_file"]))
    return found


def survival_at(survivability, seconds: float, dt: float) -> float:
    """The survivability at the first step at or after ``seconds`` (the horizon's end if
    that is sooner)."""
    step = min(math.ceil(seconds / dt - 1e-9), len(survivability) - 1)
    return float(survivability[step])


def replay(path, before: float, within: float, pairs: tuple = ()) -> dict:
    """One collision's episode replayed: ``{"replayed", "contact", "plans": [...]}``, each plan
    of the last ``before`` seconds with its time, status, survivability to the horizon's end
    and within ``within`` s, and the cheapest exact cost of it and the rung's ways."""
    log = Episode.load(path)
    config = replaced(log.config(), dict(pairs))
    solver = named_solver(SOLVERS[log.meta["solver"]], log.meta.get("n_samples"))
    planner = Planner(config, solver, compile="wait")     # as the benchmarks plan
    tolerance = float(log.meta["goal_tolerances"][0])
    contact, dt = float(log.outcome_times[0]), config.horizon.dt
    replayed, plans = True, []
    for k, (state, world, goal) in zip(np.flatnonzero(log.active[0]), log.planning_inputs()):
        plan = planner.plan(state, world, goal, goal_tolerance=tolerance)
        replayed &= bool(np.allclose(plan.x, log.z[0, k], atol=1e-9))
        time = float(log.times[k])
        if time < contact - before - 1e-9:
            continue
        ways = stacked([plan.trajectory, moves.dodge_trajectories(state, config),
                               moves.back_up_trajectories(state, config)])
        total = evaluate(ways, world, goal, config).total
        survival = plan.cost.survivability
        plans.append({"time": time, "status": plan.status,
                      "survival_end": float(survival[-1]),
                      "survival_within": survival_at(survival, within, dt),
                      "cheapest": float(np.min(np.where(np.isfinite(total), total, np.inf)))})
    return {"replayed": replayed, "contact": contact, "plans": plans}


def summary(results: dict, below: float) -> dict:
    """The counts over ``{label: replay}``: collisions, those after a plan doomed by the
    horizon's end and within the second, those after a plan the last resort made
    (``clearing``), and the replays that were not the logged plans."""
    def after(key):
        return sorted(label for label, r in results.items()
                      if any(p[key] < below for p in r["plans"]))
    return {"collisions": len(results), "below": below,
            "doomed_by_the_end": len(after("survival_end")),
            "doomed_within": len(after("survival_within")),
            "cleared": sum(any(p["status"] == "clearing" for p in r["plans"])
                           for r in results.values()),
            "not_replayed": sorted(label for label, r in results.items() if not r["replayed"])}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="a benchmark's --out folder (its episodes kept)")
    parser.add_argument("--before", type=float, default=1.25,
                        help="s before the contact whose plans are read (default 1.25)")
    parser.add_argument("--within", type=float, default=1.0,
                        help="s of the survivability read soon (default 1)")
    parser.add_argument("--below", type=float, default=0.05,
                        help="a plan is doomed below this survivability (default 0.05)")
    parser.add_argument("--set", dest="pairs", action="append", default=[],
                        metavar="NAME=VALUE", help="a configuration field for the replay")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    pairs = overrides(args.pairs)
    results = {label: replay(path, args.before, args.within, pairs)
               for label, path in collision_episodes(args.out)}
    report = {"summary": summary(results, args.below), "runs": results}
    if args.json:
        print(json.dumps(report, indent=1))
        return 0
    for label, r in results.items():
        doomed = [p["time"] for p in r["plans"] if p["survival_end"] < args.below]
        print(f"{label}: contact {r['contact']:.2f} s, doomed by the end at "
              f"{', '.join(f'{t:.2f}' for t in doomed) or '-'}"
              f"{'' if r['replayed'] else ' (NOT the logged plans)'}")
    s = report["summary"]
    print(f"{s['doomed_by_the_end']} of {s['collisions']} collisions came after a plan doomed by "
          f"the horizon's end (survival < {args.below:g}), {s['doomed_within']} after one doomed "
          f"within {args.within:g} s, {s['cleared']} after a plan the last resort made "
          f"(clearing); not replayed: {len(s['not_replayed'])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
