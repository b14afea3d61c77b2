"""The NLP's problem and solvers, built once per configuration: the global graph, compiled.

:class:`Problem` is the global cost graph (:mod:`~dsmpepc_nlp.solve.nlp_global`) of one
configuration and one object size, compiled to C (:mod:`~dsmpepc_nlp.solve.compiled`) and cached
on disk; a cycle binds its parameters once (:meth:`Problem.bind`) and every evaluation after
that is one C call. The two solvers run on it and return a typed :class:`SolveResult`:

- :class:`NewtonSolver`, the trust-region Newton method of :mod:`~dsmpepc_nlp.solve.newton`
  (``SolverConfig.fast()``), one compiled call per evaluation;
- :class:`IpoptSolver`, CasADi's ``nlpsol("ipopt")`` whose objective, gradient and Hessian are
  the compiled functions (CasADi ``external`` s, no Python inside IPOPT), warm-startable.

The graph is valid at every z, so there is no re-linearisation: one solve per start.
"""

from __future__ import annotations

import functools
import math
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..core.config import VARIANTS, PlannerConfig, RobotState, SolverConfig
from ..core.errors import InputError
from ..core.world import World
from . import compiled, nlp_global
from .cache import compile_enabled
from .cycle import Cycle
from .newton import minimize, minimize_compiled


@dataclass(frozen=True)
class SolveResult:
    """One solve from one start.

    Attributes
    ----------
    x : ndarray, (4,)
        Where the solver stopped (in the box).
    fun : float
        The smooth cost there.
    status : str
        The solver's return status.
    success : bool
        True when ``x`` is usable (converged, or an iteration limit with a finite iterate).
    nit : int
        Iterations.
    time_s : float
        Wall time of the solve.
    lam_x : ndarray or None
        Bound multipliers (IPOPT; for the next plan's warm start).
    nfev : int
        Evaluations of the cost alone (line search, trust-region trials).
    ngev : int
        Evaluations with derivatives: IPOPT's gradients; the Newton method's gradient or
        Hessian calls (with ``quasi-newton`` the first is a difference Hessian, 5 gradients).
    """

    x: np.ndarray
    fun: float
    status: str
    success: bool
    nit: int
    time_s: float
    lam_x: np.ndarray | None = None
    nfev: int = 0
    ngev: int = 0


class Problem:
    """The global graph of one configuration and object size, compiled, parameters bound once.

    Parameters
    ----------
    config : PlannerConfig
    sizes : nlp_global.GraphSizes
    solver : SolverConfig
        ``fd_step`` and ``hessian`` (how the compiled Hessian is formed).
    """

    def __init__(self, config: PlannerConfig, sizes, solver: SolverConfig):
        started = time.perf_counter()
        self.config, self.sizes = config, sizes
        self.lower = np.array(config.z_lower, dtype=float)
        self.upper = np.array(config.z_upper, dtype=float)
        cost = nlp_global.flat_cost(config, sizes)
        self.n_params = cost.size1_in(1)
        step = solver.fd_step * (self.upper - self.lower)
        hessian = "exact" if solver.hessian == "exact" else "differences"
        self.functions = compiled.build(cost, self.n_params, step, (config, sizes, "global"),
                                        hessian)
        self.p = np.zeros(self.n_params)
        self.build_s = time.perf_counter() - started

    def pack(self, cycle) -> np.ndarray:
        """The flat parameter vector of ``cycle`` for this graph."""
        return nlp_global.flatten_parameters(nlp_global.pack_parameters(cycle, self.sizes))

    def bind(self, p: np.ndarray) -> None:
        """Use ``p`` for every evaluation until the next ``bind``."""
        self.p = np.ascontiguousarray(p, dtype=float)
        self.functions.bind(self.p)

    def f(self, z) -> float:
        """The smooth cost at ``z``."""
        return float(self.functions.call("F", z)[0].item())

    def fg(self, z) -> tuple:
        """``(f, gradient (4,))`` at ``z`` (a copy)."""
        value, gradient = self.functions.call("G", z)
        return float(value.item()), gradient.reshape(-1).copy()

    def fgh(self, z) -> tuple:
        """``(f, gradient (4,), Hessian (4, 4))`` at ``z`` (copies)."""
        value, gradient, hessian = self.functions.call("H", z)
        return float(value.item()), gradient.reshape(-1).copy(), np.array(hessian)


