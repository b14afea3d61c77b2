"""Accuracy and speed of the global cost graph: ``python -m dsmpepc_nlp.bench.graph_bench``.

Prints, on the crowded demo scene (map + 12 pedestrians), the error of the global graph
against the exact cost at random z (exact and default temperatures), and the time per
evaluation of the cost, its gradient and its Hessian in CasADi's virtual machine and as
compiled C (with the build time); with ``--compare-fast``, the default solver (IPOPT) and the
fast method side by side, with their cross-check. ``docs/design.md`` quotes its output.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

import numpy as np

from ..core.config import PlannerConfig
from ..core.control_law import rollout
from ..core.cost_config import SmoothingConfig
from ..core.exact_cost import evaluate
from ..core.solver_config import SolverConfig
from ..sim.scenario import load_scenario
from ..sim.simulate import simulate
from ..solve import problem as g
from ..solve.build import compiled
from ..solve.exact.cycle import Cycle
from ..solve.planner import Planner
from .crosscheck import crosscheck
from .scenes import demo_cycles


def accuracy(config: PlannerConfig, sizes: g.GraphSizes, cycles, n_z: int = 200) -> dict:
    """Median, p95 and share within 0.01 of |graph - exact| over random z and cycles."""
    lower, upper = np.array(config.z_lower), np.array(config.z_upper)
    z = lower + np.random.default_rng(0).random((n_z, 4)) * (upper - lower)
    result = {}
    for label, smoothing in (("exact_temperatures", SmoothingConfig.exact()),
                             ("default_temperatures", config.smoothing)):
        f = g.build_cost_function(config, sizes, smoothing).map(n_z)
        errors = []
        for state, world, goal in cycles:
            params = g.pack_parameters(Cycle.prepare(state, world, goal, config), sizes)
            graph = np.array(f(z.T, *(params[n] for n in g.PARAMETER_NAMES))[0]).ravel()
            exact = evaluate(rollout(z, state, config), world, goal, config).total
            finite = np.isfinite(exact)
            errors.append(np.abs(graph - exact)[finite])
        errors = np.concatenate(errors)
        result[label] = {"median": float(np.median(errors)),
                         "p95": float(np.percentile(errors, 95)),
                         "within_0.01": float(np.mean(errors < 0.01))}
    return result


def speed(config: PlannerConfig, sizes: g.GraphSizes, cycle, repeats: int = 200) -> dict:
    """Microseconds per call of F, G, H (VM and compiled) and the build seconds; compiled F
    and G also with every pose-object pair computed (``c_F_all_pairs_us``: the pose mask all
    ones, what skipping the pairs that cannot matter saves) and the share of pairs the
    cycle's mask computes (``pose_pairs_computed``)."""
    started = time.perf_counter()
    cost = g.flat_cost(config, sizes)
    span = np.array(config.z_upper) - np.array(config.z_lower)
    functions = compiled.problem_functions(cost, 1e-6 * span)
    built = compiled.load_or_compile(lambda: cost, 1e-6 * span, (config, sizes))
    result = {"build_s": time.perf_counter() - started, "compiled": built.compiled}
    params = g.pack_parameters(cycle, sizes)
    every = g.flatten_parameters(dict(params, pose_mask=np.ones_like(params["pose_mask"])))
    result["pose_pairs_computed"] = float(np.mean(params["pose_mask"])) if \
        params["pose_mask"].size else 0.0
    z = np.array([2.0, 0.1, 0.1, 0.8])
    runs = [("vm", compiled.Compiled(functions, None), g.flatten_parameters(params),
             compiled.NAMES)]
    if built.compiled:
        runs += [("c", built, g.flatten_parameters(params), compiled.NAMES),
                 ("c", built, every, ("F", "G"))]
    for label, runner, p, names in runs:
        suffix = "_all_pairs" if p is every else ""
        runner.bind(p)
        for name in names:
            runner.call(name, z)
            times = []
            for _ in range(repeats):
                tick = time.perf_counter()
                runner.call(name, z)
                times.append(time.perf_counter() - tick)
            result[f"{label}_{name}{suffix}_us"] = 1e6 * float(np.median(times))
    return result


def compare_fast(config: PlannerConfig, cycles) -> dict:
    """``nlp`` (IPOPT) and ``fast`` side by side: build seconds, plan time median / p95 (ms)
    and the share of cycles within 0.01 of the best of 4096 samples."""
    result = {}
    for label, solver in (("nlp", SolverConfig()), ("fast", SolverConfig.fast())):
        started = time.perf_counter()
        planner = Planner(config, solver)
        build = time.perf_counter() - started
        times = []
        for state, world, goal in cycles:
            tick = time.perf_counter()
            planner.plan(state, world, goal, dock=False)
            times.append(time.perf_counter() - tick)
        check = crosscheck(cycles, config, solver)
        result[label] = {"build_s": build, "plan_ms_median": 1e3 * float(np.median(times)),
                         "plan_ms_p95": 1e3 * float(np.percentile(times, 95)),
                         "within_0.01": float(np.mean(check.gap <= 0.01)),
                         "gap_median": float(np.median(check.gap))}
    return result


def scenario_cycles(name: str, seed: int = 0):
    """``(cycles, config)``: every planning cycle of a sampling episode of a built-in scenario
    (what ``dsmpepc crosscheck`` cross-checks)."""
    scenario = load_scenario(name)
    episode = simulate(scenario, PlannerConfig.variant("ds-mpepc"), SolverConfig.sampling(),
                       np.random.default_rng(seed), record_trajectories=False)
    config = episode.config()
    if scenario.agents[0].robot is not None:
        config = dataclasses.replace(config, robot=scenario.agents[0].robot)
    return episode.planning_inputs(0), config


def main(argv=None) -> int:

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=4)
    parser.add_argument("--max-objects", type=int, default=12)
    parser.add_argument("--ray-samples", type=int, default=None,
                        help="samples along the terminal ray (default: a footprint radius apart)")
    parser.add_argument("--pose-objects", type=int, default=None,
                        help="objects at every pose (default: --max-objects)")
    parser.add_argument("--compare-fast", action="store_true",
                        help="also plan every cycle with nlp and fast and cross-check")
    parser.add_argument("--scenario", default=None,
                        help="with --compare-fast: the cycles of this scenario's sampling "
                             "episode instead of the demo scene (accuracy and speed skipped)")
    args = parser.parse_args(argv)
    if args.scenario is not None:
        cycles, config = scenario_cycles(args.scenario)
        print(json.dumps({"scenario": args.scenario, "cycles": len(cycles),
                          "fast": compare_fast(config, cycles)}, indent=2))
        return 0
    config = PlannerConfig()
    sizes = g.GraphSizes(max_objects=args.max_objects, ray_samples=args.ray_samples,
                         pose_objects=args.pose_objects)
    cycles = demo_cycles(config, args.cycles, seed=0, n_samples=64)
    report = {"sizes": str(sizes), "accuracy": accuracy(config, sizes, cycles),
              "speed": speed(config, sizes, Cycle.prepare(*cycles[0], config))}
    if args.compare_fast:
        report["fast"] = compare_fast(config, cycles)
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
