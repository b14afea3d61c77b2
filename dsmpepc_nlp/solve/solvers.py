"""The NLP's solvers, built once per configuration, on the compiled global graph.

The problem (:class:`~dsmpepc_nlp.solve.problem.Problem`: the graph compiled, parameters bound
once per cycle) is solved by

- :class:`NewtonSolver`, the trust-region Newton method of :mod:`~dsmpepc_nlp.solve.newton`
  (``SolverConfig.fast()``), one compiled call per evaluation;
- :class:`~dsmpepc_nlp.solve.ipopt.IpoptSolver`, CasADi's ``nlpsol("ipopt")`` whose objective
  and gradient are the compiled functions, warm-startable;

each returning a typed :class:`~dsmpepc_nlp.solve.problem.SolveResult`. The graph is valid at
every z, so there is no re-linearisation: one solve per start.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..core.config import VARIANTS, PlannerConfig, RobotState
from ..core.errors import InputError
from ..core.solver_config import SolverConfig
from ..core.world import World
from . import graph
from .cycle import Cycle
from .ipopt import IpoptSolver
from .newton import minimize, minimize_compiled
from .problem import Problem, SolveResult, problem, snap


def sr1(problem: Problem):
    """``fgh`` for :func:`~dsmpepc_nlp.solve.newton.minimize` with a quasi-Newton Hessian: the
    compiled (finite-difference) Hessian at the start, then symmetric rank-one updates from the
    gradients at the accepted points (one compiled gradient per step instead of five)."""
    state = {}

    def fgh(z):
        if not state:
            value, gradient, hessian = problem.fgh(z)
        else:
            value, gradient = problem.fg(z)
            step, change = z - state["z"], gradient - state["g"]
            hessian = state["H"].copy()
            residual = change - hessian @ step
            denominator = float(residual @ step)
            if abs(denominator) > 1e-8 * np.linalg.norm(step) * np.linalg.norm(residual):
                hessian += np.outer(residual, residual) / denominator
        state.update(z=np.array(z, dtype=float), g=gradient, H=hessian)
        return value, gradient, hessian
    return fgh


class NewtonSolver:
    """The trust-region Newton method on a :class:`Problem` (parameters already bound);
    ``hessian="quasi-newton"``: symmetric rank-one updates (:func:`sr1`)."""

    def __init__(self, solver: SolverConfig):
        self.solver = solver

    def solve(self, problem: Problem, z0, lam_x=None) -> SolveResult:
        """Minimise from ``z0``; ``lam_x`` is ignored (no multipliers to warm)."""
        return self.solve_many(problem, [(z0, lam_x)])[0]

    def solve_many(self, problem: Problem, starts, idle=None, more=None) -> list:
        """Minimise from every ``(z0, lam_x)`` of ``starts`` (``lam_x`` ignored), then from
        every start ``more(busy)`` lists.

        With the quasi-Newton Hessian on compiled functions the starts run at once on
        ``ParallelSettings.solve_threads`` threads, the loop compiled
        (:func:`.newton.minimize_compiled`; each result's ``time_s`` is then the batch's wall
        time; ``idle`` and ``more`` as in :func:`.threads.run_starts`); else one after
        another in the Python loop, its definition (no thread is left idle there: ``idle`` is
        not called; ``more`` is asked for first).
        """
        started = time.perf_counter()
        local = self.solver.local
        knobs = dict(radius=local.trust_radius, max_iter=local.max_iter, tol=local.tol)
        z0s = [np.asarray(z0, dtype=float) for z0, _ in starts]
        listing = []

        def listed(busy):           # once, even when the compiled loop fails after asking
            if not listing:
                listing.append([np.asarray(z0, dtype=float) for z0, _ in more(busy)])
                z0s.extend(listing[0])
            return listing[0]

        if self.solver.local.hessian == "quasi-newton":
            def lent(done, busy):     # the idle thread sees results as the solver gives them
                elapsed = time.perf_counter() - started
                idle({i: self._result(problem, z0s[i], r, elapsed) for i, r in done.items()},
                     busy)

            results = minimize_compiled(problem.functions, np.array(z0s), problem.lower,
                                        problem.upper, threads=self.solver.parallel.solve_threads,
                                        idle=None if idle is None else lent,
                                        more=None if more is None else listed, **knobs)
            if results is not None:
                elapsed = time.perf_counter() - started
                return [self._result(problem, z0, r, elapsed) for z0, r in zip(z0s, results)]
        if more is not None:
            listed(False)
        out = []
        for z0 in z0s:
            begun = time.perf_counter()
            fgh = sr1(problem) if self.solver.local.hessian == "quasi-newton" else problem.fgh
            result = minimize(problem.f, fgh, z0, problem.lower, problem.upper, **knobs)
            out.append(self._result(problem, z0, result, time.perf_counter() - begun))
        return out

    @staticmethod
    def _result(problem, z0, result, elapsed) -> SolveResult:
        counts = dict(nfev=result.nfev, ngev=result.nhev)
        if not (np.all(np.isfinite(result.x)) and math.isfinite(result.fun)):
            return SolveResult(z0, math.nan, f"non-finite result ({result.status})", False,
                               result.nit, elapsed, **counts)
        return SolveResult(snap(result.x, problem.lower, problem.upper), result.fun,
                           result.status, result.status != "non-finite", result.nit, elapsed,
                           **counts)


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
        _warm_newton_loop(built[0])
    return {"compiled": all(p.functions.compiled for p in built),
            "seconds": time.perf_counter() - started, "problems": len(built),
            "libraries": libraries, "compiled_now": missing}


def compile_missing(wanted, solver: SolverConfig, workers: int | None = None) -> tuple:
    """Compile the libraries of ``wanted`` (``(config, sizes)`` pairs) missing from the cache,
    in up to ``workers`` child processes at once (default :func:`_build_workers`); returns
    ``(distinct libraries, libraries compiled)``."""
    from . import background
    from .problem import library_key

    keys = {library_key(config, sizes, solver): (config, sizes) for config, sizes in wanted}
    missing = [key for key in keys if not compiled_library_exists(key)]
    if len(missing) > 1:    # one alone compiles in this process, as it would in a plan
        background.run_all([(key, *keys[key], solver) for key in missing],
                           workers or _build_workers())
    return len(keys), len(missing)


def compiled_library_exists(key: str) -> bool:
    """True when the library of ``key`` is cached, or nothing can be compiled."""
    from . import compiled

    return not compiled.compiling_possible() or compiled.is_cached(key)


def _build_workers() -> int:
    import os

    cores = os.cpu_count() or 1
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1
    return max(1, min(cores, int(memory // (1.5 * 2**30))))


def _warm_newton_loop(problem: Problem) -> None:
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


__all__ = ["IpoptSolver", "NewtonSolver", "Problem", "SolveResult", "build_problems", "make_solver",
           "problem", "snap", "sr1"]
