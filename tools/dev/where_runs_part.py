"""Two configurations on the same ETH/UCY replays: where their runs part, and why.

Replays each crowd episode (``dsmpepc benchmark crowd``'s episode ``k`` of ``--seed``) once with
the product's defaults changed by ``--a`` and once changed by ``--b`` (``NAME=VALUE`` each, as
the benchmarks' ``--set``), records every plan's message, and prints both outcomes, the first
state at which the robot's two paths differ, and the message of the plan each run made just
before it: the decision the two configurations took differently. This is how
docs/experiments/2026-11-28-docking-within-the-goals-region.md traced univ's changed episodes to
the plans that changed them::

    python tools/dev/where_runs_part.py --data DIR --scene univ --episodes 9 16 46 44 \\
        --a docking.region_points=0

``--json`` prints one object per episode instead.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from dsmpepc_nlp.bench.crowds import CrowdSettings, episode_scenario
from dsmpepc_nlp.bench.params import named_solver, overrides, planner_config
from dsmpepc_nlp.sim.simulate import simulate
from dsmpepc_nlp.solve.planner import Planner


def replay(settings: CrowdSettings, episode: int, seed: int) -> tuple:
    """``(episode record, messages)``: one crowd episode under ``settings``, robot 0, and the
    message of every plan it made, in order."""
    messages = []

    class Recording(Planner):
        def plan(self, *args, **kwargs):
            plan = super().plan(*args, **kwargs)
            messages.append(plan.message)
            return plan

    scenario, _ = episode_scenario(settings, episode, seed)
    solver = named_solver(settings.solver, settings.n_samples)
    run = simulate(scenario, planner_config(settings, "ds-mpepc"), solver,
                   np.random.default_rng([seed, episode]), planner_factory=Recording)
    return run, messages


def parting(a, b) -> int | None:
    """The first state index at which robot 0's states in episodes ``a`` and ``b`` differ (over
    the states both have), or None where one run's states all equal the other's."""
    sa, sb = np.asarray(a.states[0]), np.asarray(b.states[0])
    n = min(len(sa), len(sb))
    differs = np.flatnonzero(np.any(sa[:n] != sb[:n], axis=1))
    return int(differs[0]) if differs.size else None


def compare(settings: CrowdSettings, a: tuple, b: tuple, episode: int, seed: int) -> dict:
    """Episode ``episode`` under ``a`` and ``b`` (``--set`` pairs added to ``settings``)."""
    (run_a, said_a), (run_b, said_b) = (
        replay(replace(settings, overrides=settings.overrides + pairs), episode, seed)
        for pairs in (a, b))
    state = parting(run_a, run_b)
    # State k follows the plan made at cycle k - 1: that plan is where the paths part.
    cycle = None if state is None else state - 1
    return {"episode": episode,
            "outcome_a": run_a.outcomes[0], "time_a": float(run_a.outcome_times[0]),
            "outcome_b": run_b.outcomes[0], "time_b": float(run_b.outcome_times[0]),
            "parting_cycle": cycle,
            "parting_time": None if cycle is None else float(run_b.times[cycle]),
            "message_a": None if cycle is None else said_a[cycle],
            "message_b": None if cycle is None else said_b[cycle]}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="the ETH/UCY data folder")
    parser.add_argument("--scene", required=True)
    parser.add_argument("--episodes", type=int, nargs="+", required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--solver", default="nlp")
    parser.add_argument("--a", nargs="*", default=[], metavar="NAME=VALUE")
    parser.add_argument("--b", nargs="*", default=[], metavar="NAME=VALUE")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    settings = CrowdSettings(data=args.data, scene=args.scene, solver=args.solver)
    a, b = overrides(args.a), overrides(args.b)
    for episode in args.episodes:
        row = compare(settings, a, b, episode, args.seed)
        if args.json:
            print(json.dumps(row))
            continue
        print(f"episode {episode}: A {row['outcome_a']} at {row['time_a']:.1f} s, "
              f"B {row['outcome_b']} at {row['time_b']:.1f} s")
        if row["parting_cycle"] is None:
            print("  the same path")
            continue
        print(f"  the paths part after cycle {row['parting_cycle']} "
              f"(t = {row['parting_time']:.1f} s)")
        print(f"  A planned: {row['message_a']}")
        print(f"  B planned: {row['message_b']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
