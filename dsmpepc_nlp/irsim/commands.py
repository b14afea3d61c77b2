"""``dsmpepc irsim WORLD.yaml``: run an IR-SIM world with the planner driving its robot.

Registered by :mod:`dsmpepc_nlp.cli`; the runner (and IR-SIM) are imported only when the
command runs, so the command line starts without IR-SIM installed and says how to install it
when the command is used.
"""

from __future__ import annotations

import argparse
import json

from ..core import options
from ..core.config import VARIANTS
from ..core.solver_config import SOLVER_NAMES

SENSING_CHOICES = ("oracle", "lidar", "tracked")
"""The ``--sensing`` values (:data:`dsmpepc_nlp.irsim.adapter.SENSING`)."""

EPILOG = """The run ends by IR-SIM's own judgement: the robot's arrive flag (success) or collision
flag (collision), or the time limit (timeout): --max-time, else the world file's
custom: {max_time: SECONDS}, else 60 s. Table columns as for 'dsmpepc run' (docs/glossary.md);
docs/irsim.md has the adapter's API and the example worlds (examples/irsim/)."""


def register(sub, print_table) -> None:
    """Add the ``irsim`` subcommand to the ``sub`` parsers; ``print_table(rows)`` formats
    ``(label, metrics)`` rows as the other commands' tables do."""
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
    p.add_argument("--gif", action="store_true", help="also write IR-SIM's animation")
    p.add_argument("--out", default="out", help="folder for the episode log and the GIF")
    p.add_argument("--json", action="store_true", help="print JSON on stdout")
    p.set_defaults(func=lambda args: cmd_irsim(args, print_table))


def cmd_irsim(args, print_table) -> int:
    """Run the world; print the table (or one JSON object); exit status 0."""
    from .runner import run_world

    summary = run_world(args.world, sensing=args.sensing, variant=args.variant,
                        solver=args.solver, seed=args.seed, out=args.out, gif=args.gif,
                        max_time=args.max_time)
    if args.json:
        print(json.dumps(summary, allow_nan=False))
        return 0
    print(print_table([(args.variant, m) for m in summary["metrics"]]))
    for kind, path in summary["files"].items():
        print(f"{kind}: {path}")
    return 0
