"""Plan time of this checkout against another revision: alternated ``dsmpepc bench`` pairs.

The machine is shared and noisy, so a plan-time budget ("within 1.1x of the code the issue was
filed on") is checked with both sides timed in one run, alternated, each first in half of the
pairs, and read as the median of the pairs' ratios. This script does that: it checks ``BASE``
(a revision) out into a temporary git worktree, then runs ``python -m dsmpepc_nlp bench
--cycles N --json`` from a folder outside both, with ``PYTHONPATH`` pointing at the base
worktree or at this checkout, once each as a warm-up (it compiles what the base's cache lacks;
not counted), then ``--pairs`` times each::

    python tools/dev/bench_pairs.py 932845c --pairs 16
    python tools/dev/bench_pairs.py 932845c --pairs 4 --out /tmp/pairs --json
    python tools/dev/bench_pairs.py HEAD --pairs 4     # the same code both sides: the noise floor

Each run's JSON is kept in ``--out`` (``base-K.json``, ``this-K.json``) and the summary printed:
for each figure (default, fast and sampler medians, default p95, the exact cost a trajectory,
each planner's time outside and inside its solver's runs and its iterations a solve), both
sides' medians over the runs, the ratio of those medians, and the pairs' ratios (this / base):
median, smallest, largest.
Each side runs at its own defaults. How the table of
docs/experiments/2026-11-28-plan-time-against-the-issue-code.md was measured.

``--iterations`` times the IPOPT solves alone instead: each run is a fresh process of
:data:`ITERATION_PROGRAM` (the same program on both sides, using only what every revision since
the issue's has), which plans the demo cycles once to warm up, then with three fresh default
planners, and reports IPOPT's own wall time an iteration (the solves' ``t_wall_total`` over
their iterations, summed over the cycles; the median of the three planners) and the
iterations a solve::

    python tools/dev/bench_pairs.py 932845c --pairs 6 --iterations

``--fresh`` times a fresh process's first plan instead: each run is a new interpreter running
:data:`FRESH_PROGRAM` (again only what every revision since the issue's has), which times the
package's import from its first statement, then, after building the demo's first cycle
(untimed), the default planner's construction and one plan of that cycle; the parent adds the
child's whole wall time, interpreter start and exit included. The warm-up run of each side
writes its bytecode, so the timed runs read modules from bytecode, as ``pip install .`` leaves
them (unless ``PYTHONDONTWRITEBYTECODE`` is set)::

    python tools/dev/bench_pairs.py f0ebd4c --pairs 20 --fresh
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]     # the checkout: this file is tools/dev/

FIGURES = {
    "default median, ms": ("default", "median_ms"),
    "default p95, ms": ("default", "p95_ms"),
    "default outside the solves, ms": ("default", "overhead_ms"),
    "default inside the solves, ms": ("default", "solver_ms"),
    "default iterations a solve": ("default", "iterations"),
    "fast median, ms": ("fast", "median_ms"),
    "fast outside the solves, ms": ("fast", "overhead_ms"),
    "fast inside the solves, ms": ("fast", "solver_ms"),
    "fast iterations a solve": ("fast", "iterations"),
    "sampler median, ms": ("sampling", "median_ms"),
    "exact cost, us a trajectory": ("exact_us_per_trajectory",),
}
"""Summary rows: a name and the key path into ``dsmpepc bench --json``'s object."""

ITERATION_FIGURES = {
    "default ms an iteration": ("default", "ms_per_iteration"),
    "default iterations a solve": ("default", "iterations"),
}
"""Summary rows of ``--iterations``: the key paths into :data:`ITERATION_PROGRAM`'s object."""

