"""Plan time of the NLP (default and fast) and of the sampler at equal exact cost, side by side;
the exact evaluator and a 4096-sample sampling plan on the compiled and the numpy path.

Run ``dsmpepc bench`` (prints the table; ``--json`` for the numbers). Timings are wall-clock
medians on a shared machine, both paths measured in the same run so that their ratio is
meaningful; nothing here is asserted in tests.
"""

from __future__ import annotations

import contextlib
import time

import numpy as np

from ..core.config import PlannerConfig
from ..core.solver_config import SolverConfig
from ..solve.exact import loader as exact
from ..solve.exact.cycle import Cycle
from ..solve.exact.evaluator import Evaluator
from ..solve.optimize.starts import box_samples
from .scenes import demo_cycles

LADDER = (64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384)
"""Sample counts tried for the sampler at equal exact cost."""


def _summary(times_s) -> dict:
    """Median and p95 of the plan times, and the first plan's (``first_ms``: a fresh planner's
    first plan loads the compiled graph of its object bucket, and the exact kernel)."""
    ms = 1e3 * np.asarray(times_s, dtype=float)
    return {"median_ms": float(np.median(ms)), "p95_ms": float(np.percentile(ms, 95)),
            "first_ms": float(ms[0])}


def run_bench(n_cycles: int = 20, seed: int = 0, config: PlannerConfig | None = None,
              ladder=LADDER, tol: float = 0.01, default: SolverConfig | None = None) -> dict:
    """Time every planner on the crowded demo scene (map + 12 pedestrians).

    Parameters
    ----------
    n_cycles : int
        Cycles of :func:`~dsmpepc_nlp.bench.scenes.demo_cycles`.
    seed : int
    config : PlannerConfig, optional
    ladder : sequence of int
        Sample counts; per cycle the smallest whose best exact cost is within ``tol`` of the
        default NLP's exact cost is timed (the largest when none is).
    tol : float
    default : SolverConfig, optional
        The default planner's solver (IPOPT with its defaults when None; ``dsmpepc bench
        --ipopt-option`` changes its options).

    Returns
    -------
    dict
        ``default``, ``fast``, ``sampling``: each ``median_ms``, ``p95_ms``, ``first_ms``
        (and ``build_s``, ``exact_cost_median`` for the NLPs, ``samples_median`` for
        sampling);
        ``ratio_default_to_sampling``; ``overhead_ms`` in ``default`` and ``fast`` (a plan's
        time outside the NLP solver's runs, median: the non-solver overhead) and
        ``solver_ms`` (inside them, median); the fields of
        :func:`exact_timing`; ``cycles``; ``table`` (printable).
    """
    from ..solve.planner import Planner

    config = PlannerConfig() if config is None else config
    cycles = demo_cycles(config, n_cycles, seed)
    result = {"cycles": n_cycles, "tol": tol}
    nlp_costs = None
    default = SolverConfig() if default is None else default
    for name, solver in (("default", default), ("fast", SolverConfig.fast())):
        started = time.perf_counter()
        planner = Planner(config, solver, compile="wait")
        build_s = time.perf_counter() - started
        times, costs, overheads, in_solver, solves, gains = [], [], [], [], [], []
        for state, world, goal in cycles:
            before = planner.nlp.solver_s if planner.nlp is not None else np.nan
            plan = planner.plan(state, world, goal, dock=False)
            spent = (planner.nlp.solver_s if planner.nlp is not None else np.nan) - before
            times.append(plan.wall_time)
            costs.append(plan.fun)
            overheads.append(plan.wall_time - spent)
            in_solver.append(spent)
            solves.append(list(planner.nlp.last_stats) if planner.nlp is not None else [])
            gains.append(polish_gain(plan.starts))
        # The compiled graph is built (or loaded) on the first plan of each object bucket.
        build_s += planner.nlp.build_s if planner.nlp is not None else 0.0
        result[name] = {**_summary(times), "build_s": build_s,
                        "overhead_ms": 1e3 * float(np.median(overheads)),
                        "solver_ms": 1e3 * float(np.median(in_solver)),
                        "exact_cost_median": float(np.nanmedian(costs)),
                        **_solve_counts(solves), **_gain_summary(gains, tol)}
        if name == "default":
            nlp_costs = costs
    samplers = {n: Planner(config, SolverConfig.sampling(n_samples=n, seed=seed)) for n in ladder}
    times, counts = [], []
    for (state, world, goal), target in zip(cycles, nlp_costs):
        chosen = None
        for n in ladder:
            plan = samplers[n].plan(state, world, goal, dock=False)
            chosen = (n, plan.wall_time)
            if plan.fun <= target + tol:
                break
        counts.append(chosen[0])
        times.append(chosen[1])
    result["sampling"] = {**_summary(times), "samples_median": float(np.median(counts))}
    result["ratio_default_to_sampling"] = (result["default"]["median_ms"]
                                           / result["sampling"]["median_ms"])
    result.update(exact_timing(cycles, config, seed))
    result["fresh_process"] = fresh_first_plan(cycles[0], config)
    result["table"] = format_table(result)
    return result


