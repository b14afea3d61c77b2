"""Leave-one-out: each default extension switched off alone, paired against the full defaults.

Runs the product's defaults and, for each extension (or family of fields that only works
together), the defaults with that extension off, on a fixed reduced report set, then pairs
every run against the defaults case by case (``dsmpepc paired``'s sign test)::

    python tools/dev/ablation.py --out ROOT --barn DATA/barn --ethucy DATA/ethucy
    python tools/dev/ablation.py --out ROOT ... --only passive dodge --sensing realistic
    python tools/dev/ablation.py --out ROOT ... --report      # the table from what is done

Plans have no deadline (``--time-budget none``), so a run's outcome does not depend on the
machine's load, and an extension that never acts in a case leaves that case as it was. Each
benchmark is run with ``--resume``: a stopped ablation goes on where it stopped. An extension
is not run on a benchmark where it cannot act (``SKIP``): following needs a followed goal (only
the hall and the L-corridor have one), and BARN has no people to dodge or be passive about. The
paper's six scenes with both variants (``scenarios``) are in the set: they are what a removal
of the turns in place lost.
``--report`` prints one markdown row per extension: per benchmark the cases only the defaults
win and only the extension-off run wins, and how much later (+) the shared successes arrive
with it off; then the sums and the collisions it adds.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys

from dsmpepc_nlp.bench.paired import compare, load

EXTENSIONS = {
    "collision-weight": ("c_collision=0.1",),
    "sigma-from-map": ("sigma_static_from_map=0",),
    "ramp-from-robot": ("control_law.r_thresh_from_robot=0", "control_law.r_thresh=1.2"),
    "dock-from-reach": ("docking.radius_from_reach=0",),
    "dock-arrival-radius": ("docking.arrival_radius=0",),
    "dock-follow": ("docking.follow=0",),
    "dock-turn-in-place": ("docking.turn_in_place=0",),
    "dock-region": ("docking.region_points=0",),
    "dock-at-tolerance": ("docking.arrival_at_tolerance=0",),
    "ladder": ("stall.levels=0",),
    "stall-progress": ("stall.min_progress=0",),
    "back-up": ("stall.back_up=0",),
    "threat-gate": ("stall.back_up_threat=0",),
    "dodge": ("stall.dodge=0",),
    "turn-to-goal": ("stall.turn_to_goal=0",),
    "last-resort": ("stall.doomed_below=0",),
    "threat-until-arrival": ("stall.threat_until_arrival=0",),
    "passive": ("stall.passive=0",),
}
"""Each extension's name and the ``--set`` pairs that switch it off (the paper preset's value)."""

PEOPLE_ONLY = ("dodge", "passive", "threat-gate", "last-resort", "threat-until-arrival")
SKIP = {"barn": set(PEOPLE_ONLY) | {"dock-follow"}}
"""Benchmarks an extension cannot act on (module docstring); every crowd benchmark skips
following. The paper's six scenes (``scenarios``, both variants) run every extension."""

SCENES = "circle-4,circle-10,hall,l-corridor,narrow-corridor,t-corridor"
"""The paper's six scenes, as the published table runs them (MPEPC and DS-MPEPC)."""


def benchmarks(args) -> dict:
    """name -> the ``dsmpepc benchmark`` arguments of one benchmark of the report set."""
    out = {}
    if args.barn:
        out["barn"] = ["barn", "--data", args.barn, "--worlds", args.worlds]
    for scene in ("circle", "square"):
        out[scene] = ["crowdnav", "--scene", scene, "--episodes", str(args.crowdnav),
                      "--seed", str(args.seed), "--variants", "ds-mpepc"]
    if args.ethucy:
        for scene in ("eth", "hotel", "univ", "zara1", "zara2"):
            out[scene] = ["crowd", "--data", args.ethucy, "--scene", scene, "--episodes",
                          str(args.ethucy_episodes), "--variants", "ds-mpepc"]
    out["scenarios"] = ["scenarios", "--scenarios", SCENES, "--variants", "mpepc", "ds-mpepc"]
    return out


def applies(name: str, bench: str) -> bool:
    if name == "defaults":
        return True
    if bench == "scenarios":
        return True
    if name == "dock-follow":
        return False
    return name not in SKIP.get(bench, set())


def run_one(root, name, bench, command, args) -> None:
    folder = os.path.join(root, name, bench)
    sets = [] if name == "defaults" else [x for pair in EXTENSIONS[name] for x in ("--set", pair)]
    cmd = [sys.executable, "-m", "dsmpepc_nlp", "benchmark", *command, *sets,
           "--workers", str(args.workers), "--time-budget", "none", "--sensing", args.sensing,
           "--out", folder, "--resume"]
    print(" ".join(cmd[2:]), flush=True)
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL)
    if done.returncode:
        print(f"{name} {bench}: exit status {done.returncode}", flush=True)


