"""The NLP's problem: the global graph of one configuration, compiled, and a solve's result.

:class:`Problem` is the global cost graph (:mod:`~dsmpepc_nlp.solve.problem`) of one
configuration and one object size, compiled to C (:mod:`~dsmpepc_nlp.solve.build.compiled`)
and cached on disk; a cycle binds its parameters once (:meth:`Problem.bind`) and every
evaluation after that is one C call. The solvers (:mod:`~dsmpepc_nlp.solve.optimize.solvers`)
run on it and return a typed :class:`SolveResult`.
"""

from __future__ import annotations

import functools
import math
import os
import time
from dataclasses import dataclass

import numpy as np

from ...core.compile_cache import compile_enabled
from ...core.config import PlannerConfig
from ...core.solver_config import LocalSolverSettings, SolverConfig
from .. import problem as graph
from ..problem import parameters as settings
from . import background, compiled


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

    @classmethod
    def not_run(cls, z0) -> SolveResult:
        """The result of a start the time budget left no time for: ``z0``, unsolved."""
        return cls(np.asarray(z0, dtype=float), math.nan, NOT_RUN, False, 0, 0.0)


NOT_RUN = "not run: the time budget was spent"
"""The status of a start the plan's deadline came before (:meth:`SolveResult.not_run`)."""


class Problem:
    """The global graph of one configuration and object size, compiled, parameters bound once.

    Parameters
    ----------
    config : PlannerConfig
    sizes : graph.GraphSizes
    solver : SolverConfig
        ``fd_step`` and ``hessian`` (how the compiled Hessian is formed).
    """

    def __init__(self, config: PlannerConfig, sizes, solver: SolverConfig):
        started = time.perf_counter()
        self.config, self.sizes = config, sizes
        self.lower = np.array(config.z_lower, dtype=float)
        self.upper = np.array(config.z_upper, dtype=float)
        # The difference steps follow the box, a setting: parameters, like the configuration's
        # numbers (the ``settings`` block), so the library is keyed by structure alone.
        self.steps = solver.local.fd_step * (self.upper - self.lower)
        hessian = "exact" if solver.local.hessian == "exact" else "differences"
        self.functions = compiled.load_or_compile(lambda: graph.flat_cost(config, sizes), None,
                                        structure_key(config, sizes), hessian)
        self.n_params = self.functions.n_params
        self.p = np.zeros(self.n_params)
        self.build_s = time.perf_counter() - started

    def pack(self, cycle) -> np.ndarray:
        """The flat parameter vector of ``cycle`` for this graph (the difference steps last)."""
        flat = graph.flatten_parameters(graph.pack_parameters(cycle, self.sizes))
        return np.concatenate([flat, self.steps])

    def bind(self, p: np.ndarray) -> None:
        """Use ``p`` (from :meth:`pack`) for every evaluation until the next ``bind``."""
        p = np.ascontiguousarray(p, dtype=float)
        if p.shape != (self.n_params,):        # compiled code would read past its end
            raise ValueError(f"p has shape {p.shape}: this problem takes ({self.n_params},), "
                             "from Problem.pack")
        self.p = p
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


def structure_key(config: PlannerConfig, sizes) -> tuple:
    """What a compiled library of ``config`` and ``sizes`` is keyed by: the graph's structure
    (:func:`.settings.structure`), the sizes with the ray's samples resolved, and the parameter
    layout; never a number that is a parameter."""
    sizes = graph.resolved_sizes(config, sizes)
    shapes = graph.parameter_shapes(config, sizes)
    return (settings.structure(config), sizes, tuple(shapes.items()), "global")


def problem(config: PlannerConfig, sizes, solver: SolverConfig) -> Problem:
    """The :class:`Problem` of a configuration, built (or loaded from the disk cache) once per
    process and shared by every planner of that configuration. Not for concurrent threads."""
    # The cache folder's override is part of the key (not cache_dir(): it reads the package
    # metadata, a millisecond per plan).
    return _problem(config, sizes, _graph_knobs(solver), compile_enabled(),
                    os.environ.get("DSMPEPC_CACHE_DIR", ""))


def library_key(config: PlannerConfig, sizes, solver: SolverConfig) -> str:
    """The cache key of the compiled library :func:`problem` loads for these arguments."""
    hessian = _graph_knobs(solver).local.hessian
    return compiled.library_key(*structure_key(config, sizes), hessian=hessian)


def readiness(config: PlannerConfig, sizes, solver: SolverConfig) -> tuple:
    """``(ready, note)``: ready when :func:`problem` returns without compiling (built in this
    process, compiled in the cache, or no compiler: the virtual machine), or when its
    background compiles failed :data:`.background.MAX_TRIES` times (the planner builds it).
    Otherwise a child process compiles it (started here, one at a time, a failed one again)
    and ``note`` says so."""
    if not compiled.compiling_possible():
        return True, ""
    knobs = _graph_knobs(solver)
    if (config, sizes, knobs) in _BUILT:
        return True, ""
    key = library_key(config, sizes, solver)
    if compiled.is_cached(key):
        background.state(key)      # reaps a child that compiled it, closes its pipe
        return True, ""
    status, seconds = background.state(key)
    if status == "done" or background.exhausted(key):
        return True, ""            # there (a race with the cache check), or built here
    what = f"the NLP's library for this structure ({sizes.k_pose} objects at a pose)"
    if background.start(key, config, sizes, knobs):
        return False, f"{what} is compiling in the background ({seconds:.0f} s so far)"
    return False, f"{what} waits for another library's compile in the background"


_BUILT: set = set()
"""(config, sizes, knobs) of the problems built in this process."""


@functools.lru_cache(maxsize=32)
def _problem(config, sizes, knobs, compiling, folder) -> Problem:
    del compiling, folder                 # part of the key: a change of either builds anew
    built = Problem(config, sizes, knobs)
    _BUILT.add((config, sizes, knobs))
    return built


def _graph_knobs(solver: SolverConfig) -> SolverConfig:
    """Only the fields a Problem depends on, so that solvers differing elsewhere share it."""
    hessian = "exact" if solver.local.hessian == "exact" else "differences"
    return SolverConfig(local=LocalSolverSettings(fd_step=solver.local.fd_step, hessian=hessian))


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


__all__ = ["Problem", "SolveResult", "library_key", "problem", "readiness", "snap",
           "structure_key"]