ITERATION_PROGRAM = """
import json, os, statistics
os.environ["DSMPEPC_COMPILE"] = "wait"
from dsmpepc_nlp import Planner, PlannerConfig, SolverConfig
from dsmpepc_nlp.bench.scenes import demo_cycles
config = PlannerConfig()
cycles = demo_cycles(config, CYCLES, 0)
warm = Planner(config, SolverConfig())
for state, world, goal in cycles:
    warm.plan(state, world, goal, dock=False)
per, its = [], []
for _ in range(3):
    planner = Planner(config, SolverConfig())
    seconds = iterations = solves = 0
    for state, world, goal in cycles:
        planner.plan(state, world, goal, dock=False)
        for stats in planner.nlp.last_stats:
            seconds += stats["t_wall_total"]
            iterations += stats["iter_count"]
            solves += 1
    per.append(1e3 * seconds / iterations)
    its.append(iterations / solves)
print(json.dumps({"default": {"ms_per_iteration": statistics.median(per),
                              "iterations": statistics.median(its)}}))
"""
"""The program ``--iterations`` runs on each side (``CYCLES`` replaced by ``--cycles``)."""


FRESH_FIGURES = {
    "first plan, ms": ("fresh", "first_plan_ms"),
    "imports, ms": ("fresh", "import_ms"),
    "planner and plan, ms": ("fresh", "plan_ms"),
    "whole process, ms": ("fresh", "process_ms"),
}
"""Summary rows of ``--fresh``: the key paths into :data:`FRESH_PROGRAM`'s object."""

FRESH_PROGRAM = """
import time
started = time.perf_counter()
import json, os
os.environ["DSMPEPC_COMPILE"] = "wait"
import dsmpepc_nlp
imported = time.perf_counter()
from dsmpepc_nlp import Planner, PlannerConfig, SolverConfig
from dsmpepc_nlp.bench.scenes import demo_cycles
config = PlannerConfig()
state, world, goal = demo_cycles(config, 1, 0)[0]
built = time.perf_counter()
Planner(config, SolverConfig()).plan(state, world, goal, dock=False)
done = time.perf_counter()
print(json.dumps({"fresh": {"import_ms": 1e3 * (imported - started),
                            "plan_ms": 1e3 * (done - built),
                            "first_plan_ms": 1e3 * (imported - started + done - built)}}))
"""
"""The program ``--fresh`` runs on each side: the import, and the planner's construction with
one plan of the demo's first cycle, timed apart from the scene's construction."""


def figure(run: dict, path: tuple) -> float:
    """The number at ``path`` in one bench object (NaN where that version does not report it)."""
    value = run
    for key in path:
        if not isinstance(value, dict) or key not in value:
            return float("nan")
        value = value[key]
    return float(value) if isinstance(value, (int, float)) else float("nan")


def summarise(base: list, this: list, figures: dict = FIGURES) -> dict:
    """Per figure of ``figures``: both sides' medians over their runs, the ratio of the
    medians, and the pairs' ratios (``this[k] / base[k]``) as median, min and max. ``base`` and
    ``this`` are bench objects, pair k at index k."""
    if len(base) != len(this) or not base:
        raise ValueError("base and this need the same number of runs, at least one")
    summary = {}
    for name, path in figures.items():
        a = [figure(run, path) for run in base]
        b = [figure(run, path) for run in this]
        pairs = [y / x for x, y in zip(a, b) if x > 0 and not math.isnan(y)]
        a_median = _median(a)
        b_median = _median(b)
        summary[name] = {
            "base_median": a_median, "this_median": b_median,
            "ratio_of_medians": b_median / a_median if a_median > 0 else float("nan"),
            "pairs": len(pairs),
            "pairs_ratio_median": statistics.median(pairs) if pairs else float("nan"),
            "pairs_ratio_min": min(pairs) if pairs else float("nan"),
            "pairs_ratio_max": max(pairs) if pairs else float("nan"),
        }
    return summary


def _median(values: list) -> float:
    """The median, or NaN when a run lacks the figure (a side's version does not report it)."""
    return float("nan") if any(math.isnan(v) for v in values) else statistics.median(values)


