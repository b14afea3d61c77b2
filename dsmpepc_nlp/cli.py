"""The ``dsmpepc`` command line: list, run, compare, crosscheck and bench scenarios.

YAML lives in ``scenario.py`` and JSON here; progress goes to stderr, results to stdout (JSON
only with ``--json``). Bad input exits with status 2 and a one-line message.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import matplotlib
import numpy as np

from .core.config import VARIANTS, PlannerConfig, SolverConfig
from .core.errors import InputError

matplotlib.use("Agg")  # files only; the command line never opens a window

SOLVERS = ("nlp", "sampling", "fast")
DEFAULT_SAMPLE_CYCLES = 5
"""Cycles per robot whose evaluated trajectories a run records for its figure."""


class UsageError(InputError):
    """A bad command-line value."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, status 2
        raise UsageError(f"{self.prog}: {message}")


class Progress:
    """A per-cycle line on stderr: rewritten in place on a terminal, every 5 s of sim otherwise."""

    def __init__(self, label: str, stream=None):
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.tty = getattr(self.stream, "isatty", lambda: False)()
        self.started = time.perf_counter()
        self._last_print = -math.inf

    def __call__(self, cycle, t, n_cycles, n_active):
        elapsed = time.perf_counter() - self.started
        line = (f"[{self.label}] t = {t:5.1f} / {n_cycles * t / (cycle + 1):.1f} s, "
                f"{n_active} robot(s) moving, {elapsed:.1f} s wall")
        if self.tty:
            self.stream.write("\r" + line)
        elif t - self._last_print >= 5.0 - 1e-9:
            self.stream.write(line + "\n")
            self._last_print = t
        self.stream.flush()

    def done(self, text: str):
        elapsed = time.perf_counter() - self.started
        self.stream.write(("\r" if self.tty else "") + f"[{self.label}] {text} "
                          f"({elapsed:.1f} s wall)" + (" " * 20 if self.tty else "") + "\n")
        self.stream.flush()


# ---------------------------------------------------------------------------------------------
# pieces shared by the commands


def _solver(name: str) -> SolverConfig:
    solver = SolverConfig.named(name)
    if solver.method != "sampling":
        try:
            from .solve import nlp  # noqa: F401
        except ImportError as exc:
            raise UsageError(f"--solver {name}: the NLP solver is not available ({exc}); "
                             "use --solver sampling") from None
    return solver


def _seed(value: str) -> int:
    try:
        seed = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{value!r} is not an integer") from None
    if seed < 0:
        raise argparse.ArgumentTypeError(f"{seed} is negative; must be >= 0")
    return seed


def _sample_cycles(scenario, config, count):
    n_cycles = max(1, int(math.ceil(scenario.duration / config.horizon.dt - 1e-9)))
    if count <= 0:
        return ()
    return tuple(np.unique(np.linspace(0, n_cycles - 1, count).round().astype(int)).tolist())


