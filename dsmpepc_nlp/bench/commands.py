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
from ..core.config import VARIANTS
from ..core.errors import InputError
from ..core.jsonio import json_clean
from ..core.progress import EpisodeProgress, say
from ..core.solver_config import SOLVER_NAMES, LocalSolverSettings, SolverConfig
from ..sim.scenario import load_scenario
from ..sim.simulate import simulate
from ..viz import figures
from . import barn, claims, crowdnav, crowds, params, sweep
from .crosscheck import crosscheck
from .params import PRESETS, overrides, parse_ipopt_options, parse_params, preset_config
from .results import parse_indices
from .summary import summarised
from .timing import run_bench

PLANNER_VARIANTS = tuple(VARIANTS)


def solver_config(name: str, n_samples: int | None = None) -> SolverConfig:
    """``SolverConfig.named(name)`` (with ``n_samples`` for the sampler when given); an
    InputError when the NLP is asked and cannot be loaded."""
    solver = params.named_solver(name, n_samples)
    if solver.method != "sampling":
        try:
            from ..solve.optimize import multistart  # noqa: F401  (IPOPT may be missing)
        except ImportError as exc:
            raise InputError(f"--solver {name}: the NLP solver is not available ({exc}); "
                             "use --solver sampling") from None
    return solver


# ---------------------------------------------------------------------------------------------
# crosscheck and bench


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


def run_timing(args) -> int:
    solver_config("nlp")
    options = parse_ipopt_options(args.ipopt_option)
    default = SolverConfig(local=LocalSolverSettings(options=options))
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


def _table_options(parser, out_default: str, solver_default: str = "nlp",
                   configurable: bool = False) -> None:
    if configurable:
        parser.add_argument("--preset", default="product", choices=PRESETS,
                            help="the planners' configuration: product (default) or paper")
        parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                            help="replace a field of the preset, e.g. sigma_static=0.05 (a "
                                 "CostConfig field) or stall.levels=0 (repeatable)")
    parser.add_argument("--workers", type=options.positive, default=None,
                        help="parallel worker processes, >= 1 (default: number of cores)")
    parser.add_argument("--out", default=out_default, help=f"output folder (default {out_default})")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    parser.add_argument("--resume", action="store_true",
                        help="continue the table in --out, skipping runs already done")
    parser.add_argument("--overwrite", action="store_true",
                        help="discard a table already in --out")
    parser.add_argument("--solver", default=solver_default, choices=SOLVER_NAMES,
                        help=f"planner solver (default {solver_default})")
    parser.add_argument("--samples", type=options.positive, default=None,
                        help="samples per plan of the sampling solver, >= 1 "
                             "(default: SolverConfig's)")


def add_barn(p) -> None:
    p.add_argument("--data", required=True, help="BARN folder (grid_files/, path_files/, ...)")
    p.add_argument("--worlds", default="0-299",
                   help="world indices: 0-299, 0-299:6 (every 6th), 3,7,9 (default 0-299)")
    p.add_argument("--variant", default="ds-mpepc", choices=PLANNER_VARIANTS)
    p.add_argument("--v-limit", type=options.number(0.0, low_open=True),
                   default=barn.DEFAULT_V_LIMIT,
                   help=f"speed limit, m/s (default {barn.DEFAULT_V_LIMIT}; the Jackal allows 2)")
    p.add_argument("--resolution", type=options.number(0.0, low_open=True),
                   default=barn.DEFAULT_RESOLUTION,
                   help=f"map cell side, m (default {barn.DEFAULT_RESOLUTION})")
    p.add_argument("--time-limit", type=options.number(0.0, low_open=True),
                   default=barn.TIME_LIMIT)
    _table_options(p, "results/barn", configurable=True)


def run_barn(args) -> dict:
    worlds = parse_indices(args.worlds, "--worlds")
    if not Path(args.data).is_dir():
        raise InputError(f"--data {args.data!r}: not a folder")
    settings = barn.BarnSettings(data=str(Path(args.data).resolve()), variant=args.variant,
                                 solver=args.solver, v_limit=args.v_limit,
                                 resolution=args.resolution, time_limit=args.time_limit,
                                 n_samples=args.samples, overrides=overrides(args.set),
                                 preset=args.preset)
    _, summary = barn.run_benchmark(settings, worlds, args.out, workers=args.workers,
                                    resume=args.resume, overwrite=args.overwrite)
    summary["out"] = str(Path(args.out) / "barn.csv")
    return summary


def add_crowd(p) -> None:
    p.add_argument("--data", required=True, help="ETH/UCY folder (<scene>/test/*.txt)")
    p.add_argument("--scene", required=True, help="eth, hotel, univ, zara1, zara2 or a file")
    p.add_argument("--episodes", type=options.positive, default=20)
    p.add_argument("--seed", type=options.seed, default=0)
    p.add_argument("--variants", nargs="+", default=["mpepc", "ds-mpepc"],
                   help=f"{', '.join(PLANNER_VARIANTS)}, orca, cv (constant-velocity baseline)")
    p.add_argument("--duration", type=options.number(0.0, low_open=True),
                   default=crowds.DEFAULT_DURATION,
                   help=f"episode length, s (default {crowds.DEFAULT_DURATION:g})")
    p.add_argument("--goal-clear", action="store_true", help="goals clear at the window's end")
    _table_options(p, "results/crowd", configurable=True)


