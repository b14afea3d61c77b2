"""``dsmpepc irsim WORLD.yaml``: run an IR-SIM world with the planner driving its robot;
``dsmpepc benchmark irsim --worlds ...``: many worlds and seeds into a result table;
``dsmpepc irsim-export barn``: BARN worlds as IR-SIM world files.

Registered by :mod:`dsmpepc_nlp.cli` (``benchmark irsim`` as one more kind of the ``benchmark``
command, which :mod:`dsmpepc_nlp.bench.commands` adds first: bench sits below irsim and cannot
name it). IR-SIM itself is imported only when a command runs, so the command line starts
without IR-SIM installed and says how to install it when a command needs it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..bench.barn import DEFAULT_V_LIMIT
from ..bench.results import parse_indices
from ..bench.suites import budget_option, run_options
from ..bench.summary import summarised
from ..core import options
from ..core.config import VARIANTS
from ..core.solver_config import SOLVER_NAMES
from .export import CYLINDERS, export_barn

SENSING_CHOICES = ("oracle", "lidar", "tracked")
"""The ``--sensing`` values (:data:`dsmpepc_nlp.irsim.adapter.SENSING`)."""

EPILOG = """The run ends by IR-SIM's own judgement: the robot's arrive flag (success) or collision
flag (collision), or the time limit (timeout): --max-time, else the world file's
custom: {max_time: SECONDS}, else 60 s. Table columns as for 'dsmpepc run' (docs/glossary.md);
docs/irsim.md has the adapter's API and the example worlds (examples/irsim/)."""


def register(sub, print_table) -> None:
    """Add ``irsim`` and ``irsim-export`` to the ``sub`` parsers, and ``irsim`` to the kinds of
    ``benchmark`` when that command is there; ``print_table(rows)`` formats ``(label,
    metrics)`` rows as the other commands' tables do."""
    _register_run(sub, print_table)
    _register_export(sub)
    kinds = _benchmark_kinds(sub)
    if kinds is not None:
        p = kinds.add_parser("irsim", help="IR-SIM world files x seeds under IR-SIM's own "
                             "judgement (needs the irsim extra)", epilog=BENCHMARK_EPILOG,
                             formatter_class=argparse.RawDescriptionHelpFormatter)
        add_benchmark(p)
        p.set_defaults(func=summarised(run_benchmark))


def _benchmark_kinds(sub):
    """The subparsers action of the ``benchmark`` command among ``sub``'s parsers, or None."""
    bench = sub.choices.get("benchmark")
    if bench is None:
        return None
    return next((a for a in bench._actions if isinstance(a, argparse._SubParsersAction)), None)