def run_one(scenario, variant: str, solver_name: str, seed: int, out: Path, *,
            animate: bool = False, sample_cycles: int = DEFAULT_SAMPLE_CYCLES,
            figure: bool = True) -> dict:
    """Simulate one scenario with one variant; write the episode and figures; return a summary."""
    from .sim.metrics import episode_metrics, json_safe
    from .sim.simulate import simulate

    config = PlannerConfig.variant(variant)
    solver = _solver(solver_name)
    progress = Progress(f"{scenario.name} {variant} {solver_name}")
    started = time.perf_counter()
    episode = simulate(scenario, config, solver, np.random.default_rng(seed),
                       record_samples=_sample_cycles(scenario, config, sample_cycles),
                       progress=progress)
    wall = time.perf_counter() - started
    progress.done(", ".join(episode.outcomes))
    stem = f"{scenario.name}-{variant}-{solver_name}-seed{seed}"
    files = {"episode": str(episode.save(out / f"{stem}.npz"))}
    if figure or animate:
        from .viz import plots

        if figure:
            files["figure"] = str(plots.episode_figure(episode, path=out / f"{stem}.png"))
        if animate:
            stride = max(1, episode.n_cycles // 150)
            files["animation"] = str(plots.animate(episode, out / f"{stem}.gif", stride=stride))
    return {
        "scenario": scenario.name, "variant": variant, "solver": solver_name, "seed": seed,
        "outcomes": list(episode.outcomes), "metrics": json_safe(episode_metrics(episode)),
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
    from .sim.scenario import builtin_names, load_scenario

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
    from .sim.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    summary = run_one(scenario, args.variant, args.solver, args.seed, Path(args.out),
                      animate=args.animate, sample_cycles=args.samples)
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
    from .viz import plots

    inputs = episode.planning_inputs(0)
    planned = episode.times[:-1][episode.active[0]]
    if not inputs:
        raise UsageError("--panels: the first robot never planned")
    k = int(np.argmin(np.abs(planned - seconds)))
    state, world, goal = inputs[k]
    stem = f"{episode.meta['scenario']}-panels-t{planned[k]:.1f}s"
    return plots.cost_panels(state, world, goal, episode.config(), path=out / f"{stem}.png")


def cmd_compare(args) -> int:
    from .viz import plots
    from .sim.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    variants = args.variants
    for v in variants:
        if v not in VARIANTS:
            raise UsageError(f"--variants: {v!r} is not one of {', '.join(VARIANTS)}")
    if len(set(variants)) != len(variants):
        raise UsageError(f"--variants: {' '.join(variants)} repeats a variant")
    out = Path(args.out)
    results = {v: run_one(scenario, v, args.solver, args.seed, out, figure=False,
                          sample_cycles=0) for v in variants}
    figure = out / f"{scenario.name}-compare-{'-'.join(variants)}-{args.solver}-seed{args.seed}.png"
    plots.compare_figure({v: r["_episode"] for v, r in results.items()}, path=figure)
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


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="dsmpepc", description="DS-MPEPC navigation scenarios: run, compare, "
                     "cross-check and benchmark.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("list", help="the built-in scenarios")
    p.add_argument("--json", action="store_true", help="print JSON on stdout")
    p.set_defaults(func=cmd_list)

    def common(p, *, variant=True):
        p.add_argument("scenario", help="built-in name (see 'list') or path of a YAML file")
        if variant:
            p.add_argument("--variant", choices=list(VARIANTS), default="ds-mpepc")
        p.add_argument("--solver", choices=SOLVERS, default="nlp",
                       help="nlp (IPOPT, default), fast (trust-region Newton) or sampling")
        p.add_argument("--seed", type=_seed, default=0, help="seed of the start perturbations")
        p.add_argument("--out", default="out", help="folder for episodes and figures")
        p.add_argument("--json", action="store_true", help="print JSON on stdout")

    p = sub.add_parser("run", help="simulate one scenario with one variant")
    common(p)
    p.add_argument("--animate", action="store_true", help="also write a GIF of the episode")
    p.add_argument("--samples", type=_nonnegative, default=DEFAULT_SAMPLE_CYCLES,
                   help="cycles whose evaluated trajectories are recorded and drawn (0: none)")
    p.add_argument("--panels", type=_time, default=None, metavar="SECONDS",
                   help="also draw the paper's Fig. 2 panels (lowest MPEPC cost, lowest TTG, "
                        "highest TTC) for the first robot's cycle nearest this time")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("compare", help="run several variants on the same scenario and seed")
    common(p, variant=False)
    p.add_argument("--variants", nargs="+", default=["mpepc", "ds-mpepc"],
                   help=f"from {', '.join(VARIANTS)} (default: mpepc ds-mpepc)")
    p.set_defaults(func=cmd_compare)
    _add_optional_commands(sub, common)
    return parser


def _nonnegative(value: str) -> int:
    return _seed(value)


def _time(value: str) -> float:
    try:
        seconds = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{value!r} is not a number of seconds") from None
    if not (math.isfinite(seconds) and seconds >= 0):
        raise argparse.ArgumentTypeError(f"{value}: must be a finite time >= 0 s")
    return seconds


def _add_optional_commands(sub, common) -> None:
    """``crosscheck`` and ``bench`` (the NLP's verification), and the benchmark commands of
    ``bench_cli`` when that module is present."""
    p = sub.add_parser("crosscheck", help="NLP vs sampling (exact costs) on every cycle of an "
                       "episode of SCENARIO (first robot; the episode is driven by the sampler)")
    common(p)
    p.add_argument("--n-samples", type=_positive, default=4096,
                   help="samples of the reference sampling planner")
    p.add_argument("--tol", type=float, default=0.01, help="gap counted as 'as good'")
    p.set_defaults(func=cmd_crosscheck)
    p = sub.add_parser("bench", help="time the NLP and the sampler on the crowded demo scene")
    p.add_argument("--cycles", type=_positive, default=20, help="planning cycles to time")
    p.add_argument("--seed", type=_seed, default=0)
    p.add_argument("--json", action="store_true", help="print JSON on stdout")
    p.set_defaults(func=cmd_bench)
    try:
        from . import bench_cli
    except ImportError:
        return
    bench_cli.register(sub)


def _positive(value: str) -> int:
    number = _seed(value)
    if number < 1:
        raise argparse.ArgumentTypeError(f"{number}: must be >= 1")
    return number


def cmd_crosscheck(args) -> int:
    from .viz import plots
    from .bench.crosscheck import crosscheck
    from .sim.scenario import load_scenario
    from .sim.simulate import simulate

    if args.solver == "sampling":
        raise UsageError("crosscheck --solver: must be nlp or fast (sampling is the reference)")
    scenario = load_scenario(args.scenario)
    config = PlannerConfig.variant(args.variant)
    solver = _solver(args.solver)
    progress = Progress(f"{scenario.name} {args.variant} episode (sampling)")
    episode = simulate(scenario, config, SolverConfig.sampling(), np.random.default_rng(args.seed),
                       record_trajectories=False, progress=progress)
    progress.done(", ".join(episode.outcomes))
    cycles = episode.planning_inputs(0)
    robot_config = episode.config()
    if scenario.agents[0].robot is not None:
        import dataclasses

        robot_config = dataclasses.replace(robot_config, robot=scenario.agents[0].robot)
    print(f"[crosscheck] {len(cycles)} cycles, {args.solver} vs sampling "
          f"({args.n_samples} samples)", file=sys.stderr)
    started = time.perf_counter()
    result = crosscheck(cycles, robot_config, solver, n_samples=args.n_samples, tol=args.tol)
    out = Path(args.out)
    stem = f"{scenario.name}-{args.variant}-crosscheck-{args.solver}-seed{args.seed}"
    figure = plots.crosscheck_figure(result.gap, path=out / f"{stem}.png")
    summary = dict(result.to_dict(), scenario=scenario.name, variant=args.variant,
                   solver=args.solver, seed=args.seed, wall_time=time.perf_counter() - started,
                   statuses={s: result.nlp_status.count(s) for s in set(result.nlp_status)},
                   figure=str(figure))
    if args.json:
        from .sim.metrics import json_safe

        print(json.dumps(json_safe(summary), allow_nan=False))
        return 0
    print(f"{summary['cycles']} cycles: gap (NLP - sampling) median "
          f"{_fmt(summary['gap_median'], 4)}"
          f", p95 {_fmt(summary['gap_p95'], 4)}, within {args.tol}: "
          f"{100 * summary['share_within_tol']:.0f}%; NLP plan statuses {summary['statuses']}")
    print(f"figure: {figure}")
    return 0


def cmd_bench(args) -> int:
    from .bench.timing import run_bench
    from .sim.metrics import json_safe

    _solver("nlp")
    print(f"[bench] timing {args.cycles} cycles of the crowded demo scene", file=sys.stderr)
    result = run_bench(n_cycles=args.cycles, seed=args.seed)
    if args.json:
        print(json.dumps(json_safe(result), allow_nan=False))
    else:
        print(result["table"])
    return 0


def main(argv=None) -> int:
    """Entry point of ``dsmpepc``; returns the exit status (0, or 2 for bad input)."""
    try:
        args = build_parser().parse_args(argv)
        if hasattr(args, "command_main"):  # bench_cli's subcommands handle their own errors
            return args.command_main(args)
        return args.func(args)
    except InputError as exc:
        print(f"dsmpepc: error: {exc}".replace("\n", " "), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("dsmpepc: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