def run_crowd(args) -> dict:
    settings = crowds.CrowdSettings(data=str(Path(args.data).resolve()), scene=args.scene,
                                    solver=args.solver, n_samples=args.samples,
                                    preset=args.preset, overrides=overrides(args.set),
                                    goal_clear=args.goal_clear, duration=args.duration)
    return crowds.run_benchmark(settings, args.variants, args.episodes, args.seed, args.out,
                                workers=args.workers, resume=args.resume,
                                overwrite=args.overwrite)


def add_crowdnav(p) -> None:
    p.add_argument("--scene", default="circle", choices=crowdnav.SCENES,
                   help="circle or square crossing (default circle)")
    p.add_argument("--robot", default="invisible", choices=crowdnav.SETTINGS,
                   help="whether the humans see the robot (default invisible, the standard)")
    p.add_argument("--episodes", type=options.positive, default=500,
                   help="episodes per variant (default 500, CrowdNav's test set)")
    p.add_argument("--seed", type=options.seed, default=0,
                   help="seed of the episode draws (episode k of a seed is the same for every "
                        "variant)")
    p.add_argument("--humans", type=options.positive, default=crowdnav.N_HUMANS,
                   help=f"ORCA humans (default {crowdnav.N_HUMANS})")
    p.add_argument("--variants", nargs="+", default=["mpepc", "ds-mpepc"],
                   help=f"{', '.join(PLANNER_VARIANTS)}, orca, cv (constant-velocity baseline)")
    p.add_argument("--duration", type=options.number(0.0, low_open=True),
                   default=crowdnav.DURATION,
                   help=f"episode length, s (default {crowdnav.DURATION:g}: CrowdNav's 25 s "
                        "limit times out at 24 s)")
    _table_options(p, "results/crowdnav", configurable=True)


def run_crowdnav(args) -> dict:
    settings = crowdnav.CrowdNavSettings(scene=args.scene, setting=args.robot,
                                         humans=args.humans, solver=args.solver,
                                         n_samples=args.samples, duration=args.duration,
                                         preset=args.preset, overrides=overrides(args.set))
    if args.solver != "sampling":
        solver_config(args.solver)  # fail early when the NLP cannot be loaded
    return crowdnav.run_benchmark(settings, args.variants, args.episodes, args.seed, args.out,
                                  workers=args.workers, resume=args.resume,
                                  overwrite=args.overwrite)


def _grid_options(p, out_default: str) -> None:
    p.add_argument("--scenarios", required=True,
                   help="comma-separated scenario names (scenarios/*.yaml) or YAML paths")
    p.add_argument("--seeds", default="0", help="seeds: 0-4, 0,5,7 (default 0)")
    p.add_argument("--start-noise", type=options.number(0.0, unit=" m"), default=None,
                   help="start-position noise, m (std, >= 0), replacing the scenarios' own so "
                        "that seeds differ (default: the scenario's)")
    p.add_argument("--scheduler", default=None,
                   help="address of a Dask scheduler (tcp://host:8786); default: processes")
    p.add_argument("--preset", default="product", choices=PRESETS, help="product or paper")
    _table_options(p, out_default)


def add_scenarios(p) -> None:
    p.add_argument("--variants", nargs="+", default=["mpepc", "ds-mpepc", "orca"])
    _grid_options(p, "results/scenarios")


def run_scenarios(args) -> dict:
    settings = sweep.SweepSettings(solver=args.solver, n_samples=args.samples,
                                   start_noise=args.start_noise, preset=args.preset)
    return sweep.run_scenarios(args.variants, [s for s in args.scenarios.split(",") if s],
                               parse_indices(args.seeds, "--seeds"), settings, args.out,
                               workers=args.workers, scheduler=args.scheduler,
                               resume=args.resume, overwrite=args.overwrite)


def add_sweep(p) -> None:
    p.add_argument("--param", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="a CostConfig field and its values (repeatable)")
    p.add_argument("--variant", default="ds-mpepc", choices=PLANNER_VARIANTS)
    _grid_options(p, "results/sweep")


def run_sweep(args) -> dict:
    settings = sweep.SweepSettings(variant=args.variant, solver=args.solver,
                                   n_samples=args.samples, start_noise=args.start_noise,
                                   preset=args.preset)
    return sweep.run_sweep(parse_params(args.param), [s for s in args.scenarios.split(",") if s],
                           parse_indices(args.seeds, "--seeds"), settings, args.out,
                           workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                           overwrite=args.overwrite)


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
                        "robot.v_limit=1.5, ttg_along_nf=1); several values or several --set: "
                        "every combination is a setting run for every cell")
    p.add_argument("--duration", type=options.number(0.0, low_open=True), default=None,
                   help="cap on every episode's length, s (default: the family's)")
    p.add_argument("--samples", type=options.positive, default=None,
                   help="samples per plan of the sampling solver, >= 1 (default: SolverConfig's)")
    p.add_argument("--no-examples", action="store_true",
                   help="skip re-running one differing run for the example figure")
    p.add_argument("--workers", type=options.positive, default=None,
                   help="parallel worker processes, >= 1 (default: number of cores)")
    p.add_argument("--out", default="results/claims", help="output folder (default "
                   "results/claims)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.add_argument("--resume", action="store_true",
                   help="continue the table in --out, skipping runs already done")
    p.add_argument("--overwrite", action="store_true", help="discard a table already in --out")


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
    scenario_options(p)
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
