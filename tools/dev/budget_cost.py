"""What the time budget costs a plan that it does not cut: the same planner with the default
budget and without one, on the crowded demo scene, alternated in one process.

Run from the repository root::

    python tools/dev/budget_cost.py --solver nlp --repeats 4
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from dsmpepc_nlp import Planner, PlannerConfig, SolverConfig
from dsmpepc_nlp.bench.scenes import demo_cycles


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--solver", default="nlp", choices=("nlp", "fast", "sampling"))
    parser.add_argument("--cycles", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=4)
    args = parser.parse_args(argv)
    config = PlannerConfig()
    cycles = demo_cycles(config, args.cycles, 0)
    planners = {budget: Planner(config, dataclasses.replace(SolverConfig.named(args.solver),
                                                            time_budget=budget))
                for budget in ("auto", None)}
    times = {budget: [] for budget in planners}
    for planner in planners.values():
        planner.prepare()
    for _ in range(args.repeats):           # alternated: the machine's drift hits both
        for budget, planner in planners.items():
            planner.reset()
            times[budget] += [planner.plan(s, w, g, dock=False).wall_time
                              for s, w, g in cycles]
    medians = {budget: float(np.median(t)) * 1e3 for budget, t in times.items()}
    for budget, median in medians.items():
        print(f"{args.solver} budget {budget or 'none'}: median {median:.2f} ms")
    print(f"ratio auto / none: {medians['auto'] / medians[None]:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
