"""What the robot planned, cycle by cycle, in one CrowdNav episode or ETH/UCY replay: each plan's
speed and survivability over its horizon, its stall level and the turn rung's best offer, beside
what the robot then did.

Benchmarks keep no plans, so this runs the episode (deterministic: the benchmark's outcome and
time come back), then replays a fresh planner over the states and people it logged, cycle by
cycle, and checks that every replayed plan's z is the logged one (``replayed``). At each
``--at`` time it prints the robot's state, the plan's z, status, exact cost and stall level,
its speed every 0.4 s and survivability every 0.6 s of the horizon and at its end, the exact
cost of the cheapest of the stall ladder's turns in place (turn, then the law; ``turn_cost``;
whether the ladder offers them then or not), and the speed the robot then drove at. It is how
docs/experiments/2026-11-29-square-invisible-stalls.md reads a stall where every plan creeps first
and speeds up late, each next plan putting the burst off::

    python tools/dev/plan_profile.py --scene square --seed 0 --episode 385 --at 20 20.5 21
    python tools/dev/plan_profile.py --scene square --seed 0 --episode 385 --at 20 \\
        --set stall.levels=5

With ``--data DIR`` the episode is a replay of ``dsmpepc benchmark crowd --data DIR`` instead
(``--scene`` eth, hotel, zara1, zara2, univ, or a recording; ``--duration`` its window)::

    python tools/dev/plan_profile.py --data DATA/ethucy --scene univ --seed 0 --episode 22 --at 5 6
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from dsmpepc_nlp.bench import crowdnav, crowds
from dsmpepc_nlp.bench.crowdnav import SETTINGS, CrowdNavSettings
from dsmpepc_nlp.bench.crowds import CrowdSettings
from dsmpepc_nlp.bench.params import named_solver, overrides
from dsmpepc_nlp.core.exact_cost import evaluate
from dsmpepc_nlp.solve.behaviours import ways
from dsmpepc_nlp.solve.planner import Planner

EVERY = 0.4
"""s between the speeds printed of a plan."""
SURVIVAL_EVERY = 0.6
"""s between the survivabilities printed of a plan."""


def _rounded(values, step: int) -> list:
    return [round(float(v), 3) for v in np.asarray(values)[::max(1, step)]]


def turn_cost(plan, state, goal, cycle) -> float:
    """The exact cost of the cheapest of the stall ladder's turns in place against ``plan``."""
    turns = ways.turn_trajectories(plan, state, goal, cycle.config)
    total = evaluate(turns, cycle.world, cycle.goal, cycle.config).total
    return float(np.min(np.where(np.isfinite(total), total, np.inf)))


def profile(settings, episode: int, seed: int, times, variant="ds-mpepc"):
    """``{"outcome", "time", "replayed", "plans": [...]}``: the episode (CrowdNav's with
    :class:`CrowdNavSettings`, an ETH/UCY replay with :class:`CrowdSettings`), and at each of
    ``times`` (s, rounded to the loop's cycles) the plan made then (the module docstring)."""
    family = crowds if isinstance(settings, CrowdSettings) else crowdnav
    log, _ = family.simulate_episode(settings, variant, episode, seed,
                                     record_trajectories=False)
    config = log.config()
    planner = Planner(config, named_solver(settings.solver, settings.n_samples))
    tolerance = float(log.meta["goal_tolerances"][0])
    wanted = {int(round(float(t) / log.dt)): float(t) for t in times}
    dt, found, replayed = config.horizon.dt, {}, True
    for k, (state, world, goal) in zip(np.flatnonzero(log.active[0]), log.planning_inputs()):
        plan = planner.plan(state, world, goal, goal_tolerance=tolerance)
        replayed &= bool(np.allclose(plan.x, log.z[0, k], atol=1e-9))
        if k in wanted:
            found[k] = {
                "time": float(log.times[k]), "planned": True,
                "state": [round(float(s), 3) for s in log.states[0, k]],
                "z": [round(float(v), 3) for v in plan.x], "status": plan.status,
                "cost": float(plan.fun), "stall_level": int(plan.stall_level),
                "speed": _rounded(plan.trajectory.v, round(EVERY / dt)),
                "survivability": _rounded(plan.cost.survivability, round(SURVIVAL_EVERY / dt)),
                "survivability_end": round(float(plan.cost.survivability[-1]), 3),
                "turn_cost": turn_cost(plan, state, goal, planner.last_evaluator.cycle),
                "next_speed": round(float(log.states[0, k + 1, 3]), 3)}
    plans = [found.get(k, {"time": t, "planned": False}) for k, t in wanted.items()]
    return {"outcome": log.outcomes[0], "time": float(log.outcome_times[0]),
            "replayed": replayed, "plans": plans}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="circle",
                        help=f"CrowdNav's {' or '.join(crowdnav.SCENES)}; with --data an "
                             f"ETH/UCY scene ({', '.join(crowds.SCENES)}) or a recording")
    parser.add_argument("--data", default=None, help="ETH/UCY data folder: replay a crossing")
    parser.add_argument("--robot", choices=SETTINGS, default="invisible")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--episode", type=int, required=True)
    parser.add_argument("--at", type=float, nargs="+", required=True, metavar="SECONDS")
    parser.add_argument("--preset", choices=("product", "paper"), default="product")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("--solver", choices=("nlp", "fast", "sampling"), default="nlp")
    parser.add_argument("--samples", type=int, default=None)
    parser.add_argument("--duration", type=float, default=None)
    args = parser.parse_args(argv)
    extra = {} if args.duration is None else {"duration": args.duration}
    common = dict(scene=args.scene, preset=args.preset, overrides=overrides(args.set),
                  solver=args.solver, n_samples=args.samples, **extra)
    if args.data is not None:
        settings = CrowdSettings(data=args.data, **common)
    elif args.scene in crowdnav.SCENES:
        settings = CrowdNavSettings(setting=args.robot, **common)
    else:
        parser.error(f"--scene {args.scene!r}: CrowdNav's scenes are "
                     f"{', '.join(crowdnav.SCENES)}; an ETH/UCY scene needs --data")
    print(json.dumps(profile(settings, args.episode, args.seed, args.at), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
