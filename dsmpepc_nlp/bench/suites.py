"""The benchmark suites' commands: ``benchmark barn | crowd | crowdnav | scenarios`` and
``sweep``, each an ``add_arguments(parser)`` / ``run(args)`` pair that :mod:`.commands` registers.

Every suite writes a resumable table to ``--out``, runs on ``--workers`` local processes or a
Dask cluster (``--scheduler tcp://HOST:PORT``), and runs its robots under a sensing profile
(``--sensing``: :mod:`dsmpepc_nlp.sim.sensing`; ``oracle``, the truth, by default).
"""

from __future__ import annotations

from pathlib import Path

from ..core import options
from ..core.config import VARIANTS
from ..core.errors import InputError
from ..core.solver_config import SOLVER_NAMES, SolverConfig
from ..sim.sensing import load_profile
from . import barn, crowdnav, crowds, params, sweep
from .params import PRESETS, overrides, parse_params
from .results import parse_indices

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





def run_options(parser, out_default: str, scheduler: bool = True) -> None:
    """The options of every command that runs a table of cases: workers (and a Dask
    scheduler), the output folder, JSON, resuming or overwriting a table."""
    parser.add_argument("--workers", type=options.positive, default=None,
                        help="parallel worker processes, >= 1 (default: number of cores)")
    if scheduler:
        parser.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                            help="run on a Dask cluster at this scheduler's address instead "
                                 "of local processes (pip install 'dsmpepc_nlp[sweep]')")
    parser.add_argument("--out", default=out_default, help=f"output folder (default {out_default})")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    parser.add_argument("--resume", action="store_true",
                        help="continue the table in --out, skipping runs already done")
    parser.add_argument("--overwrite", action="store_true",
                        help="discard a table already in --out")


def budget_option(parser) -> None:
    """``--time-budget``: each plan's deadline (``SolverConfig.time_budget``)."""
    parser.add_argument("--time-budget", type=options.time_budget, default="auto",
                        metavar="auto|none|SECONDS",
                        help="each plan's time budget (default auto: 0.75 of the control "
                             "period, 0.15 s; none: no deadline)")


def table_options(parser, out_default: str, solver_default: str = "nlp",
                   configurable: bool = False) -> None:
    if configurable:
        parser.add_argument("--preset", default="product", choices=PRESETS,
                            help="the planners' configuration: product (default) or paper")
        parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                            help="replace a field of the preset, e.g. sigma_static=0.05 (a "
                                 "CostConfig field) or stall.levels=0 (repeatable)")
    run_options(parser, out_default)
    parser.add_argument("--sensing", default="oracle", metavar="NAME|FILE",
                        help="what the robots sense: oracle (the truth, default), lidar, "
                             "tracked, realistic, or a profile YAML (docs/sensing.md)")
    parser.add_argument("--solver", default=solver_default, choices=SOLVER_NAMES,
                        help=f"planner solver (default {solver_default})")
    parser.add_argument("--samples", type=options.positive, default=None,
                        help="samples per plan of the sampling solver, >= 1 "
                             "(default: SolverConfig's)")
    budget_option(parser)


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
    table_options(p, "results/barn", configurable=True)


def run_barn(args) -> dict:
    worlds = parse_indices(args.worlds, "--worlds")
    if not Path(args.data).is_dir():
        raise InputError(f"--data {args.data!r}: not a folder")
    settings = barn.BarnSettings(data=str(Path(args.data).resolve()), variant=args.variant,
                                 solver=args.solver, v_limit=args.v_limit,
                                 resolution=args.resolution, time_limit=args.time_limit,
                                 n_samples=args.samples, time_budget=args.time_budget,
                                 overrides=overrides(args.set),
                                 preset=args.preset, sensing=sensing(args))
    _, summary = barn.run_benchmark(settings, worlds, args.out, workers=args.workers,
                                    scheduler=args.scheduler, resume=args.resume,
                                    overwrite=args.overwrite)
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
    table_options(p, "results/crowd", configurable=True)


