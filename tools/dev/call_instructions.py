"""Instructions a call of the compiled cost and of its gradient, this checkout against another
revision, counted by valgrind's callgrind: repeatable where wall time on a shared machine is not.

Wall time a plan moves by 0.3 between runs of the same two commits on this machine
(docs/experiments/2026-11-28-docking-along-the-laws-curves.md), so a 5 % change in what one
IPOPT iteration computes cannot be read from ``tools/dev/bench_pairs.py``. Callgrind counts the
instructions executed instead, the same count for the same binary and inputs whatever else the
machine runs. This script checks ``BASE`` out
into a temporary git worktree, then for each side (``PYTHONPATH`` the worktree or this
checkout, run from a folder outside both) runs :data:`PROGRAM` once plainly (it compiles what
the side's cache lacks) and once under ``valgrind --tool=callgrind``, collecting only inside
the compiled objective and gradient that IPOPT calls (``F_of_z``/``G_of_z``; ``Fb``/``Gb`` in
revisions before the compile-per-structure change). The program plans the last of the demo's
first ``--cycles`` cycles (docking off) with a default planner: the solves' calls are counted::

    python tools/dev/call_instructions.py 932845c
    python tools/dev/call_instructions.py HEAD        # the same code both sides: 1.000
    python tools/dev/call_instructions.py 932845c --out /tmp/ci
    callgrind_annotate /tmp/ci/base.callgrind; callgrind_annotate /tmp/ci/this.callgrind

With ``--out`` the two callgrind files are kept, so that ``callgrind_annotate`` can say where
each side's instructions go, function by function (how
docs/experiments/2026-11-28-a-cheaper-graph-an-iteration.md splits what is left between ``pow``
and the drivers).

It prints, per side, the calls and instructions a call of the cost (F) and of the cost with
its gradient (G), and the ratios this / base. valgrind must be installed (Debian:
``apt-get install valgrind``); the two sides run at once: 4 to 15 minutes on two cores
here (the side of 932845c took the 15). Each side
runs at its own defaults, as ``dsmpepc bench`` does. The counts are instructions, not seconds:
a ``pow`` and an addition count alike, so read them beside the wall time, not instead of it.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]     # the checkout: this file is tools/dev/

FUNCTIONS = {"F": ("F_of_z", "Fb"), "G": ("G_of_z", "Gb")}
"""The compiled functions counted: the cost alone and with its gradient, by the names of this
checkout and of revisions before the compile-per-structure change."""

PROGRAM = """
import os, sys
os.environ["DSMPEPC_COMPILE"] = "wait"
from dsmpepc_nlp import Planner, PlannerConfig, SolverConfig
from dsmpepc_nlp.bench.scenes import demo_cycles
config = PlannerConfig()
state, world, goal = demo_cycles(config, CYCLES, 0)[-1]
Planner(config, SolverConfig()).plan(state, world, goal, dock=False)
"""
"""What each side runs (``CYCLES`` replaced by ``--cycles``), using only what every revision
since the issue's has."""

_NAMED = re.compile(r"(c?fn)=\((\d+)\)(?: (.*))?$")


def calls(text: str, names) -> dict:
    """Per function of ``names`` called in a callgrind output ``text``: ``(calls, inclusive
    instructions)`` summed over its call sites (callgrind's compressed names resolved)."""
    known, callee, out = {}, None, {}
    lines = text.splitlines()
    for i, line in enumerate(lines):
        named = _NAMED.match(line)
        if named:
            kind, number, name = named.groups()
            if name:
                known[number] = name
            if kind == "cfn":
                callee = known.get(number)
            continue
        if line.startswith("calls=") and callee in names and i + 1 < len(lines):
            count = int(line.split("=", 1)[1].split()[0])
            cost = int(lines[i + 1].split()[1])
            total = out.setdefault(callee, [0, 0])
            total[0] += count
            total[1] += cost
    return {name: tuple(total) for name, total in out.items()}