def table(summary: dict) -> str:
    """The summary as aligned text."""
    lines = [f"{'figure':32s} {'base':>8s} {'this':>8s} {'ratio':>6s}   "
             "pairs' ratio: median (range)"]
    for name, row in summary.items():
        lines.append(f"{name:32s} {row['base_median']:8.2f} {row['this_median']:8.2f} "
                     f"{row['ratio_of_medians']:6.2f}   {row['pairs_ratio_median']:.2f} "
                     f"({row['pairs_ratio_min']:.2f}-{row['pairs_ratio_max']:.2f})")
    return "\n".join(lines)


def bench(source: Path, cycles: int, out: Path, cwd: Path, mode: str = "bench") -> dict:
    """One ``dsmpepc bench --json`` run of the package at ``source`` (``mode`` "iterations":
    one of :data:`ITERATION_PROGRAM`; "fresh": one of :data:`FRESH_PROGRAM`, with the child's
    whole wall time added as ``process_ms``); its object, also saved."""
    env = dict(os.environ, PYTHONPATH=str(source))
    command = {"iterations": ["-c", ITERATION_PROGRAM.replace("CYCLES", str(int(cycles)))],
               "fresh": ["-c", FRESH_PROGRAM]}.get(
        mode, ["-m", "dsmpepc_nlp", "bench", "--cycles", str(cycles), "--json"])
    started = time.perf_counter()
    done = subprocess.run([sys.executable, *command], cwd=cwd, env=env, capture_output=True,
                          text=True, check=False)
    elapsed_ms = 1e3 * (time.perf_counter() - started)
    if done.returncode != 0:
        raise SystemExit(f"bench failed for {source} (status {done.returncode}):\n"
                         f"{done.stderr[-2000:]}")
    run = json.loads(done.stdout.strip().splitlines()[-1])
    if mode == "fresh":
        run["fresh"]["process_ms"] = elapsed_ms
    out.write_text(json.dumps(run))
    return run


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("base", help="the revision to compare against (a commit, tag or branch)")
    parser.add_argument("--pairs", type=int, default=8)
    parser.add_argument("--cycles", type=int, default=20)
    parser.add_argument("--out", help="folder for each run's JSON (default: a temporary one)")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--iterations", action="store_true",
                        help="time IPOPT an iteration instead of whole plans")
    parser.add_argument("--fresh", action="store_true",
                        help="time a fresh process's import and first plan instead")
    args = parser.parse_args(argv)
    if args.iterations and args.fresh:
        parser.error("--iterations and --fresh are two different runs: give one")
    mode = "iterations" if args.iterations else "fresh" if args.fresh else "bench"
    if args.pairs < 1 or args.cycles < 1:
        parser.error("--pairs and --cycles must be at least 1")
    out = Path(args.out or tempfile.mkdtemp(prefix="bench-pairs-"))
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="bench-pairs-base-") as folder:
        worktree = Path(folder) / "base"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(worktree),
                        args.base], check=True, capture_output=True)
        try:
            sides = {"base": worktree, "this": REPO}
            for side, source in sides.items():
                bench(source, args.cycles, out / f"{side}-warmup.json", Path(folder), mode)
            runs = {"base": [], "this": []}
            for k in range(args.pairs):
                order = ("base", "this") if k % 2 == 0 else ("this", "base")
                for side in order:
                    runs[side].append(bench(sides[side], args.cycles, out / f"{side}-{k}.json",
                                            Path(folder), mode))
        finally:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force",
                            str(worktree)], check=False, capture_output=True)
    summary = summarise(runs["base"], runs["this"], {
        "iterations": ITERATION_FIGURES, "fresh": FRESH_FIGURES}.get(mode, FIGURES))
    if args.json:
        print(json.dumps({"base": args.base, "pairs": args.pairs, "out": str(out),
                          "figures": summary}, indent=1))
    else:
        print(f"this checkout against {args.base}, {args.pairs} alternated pairs "
              f"(runs in {out})")
        print(table(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