def problem(config: PlannerConfig, sizes, solver: SolverConfig) -> Problem:
    """The :class:`Problem` of a configuration, built (or loaded from the disk cache) once per
    process and shared by every planner of that configuration. Not for concurrent threads."""
    # The cache folder's override is part of the key (not cache_dir(): it reads the package
    # metadata, a millisecond per plan).
    return _problem(config, sizes, _graph_knobs(solver), compile_enabled(),
                    os.environ.get("DSMPEPC_CACHE_DIR", ""))


@functools.lru_cache(maxsize=32)
def _problem(config, sizes, knobs, compiling, folder) -> Problem:
    del compiling, folder                 # part of the key: a change of either builds anew
    return Problem(config, sizes, knobs)


def _graph_knobs(solver: SolverConfig) -> SolverConfig:
    """Only the fields a Problem depends on, so that solvers differing elsewhere share it."""
    hessian = "exact" if solver.hessian == "exact" else "differences"
    return SolverConfig(fd_step=solver.fd_step, hessian=hessian)


def snap(z, lower, upper) -> np.ndarray:
    """z clipped to the box, and put on a bound within 1e-4 of its range of it.

    An interior-point solution of an active bound sits about ``tol`` inside it; on ``v_max``
    that leaves a robot in collision creeping at ~1e-5 m/s instead of stopping (Lemma 3), so
    active bounds are made exact.
    """
    z = np.clip(z, lower, upper)
    near = 1e-4 * (upper - lower)
    z = np.where(z - lower < near, lower, z)
    return np.where(upper - z < near, upper, z)


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

    def solve_many(self, problem: Problem, starts) -> list:
        """Minimise from every ``(z0, lam_x)`` of ``starts`` (``lam_x`` ignored).

        With the quasi-Newton Hessian on compiled functions the starts run at once on
        parallel threads, the loop compiled (:func:`.newton.minimize_compiled`; each
        result's ``time_s`` is then the batch's wall time); else one after another in the
        Python loop, its definition.
        """
        started = time.perf_counter()
        knobs = dict(radius=self.solver.trust_radius, max_iter=self.solver.max_iter,
                     tol=self.solver.tol)
        z0s = [np.asarray(z0, dtype=float) for z0, _ in starts]
        if self.solver.hessian == "quasi-newton":
            results = minimize_compiled(problem.functions, np.array(z0s), problem.lower,
                                        problem.upper, **knobs)
            if results is not None:
                elapsed = time.perf_counter() - started
                return [self._result(problem, z0, r, elapsed) for z0, r in zip(z0s, results)]
        out = []
        for z0 in z0s:
            begun = time.perf_counter()
            fgh = sr1(problem) if self.solver.hessian == "quasi-newton" else problem.fgh
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


_QUIET_IPOPT = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"}

USABLE_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level", "Maximum_Iterations_Exceeded",
                   "Search_Direction_Becomes_Too_Small", "Maximum_CpuTime_Exceeded",
                   "Stop_at_Tiny_Step", "Maximum_WallTime_Exceeded")
"""IPOPT statuses whose iterate is handed back as usable: the planner judges it by its exact
cost like any other candidate."""