def per_call(text: str) -> dict:
    """``{"F": {...}, "G": {...}}``: calls and instructions a call of each of
    :data:`FUNCTIONS` (whichever of its names the side's library has)."""
    found = calls(text, {n for names in FUNCTIONS.values() for n in names})
    result = {}
    for key, names in FUNCTIONS.items():
        count = sum(found.get(n, (0, 0))[0] for n in names)
        cost = sum(found.get(n, (0, 0))[1] for n in names)
        result[key] = {"calls": count, "instructions_per_call": cost / count if count else None}
    return result


def command(source: Path, cycles: int, out: Path | None) -> tuple:
    """The side's command line and environment; under callgrind when ``out`` is a file."""
    env = {"PYTHONPATH": str(source)}
    program = ["-c", PROGRAM.replace("CYCLES", str(int(cycles)))]
    if out is None:
        return [sys.executable, *program], env
    toggles = [f"--toggle-collect={n}" for names in FUNCTIONS.values() for n in names]
    return (["valgrind", "--tool=callgrind", *toggles, f"--callgrind-out-file={out}",
             sys.executable, *program], env)


def run_sides(sides: dict, cycles: int, folder: Path) -> dict:
    """Warm each side, then count both at once; per side, :func:`per_call`."""
    for source in sides.values():
        args, env = command(source, cycles, None)
        subprocess.run(args, cwd=folder, env=dict(os.environ, **env), check=True,
                       capture_output=True)
    running = {}
    for side, source in sides.items():
        args, env = command(source, cycles, folder / f"{side}.callgrind")
        running[side] = subprocess.Popen(args, cwd=folder, env=dict(os.environ, **env),
                                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                         text=True)
    results = {}
    for side, process in running.items():
        _, err = process.communicate()
        if process.returncode != 0:
            raise SystemExit(f"{side} failed under callgrind (status {process.returncode}):\n"
                             f"{err[-2000:]}")
        results[side] = per_call((folder / f"{side}.callgrind").read_text())
    return results


def ratios(results: dict) -> dict:
    """this / base instructions a call, per function (None where a side made no call)."""
    out = {}
    for key in FUNCTIONS:
        a = results["base"][key]["instructions_per_call"]
        b = results["this"][key]["instructions_per_call"]
        out[key] = b / a if a and b else None
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("base", help="the revision to compare against (a commit, tag or branch)")
    parser.add_argument("--cycles", type=int, default=3,
                        help="plan the last of the demo's first CYCLES cycles (default 3)")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.add_argument("--out", help="keep the callgrind files (base.callgrind, "
                        "this.callgrind) in this folder")
    args = parser.parse_args(argv)
    if args.cycles < 1:
        parser.error("--cycles must be at least 1")
    if shutil.which("valgrind") is None:
        parser.error("valgrind is not installed (Debian: apt-get install valgrind)")
    with tempfile.TemporaryDirectory(prefix="call-instructions-") as folder:
        worktree = Path(folder) / "base"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(worktree),
                        args.base], check=True, capture_output=True)
        try:
            results = run_sides({"base": worktree, "this": REPO}, args.cycles, Path(folder))
            if args.out:
                Path(args.out).mkdir(parents=True, exist_ok=True)
                for side in ("base", "this"):
                    shutil.copy(Path(folder) / f"{side}.callgrind", Path(args.out))
        finally:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force",
                            str(worktree)], check=False, capture_output=True)
    result = {"base": args.base, "sides": results, "ratios": ratios(results)}
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    print(f"this checkout against {args.base}: instructions a call (callgrind)")
    for key, label in (("F", "cost (F)"), ("G", "cost and gradient (G)")):
        base, this = results["base"][key], results["this"][key]
        ratio = result["ratios"][key]
        print(f"{label:24s} base {base['instructions_per_call'] or 0:10.0f} "
              f"({base['calls']} calls)   this {this['instructions_per_call'] or 0:10.0f} "
              f"({this['calls']} calls)   ratio {ratio if ratio else float('nan'):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