_FRESH = """
import time
started = time.perf_counter()
import json, os, pickle, sys
import dsmpepc_nlp
from dsmpepc_nlp import Planner
imported = time.perf_counter()
config, (state, world, goal) = pickle.loads(sys.stdin.buffer.read())
loaded = time.perf_counter()
planner = Planner(config)
plan = planner.plan(state, world, goal, dock=False)
done = time.perf_counter()
module = sys.modules["dsmpepc_nlp.solve.planner"]
print(json.dumps({"import_ms": 1e3 * (imported - started), "plan_ms": 1e3 * (done - loaded),
                  "first_plan_ms": 1e3 * (done - started - (loaded - imported)),
                  "status": plan.status,
                  "bytecode": bool(module.__cached__) and os.path.exists(module.__cached__)}))
"""

_FIGURES = ("first_plan_ms", "import_ms", "plan_ms", "process_ms")


def _fresh_children(data: bytes, runs: int, env: dict) -> dict:
    """One untimed child (it writes the bytecode where it may), then ``runs`` timed ones:
    the medians of :data:`_FIGURES`, the statuses, and whether the package's modules were
    read from bytecode (``__pycache__``) in every timed child."""
    import json
    import subprocess
    import sys

    rows = []
    for run in range(runs + 1):
        started = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", _FRESH], input=data, capture_output=True,
                              check=True, env=env)
        row = json.loads(done.stdout.decode().strip().splitlines()[-1])
        row["process_ms"] = 1e3 * (time.perf_counter() - started)
        if run:
            rows.append(row)
    summary = {name: float(np.median([r[name] for r in rows])) for name in _FIGURES}
    summary["status"] = sorted({r["status"] for r in rows})
    summary["bytecode"] = all(r["bytecode"] for r in rows)
    return summary


def fresh_first_plan(cycle, config: PlannerConfig, runs: int = 3) -> dict:
    """The first plan of a fresh Python process, in child processes (median of ``runs``,
    after one untimed child): ``first_plan_ms`` from the interpreter's first statement
    through the imports, the planner's construction and one plan of ``cycle`` (the scene's
    unpickling left out), with ``import_ms`` and ``plan_ms`` its parts, ``process_ms`` the
    child's whole wall time (interpreter start and exit included) and the plans' ``status``.
    Whatever is compiled is in the cache already (the bench's own plans used it); a structure
    that is not compiled would be answered by the sampler (status ``sampling-compiling``).

    ``bytecode`` says whether the children read the package's modules from bytecode, as
    ``pip install .`` leaves them. Where they could not (``PYTHONDONTWRITEBYTECODE`` set
    and no ``__pycache__`` beside the sources: every import compiles its module's source,
    ~50 ms more), ``with_bytecode`` has the same figures from children given a temporary
    bytecode folder (``PYTHONPYCACHEPREFIX``), the installed package's case."""
    import os
    import pickle
    import tempfile

    data = pickle.dumps((config, cycle))
    summary = _fresh_children(data, runs, dict(os.environ))
    if not summary["bytecode"]:
        with tempfile.TemporaryDirectory(prefix="dsmpepc-pycache-") as prefix:
            env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
            env["PYTHONPYCACHEPREFIX"] = prefix
            summary["with_bytecode"] = _fresh_children(data, runs, env)
    return summary