def ipopt_options(solver: SolverConfig, warm: bool) -> dict:
    """``casadi.nlpsol`` options for IPOPT from a SolverConfig (``options`` override)."""
    options = dict(_QUIET_IPOPT)
    options.update({"ipopt.max_iter": solver.max_iter, "ipopt.tol": solver.tol,
                    # The bilinear tables' gradient jumps at cell edges: the dual residual
                    # stalls near 0.1 when the objective has converged (docs/nlp.md), so
                    # "acceptable" is judged by the objective's change alone.
                    "ipopt.acceptable_tol": 1e10, "ipopt.acceptable_iter": 3,
                    "ipopt.acceptable_dual_inf_tol": 1e10,
                    "ipopt.acceptable_obj_change_tol": 1e-3,
                    "ipopt.mu_strategy": "adaptive",
                    # The probing (Mehrotra) barrier oracle: fewer iterations than the default
                    # quality function on these 4-variable problems, at an equal or lower exact
                    # cost (docs/nlp.md, "this pass").
                    "ipopt.mu_oracle": "probing",
                    # Second-order corrections repair constraint violations; with bounds
                    # alone each rejected step paid for them in cost evaluations (46 -> 29
                    # per solve), and gradient scaling one gradient per solve. Both leave
                    # every iterate as it was (docs/nlp.md, "Pass 4").
                    "ipopt.max_soc": 0,
                    "ipopt.nlp_scaling_method": "none",
                    # The limited-memory Hessian's augmented system solved as one extended
                    # system instead of by Sherman-Morrison backsolves: the same steps to
                    # rounding, ~2 ms less of IPOPT's own time per solve (docs/nlp.md, "Pass 5").
                    "ipopt.limited_memory_aug_solver": "extended"})
    if solver.hessian == "quasi-newton":
        options["ipopt.hessian_approximation"] = "limited-memory"
    if warm:
        options.update({"ipopt.warm_start_init_point": "yes",
                        "ipopt.warm_start_bound_push": 1e-6,
                        "ipopt.warm_start_mult_bound_push": 1e-6,
                        "ipopt.mu_init": 1e-4})
    options.update(dict(solver.options))
    return options


class IpoptSolver:
    """IPOPT on a :class:`Problem` with its compiled functions; ``nlpsol`` built once per
    problem (cold and warm variants)."""

    def __init__(self, solver: SolverConfig):
        self.solver = solver
        self._built = {}

    def _nlpsol(self, problem: Problem, warm: bool, slot: int = 0):
        # One nlpsol per thread slot: an nlpsol instance is not for two threads at once.
        key = (id(problem), warm, slot)
        if key not in self._built:
            self._built[key] = _build_ipopt(problem, self.solver, warm)
        return self._built[key]

    def solve_many(self, problem: Problem, starts) -> list:
        """:meth:`solve` from every ``(z0, lam_x)`` of ``starts``, in their order.

        With ``SolverConfig.solve_threads`` above 1 the solves run at once on that many
        threads (each thread slot its own ``nlpsol``; CasADi lets go of Python's lock while
        IPOPT runs); each start is solved exactly as it would be alone.
        """
        starts = list(starts)
        slots = min(self.solver.solve_threads, len(starts))
        if slots <= 1:
            return [self.solve(problem, z0, lam_x) for z0, lam_x in starts]
        for slot in range(slots):     # built here, not in the threads: building is not
            for warm in {lam_x is not None for _, lam_x in starts}:      # thread-safe
                self._nlpsol(problem, warm, slot)
        pending = iter(range(len(starts)))
        lock = threading.Lock()
        results = [None] * len(starts)

        def work(slot):
            while True:
                with lock:
                    i = next(pending, None)
                if i is None:
                    return
                results[i] = self.solve(problem, *starts[i], slot=slot)

        for future in [_pool(slots).submit(work, slot) for slot in range(slots)]:
            future.result()
        return results

    def solve(self, problem: Problem, z0, lam_x=None, slot: int = 0) -> SolveResult:
        """Minimise from ``z0``, warm-started from ``lam_x`` when given (``slot``: which
        thread's ``nlpsol``)."""
        started = time.perf_counter()
        warm = lam_x is not None
        nlpsol = self._nlpsol(problem, warm, slot)
        args = {"x0": z0, "lbx": problem.lower, "ubx": problem.upper}
        if not problem.functions.compiled:
            args["p"] = problem.p
        if warm:
            args["lam_x0"] = lam_x
        try:
            result = nlpsol(**args)
            stats = nlpsol.stats()
        except RuntimeError as error:
            message = str(error).strip().splitlines()[-1] if str(error).strip() else "error"
            return SolveResult(np.asarray(z0, dtype=float), math.nan, f"exception: {message}",
                               False, 0, time.perf_counter() - started)
        elapsed = time.perf_counter() - started
        z = np.asarray(result["x"], dtype=float).reshape(-1)
        cost = float(result["f"])
        status = str(stats.get("return_status", "unknown"))
        nit = int(stats.get("iter_count", 0))
        counts = dict(nfev=int(stats.get("n_call_nlp_f", 0)),
                      ngev=int(stats.get("n_call_nlp_grad_f", 0)))
        if not (np.all(np.isfinite(z)) and math.isfinite(cost)):
            return SolveResult(np.asarray(z0, dtype=float), math.nan,
                               f"non-finite result ({status})", False, nit, elapsed, **counts)
        usable = bool(stats.get("success", False)) or status in USABLE_STATUSES
        return SolveResult(snap(z, problem.lower, problem.upper), cost, status, usable, nit,
                           elapsed, np.asarray(result["lam_x"], dtype=float).reshape(-1),
                           **counts)


