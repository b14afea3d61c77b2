"""The ``dsmpepc`` command line: one parser, one dispatch, one error policy.

Commands: ``list``, ``run`` and ``compare`` (scenarios, here) and ``crosscheck``, ``bench``
(plan time), ``benchmark barn|crowd|scenarios`` and ``sweep`` (from
:mod:`dsmpepc_nlp.bench.commands`), ``irsim`` (an IR-SIM world, from
:mod:`dsmpepc_nlp.irsim.commands`). Every parser sets ``func``; :func:`main` parses, calls it and
applies the policy: bad input of any kind (a value, a file, a missing optional dependency) is an
:class:`~dsmpepc_nlp.core.errors.InputError`, printed as one line on stderr with exit status 2;
Ctrl-C exits 130. Progress goes to stderr, results to stdout (one JSON object with ``--json``).
To add a command: a parser in :func:`build_parser` (or a ``register`` of its own module) whose
``func(args)`` returns the exit status.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from .bench import commands, failure_report, merge_tables, paired, results_table
from .bench.params import PRESETS, preset_config
from .core import options
from .core.config import VARIANTS
from .core.errors import InputError
from .core.jsonio import json_clean
from .core.progress import EpisodeProgress
from .core.solver_config import SOLVER_NAMES
from .irsim import commands as irsim_commands
from .sim.metrics import episode_metrics
from .sim.panels import cost_panels
from .sim.scenario import builtin_names, load_scenario
from .sim.sensing import load_profile
from .sim.simulate import simulate
from .solve.exact.loader import build_kernel
from .viz import figures

DEFAULT_SAMPLE_CYCLES = 5
"""Cycles per robot whose evaluated trajectories a run records for its figure."""


class UsageError(InputError):
    """A bad command-line value."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, status 2 (through main's policy)
        raise UsageError(f"{self.prog}: {message}")


# ---------------------------------------------------------------------------------------------
# pieces shared by the commands


def _sample_cycles(scenario, config, count):
    n_cycles = max(1, int(math.ceil(scenario.duration / config.horizon.dt - 1e-9)))
    if count <= 0:
        return ()
    return tuple(np.unique(np.linspace(0, n_cycles - 1, count).round().astype(int)).tolist())