def _register_run(sub, print_table) -> None:
    p = sub.add_parser("irsim", help="run an IR-SIM world file with the planner driving its "
                       "robot (needs the irsim extra)", epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("world", help="IR-SIM world YAML file")
    p.add_argument("--sensing", choices=SENSING_CHOICES, default="oracle",
                   help="oracle (the exact map and the true moving objects, default), lidar "
                        "(IR-SIM's lidar scan into the local map, no prior map), tracked "
                        "(people through the tracker from noisy positions)")
    p.add_argument("--variant", choices=list(VARIANTS), default="ds-mpepc")
    p.add_argument("--solver", choices=SOLVER_NAMES, default="nlp",
                   help="nlp (IPOPT, default), fast (trust-region Newton) or sampling")
    p.add_argument("--seed", type=options.seed, default=0,
                   help="seed of IR-SIM's random generator and of the detection noise")
    p.add_argument("--max-time", type=options.number(0.0, low_open=True, unit=" s"),
                   default=None, metavar="SECONDS", help="time limit of the run, s")
    budget_option(p)
    p.add_argument("--gif", action="store_true", help="also write IR-SIM's animation")
    p.add_argument("--out", default="out", help="folder for the episode log and the GIF")
    p.add_argument("--json", action="store_true", help="print JSON on stdout")
    p.set_defaults(func=lambda args: cmd_irsim(args, print_table))


def cmd_irsim(args, print_table) -> int:
    """Run the world; print the table (or one JSON object); exit status 0."""
    from .runner import run_world

    summary = run_world(args.world, sensing=args.sensing, variant=args.variant,
                        solver=args.solver, seed=args.seed, out=args.out, gif=args.gif,
                        max_time=args.max_time, time_budget=args.time_budget)
    if args.json:
        print(json.dumps(summary, allow_nan=False))
        return 0
    print(print_table([(args.variant, m) for m in summary["metrics"]]))
    for kind, path in summary["files"].items():
        print(f"{kind}: {path}")
    return 0


# ---------------------------------------------------------------------------------------------
# benchmark irsim, irsim-export barn

BENCHMARK_EPILOG = """One row per (world, seed) in OUT/irsim.csv and OUT/irsim.json, as the other
benchmarks write them (resumable; 'dsmpepc failures OUT' classifies the unsuccessful runs from
the episodes kept in OUT/episodes/). Outcomes are IR-SIM's: its arrive flag (success), its
collision flag (collision), else the time limit (timeout); docs/irsim.md."""


def add_benchmark(p) -> None:
    p.add_argument("--worlds", nargs="+", required=True, metavar="DIR_OR_FILE",
                   help="IR-SIM world files, or folders of them (their *.yaml)")
    p.add_argument("--seeds", default="0", help="seeds: 0-4, 0,5,7 (default 0)")
    p.add_argument("--sensing", choices=SENSING_CHOICES, default="oracle",
                   help="oracle (default), lidar (IR-SIM's lidar into the local map) or tracked")
    p.add_argument("--variant", choices=list(VARIANTS), default="ds-mpepc")
    p.add_argument("--solver", choices=SOLVER_NAMES, default="nlp",
                   help="nlp (IPOPT, default), fast or sampling")
    p.add_argument("--max-time", type=options.number(0.0, low_open=True, unit=" s"),
                   default=None, metavar="SECONDS",
                   help="time limit of every run, s (default: the world's custom.max_time, "
                        "else 60 s)")
    budget_option(p)
    run_options(p, "results/irsim")


def run_benchmark(args) -> dict:
    from . import benchmark

    settings = benchmark.IrsimSettings(variant=args.variant, solver=args.solver,
                                       sensing=args.sensing, max_time=args.max_time,
                                       time_budget=args.time_budget)
    paths = benchmark.world_paths(args.worlds)
    _, summary = benchmark.run_benchmark(settings, paths, parse_indices(args.seeds, "--seeds"),
                                         args.out, workers=args.workers,
                                         scheduler=args.scheduler, resume=args.resume,
                                         overwrite=args.overwrite)
    summary["out"] = str(Path(args.out) / "irsim.csv")
    return summary


def _register_export(sub) -> None:
    p = sub.add_parser("irsim-export", help="write worlds of another benchmark as IR-SIM "
                       "world files", description="Write benchmark worlds as IR-SIM world "
                       "files, for 'dsmpepc irsim' and 'dsmpepc benchmark irsim'.")
    sources = p.add_subparsers(dest="source", required=True, parser_class=type(p))
    q = sources.add_parser("barn", help="BARN worlds: the cylinders, the Jackal, the "
                           "challenge's start, goal and 100 s, the Hokuyo UST-10 lidar")
    q.add_argument("--data", required=True, help="BARN folder (grid_files/, path_files/)")
    q.add_argument("--worlds", default="0-299",
                   help="world indices: 0-299, 0-299:10 (every 10th), 3,7,9 (default 0-299)")
    q.add_argument("--out", required=True, help="folder the barn-N.yaml files go to")
    q.add_argument("--cylinders", choices=CYLINDERS, default="circle",
                   help="circle (the true cylinder, default) or box (its 0.15 m square, as "
                        "our simulator's map draws it)")
    q.add_argument("--v-limit", type=options.number(0.0, low_open=True, unit=" m/s"),
                   default=DEFAULT_V_LIMIT, help="the robot's speed limit, m/s (default "
                   f"{DEFAULT_V_LIMIT:g}, as 'benchmark barn')")
    q.add_argument("--overwrite", action="store_true", help="replace world files already there")
    q.add_argument("--json", action="store_true", help="print the files written as JSON")
    q.set_defaults(func=run_export)


def run_export(args) -> int:
    written = export_barn(args.data, parse_indices(args.worlds, "--worlds"), args.out,
                          v_limit=args.v_limit, cylinders=args.cylinders,
                          overwrite=args.overwrite)
    if args.json:
        print(json.dumps({"files": written}))
    else:
        print(f"{len(written)} IR-SIM world(s) in {args.out}: "
              f"{Path(written[0]).name} ... {Path(written[-1]).name}")
    return 0