_POOLS = {}


def _pool(threads: int) -> ThreadPoolExecutor:
    """This process's pool of at least ``threads`` threads (a forked child makes its own: a
    parent's pool threads do not exist there)."""
    key = os.getpid()
    pool = _POOLS.get(key)
    if pool is None or pool._max_workers < threads:
        if pool is not None:
            pool.shutdown(wait=False)
        pool = _POOLS[key] = ThreadPoolExecutor(threads, thread_name_prefix="dsmpepc-ipopt")
    return pool


def _build_ipopt(problem: Problem, solver: SolverConfig, warm: bool):
    """``nlpsol`` over the compiled F, with grad_f and hess_lag from the compiled G and H.

    Compiled: the bound functions of z alone (the cycle's parameters are bound once, never
    passed through IPOPT: converting and copying the tables per solve and per call cost more
    than the solve). Virtual machine: F, G, H of (z, p) with p passed to ``nlpsol``.
    """
    functions = problem.functions.functions
    bound = problem.functions.compiled
    z, p = ca.MX.sym("z", 4), ca.MX.sym("p", 0 if bound else problem.n_params)
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", 0, 1)

    def call(name):
        return functions[name + "b"](z) if bound else functions[name](z, p)

    value, gradient = call("G")
    options = ipopt_options(solver, warm)
    options["grad_f"] = ca.Function("grad_f", [z, p], [value, gradient], ["x", "p"],
                                    ["f", "grad_f_x"])
    if solver.hessian != "quasi-newton":
        options["hess_lag"] = ca.Function("hess_lag", [z, p, lam_f, lam_g],
                                          [ca.triu(lam_f * call("H")[2])],
                                          ["x", "p", "lam_f", "lam_g"],
                                          ["triu_hess_gamma_x_x"])
    nlp = {"x": z, "p": p, "f": call("F")}
    try:
        return ca.nlpsol("dsmpepc_warm" if warm else "dsmpepc_cold", "ipopt", nlp, options)
    except RuntimeError as error:
        raise InputError(f"SolverConfig.options = {solver.options!r}: CasADi could not build "
                         f"IPOPT ({str(error).splitlines()[-1]})") from None


def build(variants=None, solver: SolverConfig | None = None) -> dict:
    """Compile (or load) the graph of every built-in variant and object bucket ahead of use.

    Also compiles the fast method's loop (numba, ~20 s on first use, cached like the
    graph): run once, it keeps that out of the first fast plan.

    Returns ``compiled`` (False on the virtual machine), ``seconds`` and ``problems`` (how
    many configurations).
    """
    solver = SolverConfig() if solver is None else solver
    started = time.perf_counter()
    built = []
    for name in VARIANTS if variants is None else variants:
        for bucket in solver.pose_object_buckets:
            sizes = nlp_global.GraphSizes(pose_objects=bucket)
            built.append(problem(PlannerConfig.variant(name), sizes, solver))
    if built and built[0].functions.compiled:
        _warm_newton_loop(built[0])
    return {"compiled": all(p.functions.compiled for p in built),
            "seconds": time.perf_counter() - started, "problems": len(built)}


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


__all__ = ["IpoptSolver", "NewtonSolver", "Problem", "SolveResult", "build", "make_solver",
           "problem",
           "snap"]
