"""The DS-MPEPC NLP: the smooth cost graph solved by IPOPT (or SQP) from several starts.

The graph (``nlp_graph.py``) and the ``nlpsol`` instances are built once per configuration in
:class:`NlpSolver`; :meth:`NlpSolver.solve` only packs parameters and runs the starts. The
verdict on a start is its exact cost, taken by the :class:`~dsmpepc_nlp.planner.Planner`.

Solver settings (measured with ``python -m dsmpepc_nlp.benchmark``; see the report in the
repository's history): IPOPT with the exact Hessian of the SX graph; the ``warm`` start uses
IPOPT's warm-start options and last cycle's bound multipliers. The fast configuration is
``sqpmethod`` with ``qrqp`` and an eigenvalue-clipped exact Hessian. ``fatrop`` needs a
stage-wise structure and is refused for this 4-variable problem (it raises at construction in
CasADi 3.8; :class:`NlpSolver` reports it as a ``ValueError``).
"""

from __future__ import annotations

import hashlib
import math
import os
import time

import casadi as ca
import numpy as np

from .config import PlannerConfig, RobotState, SolverConfig
from .nlp_graph import (
    PARAMETER_NAMES,
    GraphSizes,
    build_cost_function,
    flatten_parameters,
    pack_parameters,
    parameter_shapes,
)

__all__ = ["NlpSolver", "cost_function", "pack_parameters", "GraphSizes", "PARAMETER_NAMES",
           "parameter_shapes"]


def cost_function(config: PlannerConfig, sizes: GraphSizes | None = None,
                  smoothing=None) -> ca.Function:
    """The smooth DS-MPEPC cost as a ``casadi.Function`` to embed in your own problem.

    Parameters
    ----------
    config : PlannerConfig
        Method and parameters; the temperatures come from ``config.smoothing`` unless
        ``smoothing`` is given (``SmoothingConfig.exact()`` gives the non-smooth forms).
    sizes : GraphSizes, optional
        Fixed sizes of the obstacle, map and navigation blocks.

    Returns
    -------
    casadi.Function
        Named inputs ``z`` (4: r [m], theta [rad], delta [rad], v_max [m/s]), ``state`` (5),
        ``goal`` (2), ``obstacle_circles``, ``obstacle_velocities``, ``map_disks``,
        ``nav_waypoints`` (shapes from :func:`parameter_shapes`); named outputs ``cost``,
        ``progress``, ``action``, ``collision``, ``heading``, ``terminal``.

    Examples
    --------
    >>> f = cost_function(PlannerConfig())                       # doctest: +SKIP
    >>> params = pack_parameters(state, world, goal, PlannerConfig(), GraphSizes())
    >>> f(z=[2.0, 0.0, 0.0, 0.8], **params)["cost"]              # doctest: +SKIP
    """
    return build_cost_function(config, GraphSizes() if sizes is None else sizes, smoothing)


_QUIET_IPOPT = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"}


def _plugin_options(solver: SolverConfig, warm: bool) -> tuple[str, dict]:
    """``(plugin, options)`` for ``casadi.nlpsol`` from a SolverConfig."""
    if solver.method == "ipopt":
        options = dict(_QUIET_IPOPT)
        options.update({"ipopt.max_iter": solver.max_iter, "ipopt.tol": solver.tol,
                        "ipopt.acceptable_tol": 1e-3, "ipopt.acceptable_iter": 3,
                        "ipopt.mu_strategy": "adaptive"})
        if warm:
            options.update({"ipopt.warm_start_init_point": "yes",
                            "ipopt.warm_start_bound_push": 1e-6,
                            "ipopt.warm_start_mult_bound_push": 1e-6,
                            "ipopt.mu_init": 1e-4})
    elif solver.method == "sqpmethod":
        options = {"qpsol": "qrqp", "print_time": False, "print_header": False,
                   "print_iteration": False, "print_status": False,
                   "max_iter": solver.max_iter, "tol_du": solver.tol, "tol_pr": solver.tol,
                   "hessian_approximation": "exact", "convexify_strategy": "eigen-clip",
                   "error_on_fail": False,
                   "qpsol_options": {"print_iter": False, "print_header": False,
                                     "print_info": False, "error_on_fail": False}}
    elif solver.method == "fatrop":
        options = {"print_time": False, "structure_detection": "none",
                   "fatrop.print_level": 0, "fatrop.max_iter": solver.max_iter}
    else:
        raise ValueError(f"SolverConfig.method = {solver.method!r}: NlpSolver needs an NLP "
                         "plugin (ipopt, sqpmethod, fatrop)")
    options.update(dict(solver.options))
    return solver.method, options


