"""IPOPT on the compiled problem: CasADi's ``nlpsol("ipopt")`` whose objective and gradient
are the compiled functions (no Python inside IPOPT), warm-startable, the solves of one plan on
parallel threads (each thread its own ``nlpsol``).
"""

from __future__ import annotations

import difflib
import math
import re
import subprocess
import sys
import time
from functools import lru_cache

import casadi as ca
import numpy as np

from ...core.errors import InputError
from ...core.solver_config import SolverConfig
from ..build.csource import OF_Z_ALONE
from ..build.library import Problem, SolveResult, snap
from .threads import StartExecutor

_QUIET_IPOPT = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"}

USABLE_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level", "Maximum_Iterations_Exceeded",
                   "Search_Direction_Becomes_Too_Small", "Maximum_CpuTime_Exceeded",
                   "Stop_at_Tiny_Step", "Maximum_WallTime_Exceeded")
"""IPOPT statuses whose iterate is handed back as usable: the planner judges it by its exact
cost like any other candidate."""


WALL_LIMITS = (0.005, 0.01, 0.02, 0.03, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.5, 1.0)
"""s: the wall-time limits IPOPT is built with (its options are fixed when an ``nlpsol`` is
built, ~1 ms each): a solve gets the largest that the plan's deadline leaves time for
(:func:`wall_limit`)."""


def wall_limit(left: float) -> float | None:
    """IPOPT's ``max_wall_time`` for a solve with ``left`` seconds to the deadline: None
    without a deadline, 0 when there is no time for a solve (less than the smallest of
    :data:`WALL_LIMITS`), else the largest of them not above ``left``."""
    if not math.isfinite(left):
        return None
    return max((w for w in WALL_LIMITS if w <= left), default=0.0)


def ipopt_options(solver: SolverConfig, warm: bool) -> dict:
    """``casadi.nlpsol`` options for IPOPT from a SolverConfig (``options`` override)."""
    options = dict(_QUIET_IPOPT)
    options.update({"ipopt.max_iter": solver.local.max_iter, "ipopt.tol": solver.local.tol,
                    # The bilinear tables' gradient jumps at cell edges: the dual residual
                    # stalls near 0.1 when the objective has converged (docs/design.md), so
                    # "acceptable" is judged by the objective's change alone.
                    "ipopt.acceptable_tol": 1e10, "ipopt.acceptable_iter": 3,
                    "ipopt.acceptable_dual_inf_tol": 1e10,
                    "ipopt.acceptable_obj_change_tol": 1e-3,
                    "ipopt.mu_strategy": "adaptive",
                    # The probing (Mehrotra) barrier oracle: fewer iterations than the default
                    # quality function on these 4-variable problems, at an equal or lower exact
                    # cost (docs/experiments/2026-11-23-compiled-box-qp-and-probing-oracle.md).
                    "ipopt.mu_oracle": "probing",
                    # Second-order corrections repair constraint violations; with bounds
                    # alone each rejected step paid for them in cost evaluations, and
                    # gradient scaling one gradient per solve. Both leave every iterate as it
                    # was (docs/experiments/2026-11-23-ipopt-options-and-ray-samples.md).
                    "ipopt.max_soc": 0,
                    "ipopt.nlp_scaling_method": "none",
                    # The limited-memory Hessian's augmented system solved as one extended
                    # system instead of by Sherman-Morrison backsolves: the same steps to
                    # rounding, less of IPOPT's own time per solve
                    # (docs/experiments/2026-11-23-ipopt-on-two-threads-and-pose-mask.md).
                    "ipopt.limited_memory_aug_solver": "extended"})
    if solver.local.hessian == "quasi-newton":
        options["ipopt.hessian_approximation"] = "limited-memory"
    if warm:
        options.update({"ipopt.warm_start_init_point": "yes",
                        "ipopt.warm_start_bound_push": 1e-6,
                        "ipopt.warm_start_mult_bound_push": 1e-6,
                        "ipopt.mu_init": 1e-4})
    options.update(dict(solver.local.options))
    return options