def run_one(scenario, variant: str, solver_name: str, seed: int, out: Path, *,
            animate: bool = False, sample_cycles: int = DEFAULT_SAMPLE_CYCLES,
            figure: bool = True, preset: str = "product", sensing: str = "oracle",
            time_budget="auto") -> dict:
    """Simulate one scenario with one variant; write the episode and figures; return a summary."""
    config = preset_config(preset, variant)
    solver = dataclasses.replace(commands.solver_config(solver_name), time_budget=time_budget)
    profile = load_profile(sensing)
    progress = EpisodeProgress(f"{scenario.name} {variant} {solver_name}")
    started = time.perf_counter()
    episode = simulate(scenario, config, solver, np.random.default_rng(seed),
                       record_samples=_sample_cycles(scenario, config, sample_cycles),
                       progress=progress, sensing=profile)
    wall = time.perf_counter() - started
    progress.done(", ".join(episode.outcomes))
    sensed = "" if profile.is_oracle else f"-{profile.name}"
    stem = f"{scenario.name}-{variant}-{solver_name}{sensed}-seed{seed}"
    files = {"episode": str(episode.save(out / f"{stem}.npz"))}
    if figure:
        files["figure"] = str(figures().episode_figure(episode, path=out / f"{stem}.png"))
    if animate:
        stride = max(1, episode.n_cycles // 150)
        files["animation"] = str(figures().animate(episode, out / f"{stem}.gif", stride=stride))
    return {
        "scenario": scenario.name, "variant": variant, "solver": solver_name, "seed": seed,
        "sensing": profile.name, "outcomes": list(episode.outcomes),
        "metrics": json_clean(episode_metrics(episode)),
        "wall_time": wall, "files": files, "_episode": episode,
    }


def _public(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if not k.startswith("_")}


def _fmt(value, digits=2):
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


COLUMNS = (("outcome", "outcome", None), ("time", "outcome_time", 1), ("path", "path_length", 2),
           ("static", "min_static_clearance", 2), ("dynamic", "min_dynamic_clearance", 2),
           ("discomf", "discomfort", 2), ("follow", "following_distance", 2),
           ("plan med", "plan_time_median", 3), ("plan p95", "plan_time_p95", 3))


def metrics_table(rows: list) -> str:
    """A plain-text table of ``(label, metrics dict)`` rows."""
    header = ["run", "robot"] + [c[0] for c in COLUMNS]
    body = [[label, m["robot"]] + [_fmt(m[key], d) if d else str(m[key]) for _, key, d in COLUMNS]
            for label, m in rows]
    widths = [max(len(r[i]) for r in [header] + body) for i in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in [header] + body]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# commands


def cmd_list(args) -> int:
    items = []
    for name in builtin_names():
        s = load_scenario(name)
        items.append({"name": name, "robots": len(s.agents), "pedestrians": len(s.pedestrians),
                      "duration": s.duration, "description": s.description})
    if args.json:
        print(json.dumps(items))
    else:
        for item in items:
            print(f"{item['name']:16s} {item['robots']:2d} robot(s) {item['pedestrians']:2d} "
                  f"pedestrian(s) {item['duration']:5.1f} s  {item['description']}")
    return 0


def cmd_run(args) -> int:
    scenario = load_scenario(args.scenario)
    summary = run_one(scenario, args.variant, args.solver, args.seed, Path(args.out),
                      animate=args.animate, sample_cycles=args.samples, preset=args.preset,
                      sensing=args.sensing, time_budget=args.time_budget)
    if args.panels is not None:
        summary["files"]["panels"] = str(_cost_panels(summary["_episode"], args.panels,
                                                      Path(args.out)))
    if args.json:
        print(json.dumps(_public(summary), allow_nan=False))
        return 0
    print(metrics_table([(args.variant, m) for m in summary["metrics"]]))
    for kind, path in summary["files"].items():
        print(f"{kind}: {path}")
    return 0


def _cost_panels(episode, seconds: float, out: Path) -> Path:
    """The paper's Fig. 2 panels for the first robot's planning cycle nearest ``seconds``."""
    inputs = episode.planning_inputs(0)
    planned = episode.times[:-1][episode.active[0]]
    if not inputs:
        raise UsageError("--panels: the first robot never planned")
    k = int(np.argmin(np.abs(planned - seconds)))
    state, world, goal = inputs[k]
    stem = f"{episode.meta['scenario']}-panels-t{planned[k]:.1f}s"
    panels = cost_panels(state, world, goal, episode.config())
    return figures().cost_panels(panels, path=out / f"{stem}.png")


def cmd_compare(args) -> int:
    scenario = load_scenario(args.scenario)
    variants = args.variants
    for v in variants:
        if v not in VARIANTS:
            raise UsageError(f"--variants: {v!r} is not one of {', '.join(VARIANTS)}")
    if len(set(variants)) != len(variants):
        raise UsageError(f"--variants: {' '.join(variants)} repeats a variant")
    out = Path(args.out)
    results = {v: run_one(scenario, v, args.solver, args.seed, out, figure=False,
                          sample_cycles=0, preset=args.preset, sensing=args.sensing,
                          time_budget=args.time_budget)
               for v in variants}
    sensed = "" if args.sensing == "oracle" else f"-{load_profile(args.sensing).name}"
    figure = out / (f"{scenario.name}-compare-{'-'.join(variants)}-{args.solver}{sensed}"
                    f"-seed{args.seed}.png")
    figures().compare_figure({v: r["_episode"] for v, r in results.items()}, path=figure)
    if args.json:
        payload = {v: dict(_public(r), files=dict(r["files"], compare_figure=str(figure)))
                   for v, r in results.items()}
        print(json.dumps(payload, allow_nan=False))
        return 0
    print(metrics_table([(v, m) for v, r in results.items() for m in r["metrics"]]))
    print(f"figure: {figure}")
    for v, r in results.items():
        print(f"episode ({v}): {r['files']['episode']}")
    return 0


def _scenario_options(p, *, variant=True, sensing=True):
    """Options of the commands that run one scenario: run, compare, crosscheck."""
    if sensing:
        p.add_argument("--sensing", default="oracle", metavar="NAME|FILE",
                       help="what the robot senses: oracle (the truth, default), lidar, "
                            "tracked, realistic, or a profile YAML (docs/sensing.md)")
        p.add_argument("--time-budget", type=options.time_budget, default="auto",
                       metavar="auto|none|SECONDS",
                       help="each plan's time budget (default auto: 0.75 of the control "
                            "period, 0.15 s; none: no deadline)")
    p.add_argument("scenario", help="built-in name (see 'list') or path of a YAML file")
    if variant:
        p.add_argument("--variant", choices=list(VARIANTS), default="ds-mpepc")
    p.add_argument("--solver", choices=SOLVER_NAMES, default="nlp",
                   help="nlp (IPOPT, default), fast (trust-region Newton) or sampling")
    p.add_argument("--seed", type=options.seed, default=0, help="seed of the start perturbations")
    p.add_argument("--preset", choices=PRESETS, default="product",
                   help="product (the package's defaults) or paper (the paper's values, none "
                        "of our extensions; README, 'Defaults')")
    p.add_argument("--out", default="out", help="folder for episodes and figures")
    p.add_argument("--json", action="store_true", help="print JSON on stdout")


def build_parser() -> argparse.ArgumentParser:
    """The one parser of ``dsmpepc``; every (sub)command sets ``func(args) -> exit status``."""
    parser = _Parser(prog="dsmpepc", description="DS-MPEPC navigation scenarios: run, compare, "
                     "cross-check and benchmark.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("list", help="the built-in scenarios")
    p.add_argument("--json", action="store_true", help="print JSON on stdout")
    p.set_defaults(func=cmd_list)

    p = sub.add_parser("run", help="simulate one scenario with one variant")
    _scenario_options(p)
    p.add_argument("--animate", action="store_true", help="also write a GIF of the episode")
    p.add_argument("--samples", type=options.nonnegative, default=DEFAULT_SAMPLE_CYCLES,
                   help="cycles whose evaluated trajectories are recorded and drawn (0: none)")
    p.add_argument("--panels", type=options.number(0.0, unit=" s"), default=None,
                   metavar="SECONDS",
                   help="also draw the paper's Fig. 2 panels (lowest MPEPC cost, lowest TTG, "
                        "highest TTC) for the first robot's cycle nearest this time")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("compare", help="run several variants on the same scenario and seed")
    _scenario_options(p, variant=False)
    p.add_argument("--variants", nargs="+", default=["mpepc", "ds-mpepc"],
                   help=f"from {', '.join(VARIANTS)} (default: mpepc ds-mpepc)")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("build", help="compile (or load) the exact evaluator for the built-in "
                       "configurations into the user cache folder")
    p.add_argument("--nlp", action="store_true",
                   help="also the NLP's compiled graph for the built-in variants and object "
                        "buckets (about 1 minute on 2 cores the first time)")
    p.add_argument("--scenario-robots", action="store_true",
                   help="with --nlp, also the robot bodies of the built-in scenarios (the "
                        "0.6 x 0.4 m two-circle robot: about 2.5 more minutes)")
    p.set_defaults(func=cmd_build)

    p = sub.add_parser("cache", help="what is compiled and cached (entries, size, last use); "
                       "'dsmpepc cache clear' empties it, 'dsmpepc cache prune' bounds it")
    p.add_argument("action", nargs="?", choices=("show", "clear", "prune"), default="show")
    p.add_argument("--json", action="store_true", help="print JSON on stdout")
    p.set_defaults(func=cmd_cache)

    commands.register(sub, _scenario_options)
    for name, epilog in (("run", METRICS_EPILOG), ("compare", METRICS_EPILOG),
                         ("bench", BENCH_EPILOG)):
        sub.choices[name].epilog = epilog
        sub.choices[name].formatter_class = argparse.RawDescriptionHelpFormatter
    failure_report.register(sub)
    paired.register(sub)
    results_table.register(sub)
    merge_tables.register(sub)
    irsim_commands.register(sub, metrics_table)
    return parser


METRICS_EPILOG = """table columns (docs/glossary.md has every metric):
  outcome   success, collision (at-fault or struck), deadlock or timeout
  time      s, when the outcome was decided     path      m, length driven
  static    m, least clearance to the map        dynamic   m, least clearance to others
  discomf   share of states with a pedestrian closer than DISCOMFORT_GAP
  follow    m, mean centre distance to the followed pedestrian
  plan med  s, median planning-cycle time        plan p95  s, its 95th percentile"""

BENCH_EPILOG = """table columns (docs/glossary.md):
  median ms, p95 ms  one plan's wall time over the demo cycles; first ms: a fresh planner's
  first plan; build s: building or loading the NLP's compiled graph.
  The sampling row runs "at equal cost": per cycle the smallest sample count (64 ... 16,384)
  whose best exact cost is within --tol of the default NLP's, not SolverConfig.sampling()'s
  4,096 samples."""


def cmd_cache(args) -> int:
    from .core import compile_cache as cache

    if args.action == "clear":
        freed = cache.clear()
        print(f"cache cleared: {freed / 2**20:.1f} MB freed ({cache.cache_root()})")
        return 0
    removed = cache.prune() if args.action == "prune" else []
    listed = cache.entries()
    total = sum(e["bytes"] for e in listed)
    if args.json:
        print(json.dumps({"root": str(cache.cache_root()), "bytes": total,
                          "bound_bytes": cache.MAX_CACHE_BYTES,
                          "removed": [str(e["path"]) for e in removed],
                          "entries": [dict(e, path=str(e["path"])) for e in listed]}))
        return 0
    if removed:
        print(f"pruned {len(removed)} entries")
    print(f"{cache.cache_root()}: {len(listed)} entries, {total / 2**20:.1f} MB "
          f"(bound {cache.MAX_CACHE_BYTES / 2**20:.0f} MB; entries of other versions and "
          f"unused for {cache.MAX_IDLE_DAYS:g} days are pruned after each compile)")
    now = time.time()
    for e in reversed(listed):
        age = (now - e["last_used"]) / 3600.0
        print(f"  {e['kind']:8s} {e['bytes'] / 2**20:7.2f} MB  used {age:7.1f} h ago  "
              f"{e['version']}/{e['path'].name}")
    return 0


def cmd_build(args) -> int:
    import threading

    nlp = {}
    worker = None
    if getattr(args, "nlp", False):     # the C compiles run in child processes meanwhile
        from .solve.optimize.solvers import build_problems

        robots = {a.robot for name in builtin_names() if args.scenario_robots
                  for a in load_scenario(name).agents if a.robot is not None}
        worker = threading.Thread(target=lambda: nlp.update(build_problems(robots=sorted(
            robots, key=repr))), daemon=True)
        worker.start()
    result = build_kernel()
    if not result["compiled"]:
        print("compiled evaluator off (DSMPEPC_NO_COMPILE or no numba): the numpy path runs")
    else:
        print(f"exact evaluator ready for {', '.join(result['configurations'])} in "
              f"{result['seconds']:.1f} s; cache: {result['cache']}")
    if worker is not None:
        worker.join()
        state = "compiled" if nlp["compiled"] else "on CasADi's virtual machine"
        print(f"NLP graph ready ({state}) for {nlp['problems']} configurations "
              f"({nlp['libraries']} libraries, {nlp['compiled_now']} compiled now) in "
              f"{nlp['seconds']:.1f} s")
    return 0


def main(argv=None) -> int:
    """Entry point of ``dsmpepc``; returns the exit status (0, 2 for bad input, 130 on Ctrl-C,
    141 when the reader of stdout went away, as a shell reports SIGPIPE)."""
    try:
        args = build_parser().parse_args(argv)
        return args.func(args)
    except InputError as exc:
        print(f"dsmpepc: error: {exc}".replace("\n", " "), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("dsmpepc: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader left (``dsmpepc list | head -1``): say nothing, as cat does. Python would
        # report the pipe again when it flushes stdout at exit, so stdout goes to devnull.
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