def _solve_counts(solves) -> dict:
    """Means over the NLP's solves of the cycles (``solves``: per cycle, ``last_stats``):
    ``solves_per_plan``, ``iterations``, ``cost_evaluations`` and ``derivative_evaluations``
    per solve (where a solve's time goes: see ``SolveResult.nfev``, ``ngev``)."""
    flat = [s for cycle in solves for s in cycle]
    if not flat:
        return {}
    return {"solves_per_plan": len(flat) / len(solves),
            "iterations": float(np.mean([s["iter_count"] for s in flat])),
            "cost_evaluations": float(np.mean([s["nfev"] for s in flat])),
            "derivative_evaluations": float(np.mean([s["ngev"] for s in flat]))}


def polish_gain(starts) -> float:
    """How much the exact-cost polish lowered the plan's exact cost below the best solved or
    screened candidate (0 when it found nothing better; NaN without candidates)."""
    candidates = [r.exact_cost for r in starts if r.name != "polish" and np.isfinite(r.exact_cost)]
    if not candidates:
        return float("nan")
    polished = [r.exact_cost for r in starts if r.name == "polish"]
    return float(min(candidates) - polished[0]) if polished else 0.0


def _gain_summary(gains, tol) -> dict:
    """``polish_gain_median``, ``_p90``, ``_max`` and ``polish_gain_share`` (above ``tol``)
    over the cycles: what the polish is worth."""
    gains = np.asarray(gains, dtype=float)
    gains = gains[np.isfinite(gains)]
    if gains.size == 0:
        return {}
    return {"polish_gain_median": float(np.median(gains)),
            "polish_gain_p90": float(np.percentile(gains, 90)),
            "polish_gain_max": float(np.max(gains)),
            "polish_gain_share": float(np.mean(gains > tol))}


def _median_s(run, repeats, clock=time.perf_counter):
    times = []
    for _ in range(repeats):
        started = clock()
        run()
        times.append(clock() - started)
    return float(np.median(times))


def exact_timing(cycles, config: PlannerConfig, seed: int = 0, n: int = 4096,
                 repeats: int = 7) -> dict:
    """The exact evaluator and a whole sampling plan, compiled and numpy, in one run.

    ``exact_us_per_trajectory``: a batch of ``n`` box samples on the first demo cycle, the
    per-cycle object prepared inside the timed call, median of ``repeats``.
    ``sampling_4096_ms``: median plan time of the sampling planner with ``n`` samples over the
    cycles. Each has a ``_numpy`` twin and a ``_speedup`` ratio; ``compiled`` says whether the
    compiled path ran (else both figures are the numpy path's). ``exact_cpu_us_per_trajectory``
    (and its twin) is the process's CPU time, all threads summed: on a shared machine it shows
    the work when wall-clock time shows the contention.
    """
    state, world, goal = cycles[0]
    z = box_samples(config, n, seed)

    def batch():
        Evaluator(Cycle.prepare(state, world, goal, config)).evaluate(z)

    from ..solve.planner import Planner

    planner = Planner(config, SolverConfig.sampling(n_samples=n, seed=seed))

    def plans():
        return [planner.plan(s, w, g, dock=False).wall_time for s, w, g in cycles]

    result = {"compiled": exact.kernel() is not None}
    batch()                                   # compile or load before timing
    for suffix, context in (("", contextlib.nullcontext()), ("_numpy", exact.numpy_only())):
        with context:
            result[f"exact_us_per_trajectory{suffix}"] = 1e6 * _median_s(batch, repeats) / n
            result[f"exact_cpu_us_per_trajectory{suffix}"] = 1e6 * _median_s(
                batch, repeats, time.process_time) / n
            result[f"sampling_4096_ms{suffix}"] = 1e3 * float(np.median(plans()))
    for name in ("exact_us_per_trajectory", "exact_cpu_us_per_trajectory", "sampling_4096_ms"):
        result[f"{name}_speedup"] = result[f"{name}_numpy"] / result[name]
    return result


