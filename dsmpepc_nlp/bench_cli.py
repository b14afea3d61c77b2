"""Command line of the benchmarks and sweeps: ``dsmpepc benchmark ...``, ``dsmpepc sweep``.

``benchmark barn`` (BARN worlds), ``benchmark crowd`` (ETH/UCY crossings), ``benchmark
scenarios`` (planner variants and ORCA side by side on YAML scenarios) and ``sweep``.
``register(subparsers)`` adds them to the ``dsmpepc`` parser; ``main(argv)`` runs them
stand-alone. Results go to ``--out`` (one table per run, written atomically after every row);
progress goes to stderr, the summary to stdout (``--json``: one JSON object).

Resuming: a folder that already holds a table is never overwritten silently. ``--resume``
continues it (rows already there are skipped, keyed by world / episode / parameters + scenario +
seed); ``--overwrite`` starts over; with neither, the command stops with an error saying so.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from .core.errors import InputError
from .bench.results import dumps, parse_indices

EXIT_BAD_INPUT = 2


def _common(parser, out_default: str) -> None:
    parser.add_argument("--workers", type=int, default=None,
                        help="parallel worker processes (default: number of cores)")
    parser.add_argument("--out", default=out_default, help=f"output folder (default {out_default})")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    parser.add_argument("--resume", action="store_true",
                        help="continue the table in --out, skipping runs already done")
    parser.add_argument("--overwrite", action="store_true",
                        help="discard a table already in --out")
    parser.add_argument("--solver", default="nlp", choices=("nlp", "fast", "sampling"),
                        help="planner solver (default nlp)")
    parser.add_argument("--samples", type=int, default=None,
                        help="samples per plan of the sampling solver (default: SolverConfig's)")


def register(subparsers) -> None:
    """Add ``benchmark`` (with ``barn`` and ``crowd``) and ``sweep`` to a subparsers object."""
    from .bench.barn import DEFAULT_RESOLUTION, DEFAULT_V_LIMIT, TIME_LIMIT

    bench = subparsers.add_parser("benchmark", help="run a public benchmark",
                                  description="Run BARN worlds, ETH/UCY crowd crossings or "
                                  "planner variants side by side on YAML scenarios.")
    kinds = bench.add_subparsers(dest="benchmark", required=True)

    barn = kinds.add_parser("barn", help="BARN Challenge worlds (static clutter, Jackal)")
    barn.add_argument("--data", required=True, help="BARN folder (grid_files/, path_files/, ...)")
    barn.add_argument("--worlds", default="0-299",
                      help="world indices: 0-299, 0-299:6 (every 6th), 3,7,9 (default 0-299)")
    barn.add_argument("--variant", default="ds-mpepc",
                      choices=("mpepc", "ds-mpepc", "pc-only", "terminal-only"))
    barn.add_argument("--v-limit", type=float, default=DEFAULT_V_LIMIT,
                      help=f"speed limit, m/s (default {DEFAULT_V_LIMIT}; the Jackal allows 2)")
    barn.add_argument("--resolution", type=float, default=DEFAULT_RESOLUTION,
                      help=f"map cell side, m (default {DEFAULT_RESOLUTION})")
    barn.add_argument("--time-limit", type=float, default=TIME_LIMIT)
    barn.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                      help="replace a configuration field, e.g. sigma_static=0.05 (a CostConfig "
                           "field) or docking.radius=1.5 (repeatable)")
    _common(barn, "results/barn")
    barn.set_defaults(run=_run_barn, command_main=execute)

    crowd = kinds.add_parser("crowd", help="ETH/UCY pedestrians replayed around a crossing robot")
    crowd.add_argument("--data", required=True, help="ETH/UCY folder (<scene>/test/*.txt)")
    crowd.add_argument("--scene", required=True, help="eth, hotel, univ, zara1, zara2 or a file")
    crowd.add_argument("--episodes", type=int, default=20)
    crowd.add_argument("--seed", type=int, default=0)
    crowd.add_argument("--variants", nargs="+", default=["mpepc", "ds-mpepc"],
                       help="mpepc, ds-mpepc, pc-only, terminal-only, orca")
    crowd.add_argument("--duration", type=float, default=None,
                       help="episode length, s (default: crowds.DEFAULT_DURATION)")
    _common(crowd, "results/crowd")
    crowd.set_defaults(run=_run_crowd, command_main=execute)

    scen = kinds.add_parser("scenarios", help="planner variants (and ORCA) on YAML scenarios")
    scen.add_argument("--scenarios", required=True,
                      help="comma-separated scenario names (scenarios/*.yaml) or YAML paths")
    scen.add_argument("--variants", nargs="+", default=["mpepc", "ds-mpepc", "orca"])
    scen.add_argument("--seeds", default="0", help="seeds: 0-4, 0,5,7 (default 0)")
    scen.add_argument("--start-noise", type=float, default=None,
                      help="start-position noise, m (std), replacing the scenarios' own")
    scen.add_argument("--scheduler", default=None, help="address of a Dask scheduler")
    _common(scen, "results/scenarios")
    scen.set_defaults(run=_run_scenarios, command_main=execute)

    sweep = subparsers.add_parser("sweep", help="grid of cost parameters x scenarios x seeds",
                                  description="Run a parameter grid; tables and heatmaps.")
    sweep.add_argument("--param", action="append", default=[], metavar="NAME=V1,V2,...",
                       help="a CostConfig field and its values (repeatable)")
    sweep.add_argument("--scenarios", required=True,
                       help="comma-separated scenario names (scenarios/*.yaml) or YAML paths")
    sweep.add_argument("--seeds", default="0", help="seeds: 0-2, 0,5,7 (default 0)")
    sweep.add_argument("--variant", default="ds-mpepc",
                       choices=("mpepc", "ds-mpepc", "pc-only", "terminal-only"))
    sweep.add_argument("--start-noise", type=float, default=None,
                       help="start-position noise, m (std), replacing the scenarios' own so "
                            "that seeds differ (default: the scenario's)")
    sweep.add_argument("--scheduler", default=None,
                       help="address of a Dask scheduler (tcp://host:8786); default: processes")
    _common(sweep, "results/sweep")
    sweep.set_defaults(run=_run_sweep, command_main=execute)


def _run_barn(args) -> dict:
    from .bench.barn import BarnSettings, run_benchmark

    worlds = parse_indices(args.worlds, "--worlds")
    if not Path(args.data).is_dir():
        raise InputError(f"--data {args.data!r}: not a folder")
    settings = BarnSettings(data=str(Path(args.data).resolve()), variant=args.variant,
                            solver=args.solver, v_limit=args.v_limit,
                            resolution=args.resolution, time_limit=args.time_limit,
                            n_samples=args.samples, overrides=_overrides(args.set))
    rows, summary = run_benchmark(settings, worlds, args.out, workers=args.workers,
                                  resume=args.resume, overwrite=args.overwrite)
    summary["out"] = str(Path(args.out) / "barn.csv")
    return summary


def _overrides(specs) -> tuple:
    from .bench.sweep import parse_params

    params = parse_params(specs)
    for name, values in params.items():
        if len(values) != 1:
            raise InputError(f"--set {name}: give one value, not {len(values)}")
    return tuple((name, values[0]) for name, values in params.items())


def _run_crowd(args) -> dict:
    from .bench.crowds import CrowdSettings, run_benchmark

    settings = CrowdSettings(data=str(Path(args.data).resolve()), scene=args.scene,
                             solver=args.solver, n_samples=args.samples,
                             **({"duration": args.duration} if args.duration else {}))
    summary = run_benchmark(settings, args.variants, args.episodes, args.seed, args.out,
                            workers=args.workers, resume=args.resume, overwrite=args.overwrite)
    return summary


def _run_sweep(args) -> dict:
    from .bench.sweep import SweepSettings, parse_params, run_sweep

    params = parse_params(args.param)
    scenarios = [s for s in args.scenarios.split(",") if s]
    settings = SweepSettings(variant=args.variant, solver=args.solver, n_samples=args.samples,
                             start_noise=args.start_noise)
    return run_sweep(params, scenarios, parse_indices(args.seeds, "--seeds"), settings,
                     args.out, workers=args.workers, scheduler=args.scheduler,
                     resume=args.resume, overwrite=args.overwrite)


def _run_scenarios(args) -> dict:
    from .bench.sweep import SweepSettings, run_scenarios

    settings = SweepSettings(solver=args.solver, n_samples=args.samples,
                             start_noise=args.start_noise)
    return run_scenarios(args.variants, [s for s in args.scenarios.split(",") if s],
                         parse_indices(args.seeds, "--seeds"), settings, args.out,
                         workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                         overwrite=args.overwrite)


def _print_summary(summary: dict, as_json: bool) -> None:
    if as_json:
        print(dumps(summary).replace("\n", "").replace(" ", ""))
        return
    for key, value in summary.items():
        if isinstance(value, dict):
            print(f"{key}:")
            for k, v in value.items():
                print(f"  {k}: {_fmt(v)}")
        else:
            print(f"{key}: {_fmt(value)}")


def _fmt(value):
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.4g}"
    if isinstance(value, dict):
        return json.dumps({k: _fmt(v) for k, v in value.items()})
    return str(value)


def execute(args) -> int:
    """Run parsed ``args`` of one of the subcommands; the exit status."""
    try:
        summary = args.run(args)
    except (ValueError, FileExistsError, ImportError) as exc:
        print(f"dsmpepc: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    _print_summary(summary, args.json)
    return 0


def main(argv=None) -> int:
    """Stand-alone entry point: ``python -m dsmpepc_nlp.bench_cli benchmark barn --data ...``."""
    parser = argparse.ArgumentParser(prog="dsmpepc")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return execute(args)


if __name__ == "__main__":
    sys.exit(main())