def _jit_options(config: PlannerConfig, sizes: GraphSizes, directory: str) -> dict:
    """C compilation options cached on disk by a hash of the configuration."""
    key = hashlib.sha1(repr((config, sizes)).encode()).hexdigest()[:16]
    os.makedirs(directory, exist_ok=True)
    return {"jit": True, "compiler": "shell", "jit_cleanup": False,
            "jit_name": os.path.join(directory, f"dsmpepc_{key}"),
            "jit_options": {"flags": ["-O2"], "verbose": False}}


class NlpSolver:
    """Multi-start NLP over z for one configuration; built once, solved every cycle.

    Parameters
    ----------
    config : PlannerConfig
    solver : SolverConfig
        Plugin (``ipopt``, ``sqpmethod``), options, iteration limit, ``n_spread`` and ``seed``.
    sizes : GraphSizes, optional
        Obstacle, map and navigation block sizes (default: 16 objects of 1 circle, 48 map disks,
        8 waypoints). Objects beyond ``max_objects`` are dropped, farthest first.
    jit_directory : str, optional
        Where compiled code is cached when ``solver.jit`` is set.

    Attributes
    ----------
    build_s : float
        Seconds spent building the graph and solvers.
    """

    def __init__(self, config: PlannerConfig, solver: SolverConfig | None = None,
                 sizes: GraphSizes | None = None, jit_directory: str = ".dsmpepc_jit"):
        started = time.perf_counter()
        self.config = config
        self.solver_config = SolverConfig() if solver is None else solver
        self.sizes = GraphSizes() if sizes is None else sizes
        self.cost = build_cost_function(config, self.sizes)
        z = ca.SX.sym("z", 4)
        blocks = [ca.SX.sym(n, *parameter_shapes(self.sizes)[n]) for n in PARAMETER_NAMES]
        flat = ca.vertcat(*(ca.vec(b) for b in blocks))
        nlp = {"x": z, "p": flat, "f": self.cost(z, *blocks)[0]}
        extra = (_jit_options(config, self.sizes, jit_directory)
                 if self.solver_config.jit else {})
        plugin, options = _plugin_options(self.solver_config, warm=False)
        try:
            self._cold = ca.nlpsol("dsmpepc_cold", plugin, nlp, {**options, **extra})
            self._warm = self._cold
            if plugin == "ipopt":
                _, warm_options = _plugin_options(self.solver_config, warm=True)
                self._warm = ca.nlpsol("dsmpepc_warm", plugin, nlp, {**warm_options, **extra})
        except RuntimeError as error:
            raise ValueError(f"SolverConfig.method = {plugin!r}: CasADi could not build the "
                             f"solver for this problem ({str(error).splitlines()[-1]})") from None
        self.lower = np.array(config.z_lower, dtype=float)
        self.upper = np.array(config.z_upper, dtype=float)
        from .sampling import box_samples

        self.spread = box_samples(config, self.solver_config.n_spread, self.solver_config.seed)
        self._lam_x = None
        self.build_s = time.perf_counter() - started

    def parameters(self, state: RobotState, world, goal) -> np.ndarray:
        """The flat parameter vector of one cycle (see :func:`nlp_graph.pack_parameters`)."""
        return flatten_parameters(pack_parameters(state, world, goal, self.config, self.sizes))

    def solve(self, state: RobotState, world, goal, starts: dict) -> list:
        """Run every start and return one :class:`~dsmpepc_nlp.planner.StartRecord` each.

        Parameters
        ----------
        state : RobotState
        world : World
        goal : array_like, (2,)
            Goal position, m.
        starts : dict of str to ndarray (4,)
            Named starts (e.g. from :func:`~dsmpepc_nlp.sampling.structured_starts`); the
            ``n_spread`` box starts are added as ``spread-0``, ``spread-1``, ...

        Returns
        -------
        list of StartRecord
            In the order of ``starts`` then the spread starts. Solver trouble never raises:
            the record has ``success=False`` and a status saying why.
        """
        from .planner import StartRecord

        named = [(name, np.asarray(z, dtype=float)) for name, z in starts.items()]
        named += [(f"spread-{i}", z) for i, z in enumerate(self.spread)]
        records = []
        try:
            p = self.parameters(state, world, goal)
        except (ValueError, FloatingPointError) as error:
            return [StartRecord(name, z0, np.clip(z0, self.lower, self.upper),
                                f"parameters: {error}", False, 0, 0.0) for name, z0 in named]
        best_cost, best_lam = math.inf, None
        for name, z0 in named:
            record, lam_x = self._run(name, z0, p)
            records.append(record)
            if record.success and record.smooth_cost < best_cost:
                best_cost, best_lam = record.smooth_cost, lam_x
        self._lam_x = best_lam
        return records

    def _snap(self, z):
        """z clipped to the box, and put on a bound within 1e-4 of its range of it.

        An interior-point solution of an active bound sits about ``tol`` inside it; on
        ``v_max`` that leaves a robot in collision creeping at ~1e-5 m/s instead of stopping
        (Lemma 3), so active bounds are made exact.
        """
        z = np.clip(z, self.lower, self.upper)
        near = 1e-4 * (self.upper - self.lower)
        z = np.where(z - self.lower < near, self.lower, z)
        return np.where(self.upper - z < near, self.upper, z)

    def _run(self, name, z0, p):
        from .planner import StartRecord

        z_start = np.clip(np.where(np.isfinite(z0), z0, self.lower), self.lower, self.upper)
        warm = name == "warm" and self._lam_x is not None
        solver = self._warm if warm else self._cold
        args = {"x0": z_start, "p": p, "lbx": self.lower, "ubx": self.upper}
        if warm:
            args["lam_x0"] = self._lam_x
        started = time.perf_counter()
        try:
            result = solver(**args)
            stats = solver.stats()
        except RuntimeError as error:
            message = str(error).strip().splitlines()[-1] if str(error).strip() else "error"
            return StartRecord(name, z0, z_start, f"exception: {message}", False, 0,
                               time.perf_counter() - started), None
        elapsed = time.perf_counter() - started
        z = np.asarray(result["x"], dtype=float).reshape(-1)
        cost = float(result["f"])
        status = str(stats.get("return_status", "unknown"))
        success = bool(stats.get("success", False))
        if not (np.all(np.isfinite(z)) and math.isfinite(cost)):
            return StartRecord(name, z0, z_start, f"non-finite result ({status})", False,
                               int(stats.get("iter_count", 0)), elapsed), None
        # A start stopped by the iteration limit still hands back a usable iterate: the
        # planner judges it by its exact cost like any other.
        usable = success or status in ("Maximum_Iterations_Exceeded", "Solved_To_Acceptable_Level",
                                       "Search_Direction_Becomes_Too_Small",
                                       "Maximum_Iterations_Reached", "SOLVER_RET_LIMITED")
        return (StartRecord(name, z0, self._snap(z), status, usable,
                            int(stats.get("iter_count", 0)), elapsed, cost),
                np.asarray(result["lam_x"], dtype=float).reshape(-1))