def format_table(result: dict) -> str:
    """The benchmark as a fixed-width table."""
    lines = [f"{'planner':<10}{'median ms':>12}{'p95 ms':>12}{'first ms':>10}{'build s':>10}"]
    for name in ("default", "fast", "sampling"):
        row = result[name]
        build = f"{row['build_s']:.2f}" if "build_s" in row else "-"
        lines.append(f"{name:<10}{row['median_ms']:>12.1f}{row['p95_ms']:>12.1f}"
                     f"{row['first_ms']:>10.1f}{build:>10}")
    lines.append(f"ratio default/sampling at equal cost: {result['ratio_default_to_sampling']:.2f}")
    if "exact_us_per_trajectory" in result:
        path = "compiled" if result["compiled"] else "numpy (compiled path off)"
        lines.append(f"{'':<28}{path:>12}{'numpy':>12}{'speed-up':>10}")
        for name, label in (("exact_us_per_trajectory", "exact cost, us/trajectory"),
                            ("exact_cpu_us_per_trajectory", "  CPU (all threads), us"),
                            ("sampling_4096_ms", "sampling plan 4096, ms")):
            lines.append(f"{label:<28}{result[name]:>12.2f}{result[name + '_numpy']:>12.2f}"
                         f"{result[name + '_speedup']:>10.1f}")
    for name in ("default", "fast"):
        if "overhead_ms" in result[name]:
            lines.append(f"{name} plan outside the NLP solver's runs: "
                         f"{result[name]['overhead_ms']:.1f} ms median, inside them "
                         f"{result[name]['solver_ms']:.1f} ms")
        if "solves_per_plan" in result[name]:
            row = result[name]
            lines.append(f"{name}: {row['solves_per_plan']:.1f} solves per plan; per solve "
                         f"{row['iterations']:.1f} iterations, {row['cost_evaluations']:.1f} "
                         f"cost and {row['derivative_evaluations']:.1f} derivative evaluations")
        if "polish_gain_share" in result[name]:
            row = result[name]
            lines.append(f"{name}: the exact polish lowered the exact cost by more than "
                         f"{result.get('tol', 0.01)} in {100 * row['polish_gain_share']:.0f} % "
                         f"of plans (median {row['polish_gain_median']:.4f}, p90 "
                         f"{row['polish_gain_p90']:.3f}, max {row['polish_gain_max']:.3f})")
    if result.get("fresh_process"):
        lines += fresh_lines(result["fresh_process"])
    return "\n".join(lines)


def fresh_lines(fresh: dict) -> list:
    """The lines of the table on :func:`fresh_first_plan`'s figures."""
    lines = ["first plan of a fresh process (child, default solver): " + _fresh_line(fresh)]
    if "with_bytecode" in fresh:
        lines.append("  the package has no bytecode here (PYTHONDONTWRITEBYTECODE, no "
                     "__pycache__); with bytecode, as `pip install .` leaves it: "
                     + _fresh_line(fresh["with_bytecode"]))
    return lines


def _fresh_line(fresh: dict) -> str:
    source = "bytecode" if fresh["bytecode"] else "source"
    return (f"{fresh['first_plan_ms']:.0f} ms median (modules from {source}; imports "
            f"{fresh['import_ms']:.0f} ms, planner and plan {fresh['plan_ms']:.0f} ms; whole "
            f"child {fresh['process_ms']:.0f} ms; status {', '.join(fresh['status'])})")


if __name__ == "__main__":
    print(run_bench()["table"])
