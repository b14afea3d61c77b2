"""What the robot planned, cycle by cycle, in one CrowdNav episode: each plan's speed over its
horizon beside what the robot then did.

Benchmarks keep no plan trajectories (their episodes are small); this re-runs one CrowdNav
episode with them (deterministic: the benchmark's outcome and time come back) and prints, at
each ``--at`` time, the robot's state, the plan's z, status and exact cost, the plan's speed
every 0.4 s of its horizon, its survivability at the horizon's end, and the speed the robot
then drove at. It is how docs/results.md reads a stall
where every plan creeps first and speeds up late, and each next plan puts the burst off::

    python tools/plan_profile.py --scene square --seed 0 --episode 385 --at 20 20.5 21 21.5
    python tools/plan_profile.py --scene square --seed 0 --episode 385 --at 20 --set stall.levels=5
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from dsmpepc_nlp.bench.crowdnav import (
    SCENES,
    SETTINGS,
    TIME_STEP,
    CrowdNavSettings,
    simulate_episode,
)
from dsmpepc_nlp.bench.params import overrides, planner_config

EVERY = 0.4
"""s between the speeds printed of a plan."""


def profile(settings: CrowdNavSettings, episode: int, seed: int, times, variant="ds-mpepc"):
    """``{"outcome", "time", "plans": [...]}``: the episode re-run with its plans kept, and
    at each of ``times`` (s, rounded to the loop's 0.25 s cycles) the plan made then."""
    log, _ = simulate_episode(settings, variant, episode, seed, record_trajectories=True)
    dt = planner_config(settings, variant).horizon.dt
    plans = []
    for t in times:
        k = int(round(float(t) / TIME_STEP))
        if not (0 <= k < log.n_cycles and log.active[0, k]):
            plans.append({"time": float(t), "planned": False})
            continue
        poses = log.plan_poses[0, k]
        speed = np.hypot(*np.diff(poses[:, :2], axis=0).T) / dt
        plans.append({
            "time": float(log.times[k]), "planned": True,
            "state": [round(float(s), 3) for s in log.states[0, k]],
            "z": [round(float(v), 3) for v in log.z[0, k]],
            "status": log.statuses[int(log.status[0, k])],
            "cost": float(log.cost_total[0, k]),
            "speed": [round(float(v), 3) for v in speed[::max(1, round(EVERY / dt))]],
            "survivability_end": round(float(log.survivability[0, k]), 3),
            "next_speed": (round(float(log.states[0, k + 1, 3]), 3)
                           if k + 1 < len(log.times) else None)})
    return {"outcome": log.outcomes[0], "time": float(log.outcome_times[0]), "plans": plans}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", choices=SCENES, default="circle")
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
    settings = CrowdNavSettings(scene=args.scene, setting=args.robot, preset=args.preset,
                                overrides=overrides(args.set), solver=args.solver,
                                n_samples=args.samples, **extra)
    print(json.dumps(profile(settings, args.episode, args.seed, args.at), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