def table_of(folder):
    names = [f for f in os.listdir(folder) if f.endswith(".csv")] if os.path.isdir(folder) else []
    return os.path.join(folder, names[0]) if len(names) == 1 else None


def scene_result(base: str, off: str) -> dict:
    """:func:`~dsmpepc_nlp.bench.paired.compare`'s keys for two ``benchmark scenarios``
    folders, a case being a (variant, scene, seed) row: won where every robot succeeds, a
    collision where any collides, the time the robots' mean time to goal."""
    def rows(folder):
        with open(os.path.join(folder, "scenarios.json"), encoding="utf-8") as handle:
            return {f"{r['variant']}/{r['scenario']}/{r['seed']}": r
                    for r in json.load(handle)["rows"]}
    a, b = rows(base), rows(off)
    cases = sorted(set(a) & set(b))
    won = {k: [c for c in cases if t[c].get("success_rate") == 1.0] for k, t in
           (("a", a), ("b", b))}
    shared = [c for c in won["a"] if c in won["b"]]

    def mean(table):
        return (sum(table[c]["time_to_goal"] for c in shared) / len(shared) if shared
                else math.nan)

    return {"cases": len(cases), "only_a": [c for c in won["a"] if c not in won["b"]],
            "only_b": [c for c in won["b"] if c not in won["a"]], "p": math.nan,
            "collisions_a": sum((a[c].get("collision_rate") or 0) > 0 for c in cases),
            "collisions_b": sum((b[c].get("collision_rate") or 0) > 0 for c in cases),
            "shared_time_a": mean(a), "shared_time_b": mean(b)}


def report(root, marks) -> list:
    """One dict per extension and benchmark: the cases only the defaults win (what the
    extension wins), the cases only the extension-off run wins, collisions of each and the
    mean time of the shared successes of each."""
    rows = []
    for name in EXTENSIONS:
        for bench in marks:
            folders = [os.path.join(root, n, bench) for n in ("defaults", name)]
            base, off = (table_of(f) for f in folders)
            if base is None or off is None:
                continue
            result = (scene_result(*folders) if bench == "scenarios"
                      else compare(load(base), load(off)))
            rows.append(dict(
                extension=name, benchmark=bench, cases=result["cases"],
                lost_off=result["only_a"], won_off=result["only_b"], p=round(result["p"], 4),
                collisions=(result["collisions_a"], result["collisions_b"]),
                shared_time=(round(result["shared_time_a"], 2),
                             round(result["shared_time_b"], 2))))
    return rows


def markdown(rows, marks) -> str:
    """The rows of :func:`report` as a markdown table, one line per extension."""
    lines = ["| extension off | " + " | ".join(marks) + " | all: lost / won | collisions more |",
             "|---|" + "---|" * (len(marks) + 2)]
    by = {}
    for row in rows:
        by.setdefault(row["extension"], {})[row["benchmark"]] = row
    for name, cells in by.items():
        shown, lost, won, more = [], 0, 0, 0
        for bench in marks:
            row = cells.get(bench)
            if row is None:
                shown.append("-")
                continue
            lost, won = lost + len(row["lost_off"]), won + len(row["won_off"])
            more += row["collisions"][1] - row["collisions"][0]
            late = row["shared_time"][1] - row["shared_time"][0]
            shown.append(f"{len(row['lost_off'])} / {len(row['won_off'])}, {late:+.2f} s")
        lines.append(f"| {name} | " + " | ".join(shown) + f" | {lost} / {won} | {more:+d} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--barn", help="BARN data folder (skipped if not given)")
    parser.add_argument("--ethucy", help="ETH/UCY data folder (skipped if not given)")
    parser.add_argument("--worlds", default="1-299:6")
    parser.add_argument("--crowdnav", type=int, default=100)
    parser.add_argument("--ethucy-episodes", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--sensing", default="oracle")
    parser.add_argument("--only", nargs="+", choices=sorted(EXTENSIONS))
    parser.add_argument("--benchmarks", nargs="+")
    parser.add_argument("--report", action="store_true", help="only print the table")
    args = parser.parse_args(argv)
    marks = benchmarks(args)
    if args.benchmarks:
        marks = {k: v for k, v in marks.items() if k in args.benchmarks}
    if not args.report:
        for name in ["defaults", *(args.only or EXTENSIONS)]:
            for bench, command in marks.items():
                if applies(name, bench):
                    run_one(args.out, name, bench, command, args)
    rows = report(args.out, marks)
    print(markdown(rows, list(marks)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