class IpoptSolver:
    """IPOPT on a :class:`Problem` with its compiled functions; ``nlpsol`` built once per
    problem (cold and warm variants)."""

    def __init__(self, solver: SolverConfig):
        check_options(solver)
        self.solver = solver
        self._built = {}

    def _nlpsol(self, problem: Problem, warm: bool, slot: int = 0, wall: float | None = None):
        # One nlpsol per thread slot (an nlpsol instance is not for two threads at once) and
        # per wall-time limit (IPOPT's options are fixed when it is built).
        key = (id(problem), warm, slot, wall)
        if key not in self._built:
            self._built[key] = _build_ipopt(problem, self.solver, warm, wall)
        return self._built[key]

    def solve_many(self, problem: Problem, starts, executor: StartExecutor | None = None) -> list:
        """:meth:`solve` from every ``(z0, lam_x)`` of ``starts``, in their order, then from
        every start the ``executor`` adds (:class:`.threads.StartExecutor`; by default one on
        ``ParallelSettings.solve_threads`` threads).

        With more than one thread the solves run at once (each thread slot its own ``nlpsol``;
        CasADi lets go of Python's lock while IPOPT runs); each start is solved exactly as it
        would be alone.
        """
        starts = list(starts)
        if executor is None:
            executor = StartExecutor(self.solver.parallel.solve_threads)
        slots = executor.slots(len(starts))
        variants = {False, True} if executor.open_ended else \
            {lam_x is not None for _, lam_x in starts}
        if slots > 1:           # built here, not in the threads: building is not thread-safe
            built = self.prebuild(problem, slots, variants, executor.time_left())
            if executor.deadline is not None:       # prepare()'s work, not counted
                executor.deadline.extend(built)
        return executor.map(lambda start, slot: self.solve(problem, *start, slot=slot,
                                                           left=executor.time_left()), starts)

    def prebuild(self, problem: Problem, slots: int, variants=(False, True),
                 left: float = math.inf) -> float:
        """Build the ``nlpsol`` of every thread slot, variant (cold, warm) and wall limit a
        solve with ``left`` seconds to its deadline may be given (:func:`wall_limit`); the
        seconds spent building (0 when all were built)."""
        started = time.perf_counter()
        missing = [(problem, warm, slot, wall) for wall in _walls_up_to(wall_limit(left))
                   for warm in variants for slot in range(slots)
                   if (id(problem), warm, slot, wall) not in self._built]
        for key in missing:
            self._nlpsol(*key)
        return time.perf_counter() - started if missing else 0.0

    def solve(self, problem: Problem, z0, lam_x=None, slot: int = 0,
              left: float = math.inf) -> SolveResult:
        """Minimise from ``z0``, warm-started from ``lam_x`` when given (``slot``: which
        thread's ``nlpsol``), stopping by ``left`` seconds from now (:func:`wall_limit`)."""
        started = time.perf_counter()
        warm = lam_x is not None
        wall = wall_limit(left)
        if wall == 0.0:
            return SolveResult.not_run(z0)
        nlpsol = self._nlpsol(problem, warm, slot, wall)
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


def _walls_up_to(wall: float | None) -> list:
    """The wall limits a solve may be given once ``wall`` is the limit now: it and the smaller
    ones (a later solve has less time left); ``[None]`` without a deadline."""
    return [None] if wall is None else [w for w in WALL_LIMITS if w <= wall]


def _build_ipopt(problem: Problem, solver: SolverConfig, warm: bool, wall: float | None = None):
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
        return functions[OF_Z_ALONE[name]](z) if bound else functions[name](z, p)

    value, gradient = call("G")
    options = ipopt_options(solver, warm)
    if wall is not None:
        options["ipopt.max_wall_time"] = wall
    options["grad_f"] = ca.Function("grad_f", [z, p], [value, gradient], ["x", "p"],
                                    ["f", "grad_f_x"])
    if solver.local.hessian != "quasi-newton":
        options["hess_lag"] = ca.Function("hess_lag", [z, p, lam_f, lam_g],
                                          [ca.triu(lam_f * call("H")[2])],
                                          ["x", "p", "lam_f", "lam_g"],
                                          ["triu_hess_gamma_x_x"])
    nlp = {"x": z, "p": p, "f": call("F")}
    try:
        return ca.nlpsol("dsmpepc_warm" if warm else "dsmpepc_cold", "ipopt", nlp, options)
    except RuntimeError as error:
        raise InputError(f"SolverConfig.local.options = {solver.local.options!r}: CasADi could "
                         "not build "
                         f"IPOPT ({str(error).splitlines()[-1]})") from None


