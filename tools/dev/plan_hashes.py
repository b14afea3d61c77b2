"""Hashes of the plans of the crowded demo scene, to compare two checkouts bit for bit.

For both presets, both variants and the three solvers, a planner plans the first ``--cycles``
cycles of ``dsmpepc bench``'s demo scene (docking off); every plan's ``x`` and ``fun`` go into
one hash per configuration. Run it from each checkout and diff the output::

    python tools/dev/plan_hashes.py > new.txt
    PYTHONPATH=/path/to/other/checkout python tools/dev/plan_hashes.py > old.txt
    diff old.txt new.txt
"""

from __future__ import annotations

import argparse
import hashlib
import os

# Every planner compiles (or loads) what it needs before planning: in the default background
# mode a fresh process's first plans run the exact cost on the numpy path until the compiled
# kernel has loaded (agreeing to ~1e-9, not to the bit), which would make the hashes depend on
# how fast the kernel loaded.
os.environ["DSMPEPC_COMPILE"] = "wait"

from dsmpepc_nlp import Planner, PlannerConfig, SolverConfig  # noqa: E402
from dsmpepc_nlp.bench.scenes import demo_cycles  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=12)
    args = parser.parse_args()
    # Checkouts older than the presets had the paper's values as their defaults.
    paper = getattr(PlannerConfig, "paper", PlannerConfig.variant)
    cycles = demo_cycles(paper("ds-mpepc"), args.cycles)
    for preset in ("product", "paper"):
        for variant in ("mpepc", "ds-mpepc"):
            config = (PlannerConfig.variant(variant) if preset == "product"
                      else paper(variant))
            for solver in ("nlp", "fast", "sampling"):
                # No deadline: a plan cut by the time budget depends on the machine's load.
                planner = Planner(config, SolverConfig.named(solver).replace(time_budget=None),
                                  compile="wait")
                digest = hashlib.sha1()
                for state, world, goal in cycles:
                    plan = planner.plan(state, world, goal, dock=False)
                    digest.update(plan.x.tobytes())
                    digest.update(repr(float(plan.fun)).encode())
                print(f"{preset} {variant} {solver} {digest.hexdigest()[:16]}")


if __name__ == "__main__":
    main()
