"""The NLP's solvers by name, and every problem built ahead of use.

The problem (:class:`~dsmpepc_nlp.solve.build.library.Problem`: the graph compiled, parameters bound
once per cycle) is solved by one backend, one file each, made here (:func:`make_solver`, the
one place that names them):

- ``"newton"``: :class:`~dsmpepc_nlp.solve.optimize.newton.NewtonSolver`, the trust-region Newton
  method (``SolverConfig.fast()``), its loop compiled;
- ``"ipopt"``: :class:`~dsmpepc_nlp.solve.optimize.ipopt.IpoptSolver`, CasADi's ``nlpsol("ipopt")``
  whose objective and gradient are the compiled functions, warm-startable;

each with ``solve_many(problem, starts, executor) -> list[SolveResult]``
(:class:`~dsmpepc_nlp.solve.optimize.threads.StartExecutor` runs the starts). The graph is valid at
every z, so there is no re-linearisation: one solve per start.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from ...core.config import VARIANTS, PlannerConfig, RobotState
from ...core.errors import InputError
from ...core.solver_config import SolverConfig
from ...core.world import World
from .. import problem as graph
from ..build.library import Problem, problem
from ..exact.cycle import Cycle
from .ipopt import IpoptSolver
from .newton import NewtonSolver, minimize_compiled


def build_problems(variants=None, solver: SolverConfig | None = None, workers: int | None = None,
          robots=()) -> dict:
    """Compile (or load) the graph of every built-in variant and object bucket ahead of use,
    for the default robot and each of ``robots`` (``RobotConfig``: the built-in scenarios'
    bodies, passed by the command line).

    The libraries missing from the cache compile in up to ``workers`` child processes at once
    (default: the machine's cores, at most one per 1.5 GB of memory: a compile's ``cc1`` peaks
    near 0.9 GB), then every problem is loaded here. Also compiles the fast method's loop
    (numba, ~20 s on first use, cached like the graph): run once, it keeps that out of the first
    fast plan.

    Returns ``compiled`` (False on the virtual machine), ``seconds``, ``problems`` (how many
    configurations), ``libraries`` (distinct compiled structures) and ``compiled_now`` (how
    many were compiled by this call).
    """
    solver = SolverConfig() if solver is None else solver
    started = time.perf_counter()
    configs = [PlannerConfig.variant(name) for name in (VARIANTS if variants is None
                                                         else variants)]
    configs += [dataclasses.replace(config, robot=robot) for robot in robots
                for config in configs[:1]]      # one variant: they share a structure
    wanted = [(config, graph.GraphSizes(pose_objects=bucket)) for config in configs
              for bucket in solver.pose_object_buckets]
    libraries, missing = compile_missing(wanted, solver, workers)
    built = [problem(config, sizes, solver) for config, sizes in wanted]
    if built and built[0].functions.compiled:
        warm_newton_loop(built[0])
    return {"compiled": all(p.functions.compiled for p in built),
            "seconds": time.perf_counter() - started, "problems": len(built),
            "libraries": libraries, "compiled_now": missing}


def compile_missing(wanted, solver: SolverConfig, workers: int | None = None) -> tuple:
    """Compile the libraries of ``wanted`` (``(config, sizes)`` pairs) missing from the cache,
    in up to ``workers`` child processes at once (default :func:`_build_workers`); returns
    ``(distinct libraries, libraries compiled)``."""
    from ..build import background
    from ..build.library import library_key

    keys = {library_key(config, sizes, solver): (config, sizes) for config, sizes in wanted}
    missing = [key for key in keys if not compiled_library_exists(key)]
    if len(missing) > 1:    # one alone compiles in this process, as it would in a plan
        background.run_all([(key, *keys[key], solver) for key in missing],
                           workers or _build_workers())
    return len(keys), len(missing)


def compiled_library_exists(key: str) -> bool:
    """True when the library of ``key`` is cached, or nothing can be compiled."""
    from ..build import compiled

    return not compiled.compiling_possible() or compiled.is_cached(key)


def _build_workers() -> int:
    import os

    cores = os.cpu_count() or 1
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1
    return max(1, min(cores, int(memory // (1.5 * 2**30))))


def warm_newton_loop(problem: Problem) -> None:
    """Compile (or load) the compiled Newton loop with one short solve on an empty world."""
    cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.0), World(), np.array([5.0, 0.0]),
                          problem.config)
    problem.bind(problem.pack(cycle))
    minimize_compiled(problem.functions, [0.5 * (problem.lower + problem.upper)],
                      problem.lower, problem.upper, max_iter=1)


def make_solver(solver: SolverConfig):
    """The solver object of ``solver.method`` (``ipopt`` or ``newton``)."""
    if solver.method == "ipopt":
        return IpoptSolver(solver)
    if solver.method == "newton":
        return NewtonSolver(solver)
    raise InputError(f"SolverConfig.method = {solver.method!r}: the NLP runs 'ipopt' or "
                     "'newton'")


__all__ = ["build_problems", "compile_missing", "make_solver", "warm_newton_loop"]