def check_options(solver: SolverConfig) -> None:
    """Raise :class:`InputError` when ``solver.local.options`` would not build IPOPT.

    Each user option is tried alone on a one-variable ``nlpsol`` (about a millisecond each;
    nothing is tried without options), so the message names the option at fault, with the
    names it was probably meant to be: an IPOPT option written without its ``ipopt.`` prefix,
    an unknown name, or a value IPOPT refuses.
    """
    for key, value in solver.local.options:
        error = _trial_error({key: value})
        if error is not None:
            raise InputError(f"SolverConfig.local.options[{key!r}] = {value!r}: "
                             f"{_explain(key, error)}")


def _trial_error(options: dict) -> str | None:
    x = ca.MX.sym("x")
    trial = dict(_QUIET_IPOPT)
    trial.update(options)
    try:
        ca.nlpsol("dsmpepc_option_check", "ipopt", {"x": x, "f": x * x}, trial)
    except RuntimeError as error:
        return str(error)
    return None


def _explain(key: str, error: str) -> str:
    if "Unknown option" in error:       # CasADi's own level: no such nlpsol option
        names = re.findall(r'^> "([^"]+)"', error, flags=re.M)
        if key in ipopt_option_names():
            return (f"{key!r} is an IPOPT option: write it with the prefix, 'ipopt.{key}' "
                    "(options without a prefix are CasADi's nlpsol options)")
        return f"not a CasADi nlpsol option{_did_you_mean(key, names)}"
    unknown = re.search(r"No such IPOPT option: (\S+)", error)
    if unknown:
        name = unknown.group(1)
        suggestions = ["ipopt." + n for n in difflib.get_close_matches(
            name, ipopt_option_names(), n=3, cutoff=0.6)]
        hint = f"; did you mean {' or '.join(map(repr, suggestions))}?" if suggestions else \
            " (IPOPT's options are listed by its print_options_documentation)"
        return f"IPOPT has no option {name!r}{hint}"
    last = error.strip().splitlines()[-1] if error.strip() else "error"
    if "Invalid options were detected by Ipopt" in error or "type mismatch" in error:
        return ("IPOPT refused this value (wrong type, or not one of the option's settings; "
                f"IPOPT's documentation of {key.split('.', 1)[-1]!r} lists them): {last}")
    return f"CasADi could not build IPOPT with it: {last}"


def _did_you_mean(key: str, names) -> str:
    close = difflib.get_close_matches(key, list(names), n=3, cutoff=0.6)
    return f"; did you mean {' or '.join(map(repr, close))}?" if close else ""


_LIST_IPOPT_OPTIONS = """
import casadi as ca
x = ca.MX.sym("x")
ca.nlpsol("s", "ipopt", {"x": x, "f": x * x},
          {"ipopt.print_options_documentation": "yes", "print_time": False})(x0=1)
"""


@lru_cache(maxsize=1)
def ipopt_option_names() -> tuple:
    """IPOPT's option names, as the installed IPOPT documents them (asked once, in a child
    process: IPOPT prints its documentation on the C standard output). Only messages about
    bad options need them; empty when the child fails."""
    try:
        done = subprocess.run([sys.executable, "-c", _LIST_IPOPT_OPTIONS], capture_output=True,
                              text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return ()
    return tuple(sorted(set(re.findall(r"^([a-z][a-z0-9_]+) {2,}", done.stdout, flags=re.M))))


__all__ = ["IpoptSolver", "USABLE_STATUSES", "check_options", "ipopt_option_names",
           "ipopt_options"]
