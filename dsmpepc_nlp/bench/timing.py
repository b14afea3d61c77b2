"""Plan time of the NLP (default and fast) and of the sampler at equal exact cost, side by side.

Run ``python -m dsmpepc_nlp.benchmark`` (prints the table). Timings are wall-clock medians on a
shared machine; nothing here is asserted in tests.
"""

from __future__ import annotations

import time

import numpy as np

from ..core.config import PlannerConfig, SolverConfig
from .crosscheck import demo_cycles

LADDER = (64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384)
"""Sample counts tried for the sampler at equal exact cost."""


def _summary(times_s) -> dict:
    ms = 1e3 * np.asarray(times_s, dtype=float)
    return {"median_ms": float(np.median(ms)), "p95_ms": float(np.percentile(ms, 95))}


def run_bench(n_cycles: int = 20, seed: int = 0, config: PlannerConfig | None = None,
              ladder=LADDER, tol: float = 0.01) -> dict:
    """Time every planner on the crowded demo scene (map + 12 pedestrians).

    Parameters
    ----------
    n_cycles : int
        Cycles of :func:`~dsmpepc_nlp.crosscheck.demo_cycles`.
    seed : int
    config : PlannerConfig, optional
    ladder : sequence of int
        Sample counts; per cycle the smallest whose best exact cost is within ``tol`` of the
        default NLP's exact cost is timed (the largest when none is).
    tol : float

    Returns
    -------
    dict
        ``default``, ``fast``, ``sampling``: each ``median_ms``, ``p95_ms`` (and ``build_s``,
        ``exact_cost_median`` for the NLPs, ``samples_median`` for sampling);
        ``ratio_default_to_sampling``; ``cycles``; ``table`` (printable).
    """
    from ..solve.planner import Planner

    config = PlannerConfig() if config is None else config
    cycles = demo_cycles(config, n_cycles, seed)
    result = {"cycles": n_cycles}
    nlp_costs = None
    for name, solver in (("default", SolverConfig()), ("fast", SolverConfig.fast())):
        started = time.perf_counter()
        planner = Planner(config, solver)
        build_s = time.perf_counter() - started
        times, costs = [], []
        for state, world, goal in cycles:
            plan = planner.plan(state, world, goal, dock=False)
            times.append(plan.wall_time)
            costs.append(plan.fun)
        result[name] = {**_summary(times), "build_s": build_s,
                        "exact_cost_median": float(np.nanmedian(costs))}
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
    result["table"] = format_table(result)
    return result


def format_table(result: dict) -> str:
    """The benchmark as a fixed-width table."""
    lines = [f"{'planner':<10}{'median ms':>12}{'p95 ms':>12}{'build s':>10}"]
    for name in ("default", "fast", "sampling"):
        row = result[name]
        build = f"{row['build_s']:.2f}" if "build_s" in row else "-"
        lines.append(f"{name:<10}{row['median_ms']:>12.1f}{row['p95_ms']:>12.1f}{build:>10}")
    lines.append(f"ratio default/sampling at equal cost: {result['ratio_default_to_sampling']:.2f}")
    return "\n".join(lines)


if __name__ == "__main__":
    print(run_bench()["table"])
