"""The benchmark commands of ``dsmpepc``, each an ``add_arguments(parser)`` / ``run(args)`` pair.

``crosscheck`` (NLP vs sampling on every cycle of an episode), ``bench`` (plan time on the demo
scene), ``benchmark barn | crowd | crowdnav | scenarios`` and ``sweep``. :func:`register` adds
them to the one parser of :mod:`dsmpepc_nlp.cli`, which dispatches to ``run`` and owns the
error policy: every option is checked by its type before anything runs or is stored, and bad
input is an :class:`~dsmpepc_nlp.core.errors.InputError` (one line on stderr, exit 2).

Results of the long benchmarks go to ``--out`` (a table per run, written after every row,
continued with ``--resume``, replaced with ``--overwrite``); the summary to stdout (``--json``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from ..core import options
from ..core.errors import InputError
from ..core.jsonio import json_clean
from ..core.progress import EpisodeProgress, say
from ..core.solver_config import SOLVER_NAMES, LocalSolverSettings, SolverConfig
from ..sim.scenario import load_scenario
from ..sim.simulate import simulate
from ..viz import figures
from . import claims
from .crosscheck import crosscheck
from .map_timing import format_lidar_table, lidar_map_timing
from .params import parse_ipopt_options, parse_params, preset_config
from .results import parse_indices
from .suites import (
    PLANNER_VARIANTS,
    add_barn,
    add_crowd,
    add_crowdnav,
    add_scenarios,
    add_sweep,
    run_barn,
    run_crowd,
    run_crowdnav,
    run_options,
    run_scenarios,
    run_sweep,
    solver_config,
)
from .summary import summarised
from .timing import run_bench


def add_crosscheck(p) -> None:
    p.add_argument("--n-samples", type=options.positive, default=4096,
                   help="samples of the reference sampling planner")
    p.add_argument("--tol", type=options.number(0.0), default=0.01,
                   help="gap counted as 'as good'")


def run_crosscheck(args) -> int:
    if args.solver == "sampling":
        raise InputError("crosscheck --solver: must be nlp or fast (sampling is the reference)")
    scenario = load_scenario(args.scenario)
    config = preset_config(args.preset, args.variant)
    solver = solver_config(args.solver)
    progress = EpisodeProgress(f"{scenario.name} {args.variant} episode (sampling)")
    episode = simulate(scenario, config, SolverConfig.sampling(), np.random.default_rng(args.seed),
                       record_trajectories=False, progress=progress)
    progress.done(", ".join(episode.outcomes))
    cycles = episode.planning_inputs(0)
    robot_config = episode.config()
    if scenario.agents[0].robot is not None:
        robot_config = dataclasses.replace(robot_config, robot=scenario.agents[0].robot)
    say(f"[crosscheck] {len(cycles)} cycles, {args.solver} vs sampling "
        f"({args.n_samples} samples)")
    started = time.perf_counter()
    dock = scenario.agents[0].goal.kind == "fixed" or robot_config.docking.follow  # as simulate
    result = crosscheck(cycles, robot_config, solver, args.n_samples, args.tol, dock)
    stem = f"{scenario.name}-{args.variant}-crosscheck-{args.solver}-seed{args.seed}"
    figure = figures().crosscheck_figure(result.gap, path=Path(args.out) / f"{stem}.png")
    summary = dict(result.to_dict(), scenario=scenario.name, variant=args.variant,
                   solver=args.solver, seed=args.seed, wall_time=time.perf_counter() - started,
                   statuses={s: result.nlp_status.count(s) for s in set(result.nlp_status)},
                   figure=str(figure))
    if args.json:
        print(json.dumps(json_clean(summary), allow_nan=False))
        return 0
    print(f"{result.describe()}; NLP plan statuses {summary['statuses']}")
    print(f"figure: {figure}")
    return 0


def add_bench(p) -> None:
    p.add_argument("--cycles", type=options.positive, default=20, help="planning cycles to time")
    p.add_argument("--seed", type=options.seed, default=0)
    p.add_argument("--json", action="store_true", help="print JSON on stdout")
    p.add_argument("--ipopt-option", action="append", default=[], metavar="KEY=VALUE",
                   help="an IPOPT option for the default planner, e.g. max_soc=4 (repeatable; "
                        "to time a setting against the defaults)")
    p.add_argument("--lidar-map", action="store_true",
                   help="instead: the default planner on a map a simulated lidar builds and "
                        "changes every cycle, beside the same plans on the known map")


def run_timing(args) -> int:
    solver_config("nlp")
    options = parse_ipopt_options(args.ipopt_option)
    default = SolverConfig(local=LocalSolverSettings(options=options))
    if args.lidar_map:
        say(f"[bench] {args.cycles} cycles of the crowded demo scene, known and lidar maps")
        result = lidar_map_timing(args.cycles, args.seed, solver=default)
        print(json.dumps(json_clean(result), allow_nan=False) if args.json
              else format_lidar_table(result))
        return 0
    say(f"[bench] timing {args.cycles} cycles of the crowded demo scene")
    result = run_bench(n_cycles=args.cycles, seed=args.seed, default=default)
    result["ipopt_options"] = dict(default.local.options)
    if args.json:
        print(json.dumps(json_clean(result), allow_nan=False))
    else:
        print(result["table"])
    return 0


# ---------------------------------------------------------------------------------------------
# benchmark barn | crowd | scenarios, sweep


def _values(name: str):
    """An argparse ``type``: comma-separated geometry values, each a number > 0 (m)."""
    check = options.number(0.0, low_open=True, high=100.0, unit=" m")

    def convert(text: str) -> tuple:
        values = tuple(check(part) for part in text.split(",") if part.strip())
        if not values:
            raise argparse.ArgumentTypeError(f"{text!r}: give at least one value")
        return values

    convert.__name__ = name
    return convert


def add_claims(p) -> None:
    p.add_argument("--families", default=",".join(claims.families.FAMILIES),
                   help="comma-separated families (default: all of "
                        f"{', '.join(claims.families.FAMILIES)})")
    p.add_argument("--variants", nargs="+", default=list(claims.CLAIM_VARIANTS),
                   choices=PLANNER_VARIANTS)
    p.add_argument("--solvers", nargs="+", default=list(claims.CLAIM_SOLVERS), choices=SOLVER_NAMES)
    p.add_argument("--seeds", default="0-4", help="seeds: 0-4, 0,5,7 (default 0-4)")
    p.add_argument("--quick", action="store_true",
                   help="the small grid of each family (3 values of the first axis, one of the "
                        "second)")
    p.add_argument("--axis", type=_values("axis"), default=None, metavar="V1,V2,...",
                   help="values of the first geometry axis (gap, width, door; m), replacing "
                        "the families' grid")
    p.add_argument("--axis2", type=_values("axis2"), default=None, metavar="V1,V2,...",
                   help="values of the second geometry axis (width, length, offset; m)")
    p.add_argument("--cells", default=None, metavar="FAMILY:X:Y,...",
                   help="run exactly these cells (e.g. t-corridor:1.0:1.8,narrow-corridor:"
                        "1.4:12.6), instead of --families/--axis/--axis2")
    p.add_argument("--set", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="replace a PlannerConfig field, as sweep --param (s_ttc=0.25,0.5, "
                        "robot.v_limit=1.5, stall.levels=0); several values or several --set: "
                        "every combination is a setting run for every cell")
    p.add_argument("--duration", type=options.number(0.0, low_open=True), default=None,
                   help="cap on every episode's length, s (default: the family's)")
    p.add_argument("--samples", type=options.positive, default=None,
                   help="samples per plan of the sampling solver, >= 1 (default: SolverConfig's)")
    p.add_argument("--no-examples", action="store_true",
                   help="skip re-running one differing run for the example figure")
    run_options(p, "results/claims", scheduler=False)


def run_claims(args) -> dict:
    names = [n for n in args.families.split(",") if n]
    for name in names:
        claims.families.family(name)
    if not names:
        raise InputError("--families: give at least one family")
    for solver in set(args.solvers):
        solver_config(solver)
    if args.cells is not None:
        cells = claims.families.parse_cells(args.cells, "--cells")
    else:
        cells = [(name, float(x), float(y)) for name in names
                 for y in (args.axis2 or _grid(name, args.quick)[1])
                 for x in (args.axis or _grid(name, args.quick)[0])]
    settings = claims.ClaimSettings(n_samples=args.samples, duration=args.duration)
    return claims.run_claims(cells, args.variants, args.solvers,
                             parse_indices(args.seeds, "--seeds"), settings, args.out,
                             workers=args.workers, resume=args.resume,
                             overwrite=args.overwrite, examples=not args.no_examples,
                             params=parse_params(args.set))



def _grid(name: str, quick: bool) -> tuple:
    family = claims.families.family(name)
    return (family.quick, family.quick2) if quick else (family.values, family.values2)


def register(sub, scenario_options) -> None:
    """Add ``crosscheck``, ``bench``, ``benchmark {barn,crowd,scenarios}`` and ``sweep`` to the
    subparsers ``sub``; ``scenario_options(parser)`` adds the scenario/variant/solver/seed/out
    options shared with ``run``. Each parser's ``func`` is the command to dispatch to."""
    p = sub.add_parser("crosscheck", help="NLP vs sampling (exact costs) on every cycle of an "
                       "episode of SCENARIO (first robot; the episode is driven by the sampler)")
    scenario_options(p, sensing=False)   # the episode is driven by the sampler on the truth
    add_crosscheck(p)
    p.set_defaults(func=run_crosscheck)
    p = sub.add_parser("bench", help="time the planners (IPOPT, fast NLP, sampling at equal "
                       "cost) on the crowded demo scene")
    add_bench(p)
    p.set_defaults(func=run_timing)
    bench = sub.add_parser("benchmark", help="run a benchmark suite: BARN, ETH/UCY crowds, or "
                           "variants side by side on scenarios",
                           description="Run BARN worlds, ETH/UCY crowd crossings or planner "
                           "variants side by side on YAML scenarios.")
    kinds = bench.add_subparsers(dest="benchmark", required=True, parser_class=type(bench))
    for name, text, add, run in (
            ("barn", "BARN Challenge worlds (static clutter, Jackal)", add_barn, run_barn),
            ("crowd", "ETH/UCY pedestrians replayed around a crossing robot", add_crowd,
             run_crowd),
            ("crowdnav", "CrowdNav protocol: circle or square crossing among ORCA humans",
             add_crowdnav, run_crowdnav),
            ("scenarios", "planner variants (and ORCA) on YAML scenarios", add_scenarios,
             run_scenarios)):
        p = kinds.add_parser(name, help=text)
        add(p)
        p.set_defaults(func=summarised(run))
    p = sub.add_parser("sweep", help="grid of cost parameters x scenarios x seeds",
                       description="Run a parameter grid; tables and heatmaps.")
    add_sweep(p)
    p.set_defaults(func=summarised(run_sweep))
    p = sub.add_parser("claims", help="the claim map: variants x solvers on generated "
                       "T-corridor, narrow-corridor and doorway geometry",
                       description="Run the scenario families cell by cell; tables, a figure "
                       "and an example where the variants differ.")
    add_claims(p)
    p.set_defaults(func=summarised(run_claims))