def run_crowd(args) -> dict:
    settings = crowds.CrowdSettings(data=str(Path(args.data).resolve()), scene=args.scene,
                                    solver=args.solver, n_samples=args.samples,
                                    time_budget=args.time_budget,
                                    preset=args.preset, overrides=overrides(args.set),
                                    goal_clear=args.goal_clear, duration=args.duration,
                                    sensing=sensing(args))
    return crowds.run_benchmark(settings, args.variants, args.episodes, args.seed, args.out,
                                workers=args.workers, scheduler=args.scheduler,
                                resume=args.resume, overwrite=args.overwrite)


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
    table_options(p, "results/crowdnav", configurable=True)


def run_crowdnav(args) -> dict:
    settings = crowdnav.CrowdNavSettings(scene=args.scene, setting=args.robot,
                                         humans=args.humans, solver=args.solver,
                                         n_samples=args.samples, duration=args.duration,
                                         time_budget=args.time_budget,
                                         preset=args.preset, overrides=overrides(args.set),
                                         sensing=sensing(args))
    if args.solver != "sampling":
        solver_config(args.solver)  # fail early when the NLP cannot be loaded
    return crowdnav.run_benchmark(settings, args.variants, args.episodes, args.seed, args.out,
                                  workers=args.workers, scheduler=args.scheduler,
                                  resume=args.resume, overwrite=args.overwrite)


def _grid_options(p, out_default: str) -> None:
    p.add_argument("--scenarios", required=True,
                   help="comma-separated scenario names (scenarios/*.yaml) or YAML paths")
    p.add_argument("--seeds", default="0", help="seeds: 0-4, 0,5,7 (default 0)")
    p.add_argument("--start-noise", type=options.number(0.0, unit=" m"), default=None,
                   help="start-position noise, m (std, >= 0), replacing the scenarios' own so "
                        "that seeds differ (default: the scenario's)")
    p.add_argument("--preset", default="product", choices=PRESETS, help="product or paper")
    table_options(p, out_default)


def add_scenarios(p) -> None:
    p.add_argument("--variants", nargs="+", default=["mpepc", "ds-mpepc", "orca"])
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="replace a field of the preset, e.g. docking.follow=0 (repeatable)")
    _grid_options(p, "results/scenarios")


def run_scenarios(args) -> dict:
    settings = sweep.SweepSettings(solver=args.solver, n_samples=args.samples,
                                   time_budget=args.time_budget,
                                   start_noise=args.start_noise, preset=args.preset,
                                   sensing=sensing(args))
    return sweep.run_scenarios(args.variants, [s for s in args.scenarios.split(",") if s],
                               parse_indices(args.seeds, "--seeds"), settings, args.out,
                               workers=args.workers, scheduler=args.scheduler,
                               resume=args.resume, overwrite=args.overwrite,
                               params=dict(overrides(args.set)))


def add_sweep(p) -> None:
    p.add_argument("--param", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="a CostConfig field and its values (repeatable)")
    p.add_argument("--variant", default="ds-mpepc", choices=PLANNER_VARIANTS)
    _grid_options(p, "results/sweep")


def run_sweep(args) -> dict:
    settings = sweep.SweepSettings(variant=args.variant, solver=args.solver,
                                   n_samples=args.samples, start_noise=args.start_noise,
                                   time_budget=args.time_budget,
                                   preset=args.preset, sensing=sensing(args))
    return sweep.run_sweep(parse_params(args.param), [s for s in args.scenarios.split(",") if s],
                           parse_indices(args.seeds, "--seeds"), settings, args.out,
                           workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                           overwrite=args.overwrite)


def sensing(args) -> str:
    """``--sensing`` as given, after checking that it names a built-in profile or a valid
    profile file (an InputError naming the file and the field otherwise): workers load it
    again, so a bad file fails here, before anything runs."""
    load_profile(args.sensing)
    return args.sensing
