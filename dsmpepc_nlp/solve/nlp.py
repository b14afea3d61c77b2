"""The multi-start NLP over z: screen many starts exactly, solve from the best few.

:class:`NlpSolver` holds, per configuration, the smooth cost graph (``nlp_graph.py``) and the
solvers built once from it (CasADi ``nlpsol`` plugins, or the trust-region Newton method of
``newton.py``); :meth:`NlpSolver.solve` screens the named starts and ``n_screen`` low-discrepancy
z with the exact batched cost, runs the solver from the warm start and the best distinct others
(``n_solved``), and returns one :class:`~dsmpepc_nlp.solve.records.StartRecord` per start, each
with its exact cost: the verdict stays the exact cost. Every knob is a ``SolverConfig`` field.
Why these settings, and what they measured, is in ``docs/nlp.md``.

Longer than 400 lines while it carries the solver plumbing of both graphs (the local one with
its re-linearisation loop, and the global one); the split into problem, solvers built once and
multistart that issue 11 asks for is not finished (``docs/nlp.md``).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
import os
import time

import casadi as ca
import numpy as np

from ..core.config import PlannerConfig, RobotState, SolverConfig
from ..core.control_law import rollout
from ..core.errors import InputError
from . import compiled, nlp_global
from .newton import minimize
from .nlp_graph import (
    PARAMETER_NAMES,
    GraphSizes,
    build_cost_function,
    flatten_parameters,
    pack_parameters,
    parameter_shapes,
)
from .records import StartRecord
from .sampling import box_samples, evaluate_batch

__all__ = ["NlpSolver", "cost_function", "pack_parameters", "GraphSizes", "PARAMETER_NAMES",
           "parameter_shapes"]


def cost_function(config: PlannerConfig, sizes: GraphSizes | None = None,
                  smoothing=None) -> ca.Function:
    """The local graph the built-in solvers minimise, as a ``casadi.Function``.

    Inputs ``z`` and the blocks of :data:`PARAMETER_NAMES` (local models along a reference
    trajectory, packed by :func:`pack_parameters`); outputs ``cost`` and each term. Honest only
    near the reference: to embed the cost in your own problem use
    :func:`dsmpepc_nlp.solve.nlp_global.cost_function`, which reads the map itself.
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
                   # A monotone merit line search: the default non-monotone one (memory 4,
                   # 3 trials) took steps that raised the cost and wandered to v_max = 0.
                   "merit_memory": 1, "max_iter_ls": 8,
                   "error_on_fail": False,
                   "qpsol_options": {"print_iter": False, "print_header": False,
                                     "print_info": False, "error_on_fail": False}}
    elif solver.method == "fatrop":
        options = {"print_time": False, "structure_detection": "none",
                   "fatrop.print_level": 0, "fatrop.max_iter": solver.max_iter}
    else:
        raise InputError(f"SolverConfig.method = {solver.method!r}: NlpSolver needs an NLP "
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


def _newton_functions(z, flat, objective, extra, span, solver: SolverConfig) -> tuple:
    """``(f, fgh)`` for :func:`~dsmpepc_nlp.solve.newton.minimize`: the objective alone, and
    objective, gradient and Hessian (``solver.newton_hessian``: ``exact`` SX, or
    ``differences`` of the gradient at 5 points in one mapped call)."""
    f = ca.Function("dsmpepc_f", [z, flat], [objective], extra)
    if solver.newton_hessian == "exact":
        hessian, gradient = ca.hessian(objective, z)
        return f, ca.Function("dsmpepc_fgh", [z, flat], [objective, gradient, hessian],
                              extra)
    gradient = ca.Function("dsmpepc_fg", [z, flat], [objective, ca.gradient(objective, z)],
                           extra)
    mapped = gradient.map(5)
    step = solver.fd_step * span
    points = np.column_stack([np.zeros(4), np.diag(step)])

    def fgh(zk, p):
        values, grads = mapped(ca.repmat(ca.DM(zk), 1, 5) + points, p)
        grads = np.asarray(grads, dtype=float)
        hessian = (grads[:, 1:] - grads[:, :1]) / step
        return values[0], grads[:, 0], 0.5 * (hessian + hessian.T)
    return f, fgh


@functools.lru_cache(maxsize=16)
def _build(config: PlannerConfig, solver: SolverConfig, sizes: GraphSizes, jit_directory: str):
    """``(cost, cold, warm, newton)``: the graph and its solvers, built once per configuration
    and shared by every :class:`NlpSolver` of that configuration (one Planner per robot);
    the warm-start state stays in each NlpSolver. Not for concurrent use from several threads.
    """
    cost = build_cost_function(config, sizes)
    shapes = parameter_shapes(config, sizes)
    z = ca.SX.sym("z", 4)
    blocks = [ca.SX.sym(n, *shapes[n]) for n in PARAMETER_NAMES]
    flat = ca.vertcat(*(ca.vec(b) for b in blocks))
    nlp = {"x": z, "p": flat, "f": cost(z, *blocks)[0]}
    extra = _jit_options(config, sizes, jit_directory) if solver.jit else {}
    cold = warm = newton = None
    plugin = solver.method
    try:
        if plugin == "newton":
            span = np.array(config.z_upper, dtype=float) - np.array(config.z_lower, dtype=float)
            newton = _newton_functions(z, flat, nlp["f"], extra, span, solver)
        else:
            _, options = _plugin_options(solver, warm=False)
            cold = warm = ca.nlpsol("dsmpepc_cold", plugin, nlp, {**options, **extra})
        if plugin == "ipopt":
            _, warm_options = _plugin_options(solver, warm=True)
            warm = ca.nlpsol("dsmpepc_warm", plugin, nlp, {**warm_options, **extra})
    except RuntimeError as error:
        raise InputError(f"SolverConfig.method = {plugin!r}: CasADi could not build the "
                         f"solver for this problem ({str(error).splitlines()[-1]})") from None
    return cost, cold, warm, newton


class NlpSolver:
    """Multi-start NLP over z for one configuration; built once, solved every cycle.

    Every start (the named ones and ``n_spread`` spread over the box) is first costed exactly
    (batched numpy); the NLP then runs from the warm start and the best others only
    (``n_solved`` in all). Each solve uses local models of the map and the navigation function
    along the start's exact rollout; when the solution's poses leave the models' trust radius
    they are re-taken along the solution and the solve repeated (at most ``max_outer`` times).

    Parameters
    ----------
    config : PlannerConfig
    solver : SolverConfig
        Plugin (``ipopt``, ``sqpmethod``, ``fatrop``) or ``newton`` (no plugin: the
        trust-region method of :mod:`~dsmpepc_nlp.solve.newton`, whose ``tol`` is the predicted
        decrease counted as converged; 1e-3 suits the 0.01 cost tolerance), options,
        iteration limit, ``n_spread`` and ``seed``.
    sizes : GraphSizes, optional
        Obstacle block sizes (default: 12 objects for the terminal TTC, 3 per pose).
    jit_directory : str, optional
        Where compiled code is cached when ``solver.jit`` is set.

    Attributes
    ----------
    build_s : float
        Seconds spent building the graph and solvers.
    last_stats : list of dict
        Per NLP solve of the last cycle: name, outer iteration, iterations, wall times of the
        solver's function evaluations and the packing time (for profiling).
    """

    def __init__(self, config: PlannerConfig, solver: SolverConfig | None = None,
                 sizes: GraphSizes | None = None, jit_directory: str = ".dsmpepc_jit"):
        started = time.perf_counter()
        self.config = config
        self.solver_config = SolverConfig() if solver is None else solver
        self.sizes = GraphSizes() if sizes is None else sizes
        n_solved = self.solver_config.n_solved
        if n_solved == 0:
            n_solved = 3 if self.solver_config.method == "ipopt" else 2
        self.n_solved = n_solved
        self.lower = np.array(config.z_lower, dtype=float)
        self.upper = np.array(config.z_upper, dtype=float)
        self.cost, self._cold, self._warm, self._newton = _build(
            config, self.solver_config, self.sizes, jit_directory)
        self.spread = box_samples(config, self.solver_config.n_spread, self.solver_config.seed)
        self.screen = box_samples(config, self.solver_config.n_screen,
                                  self.solver_config.seed + 1)
        self._global = None
        if self.solver_config.graph == "global" and self.solver_config.method == "newton":
            self.global_sizes = nlp_global.GraphSizes()
            cost = nlp_global.flat_cost(config, self.global_sizes)
            step = self.solver_config.fd_step * (self.upper - self.lower)
            self._global = compiled.build(cost, cost.size1_in(1), step,
                                          (config, self.global_sizes, "global"))
        self._lam_x = None
        self.last_stats = []
        self.build_s = time.perf_counter() - started

    def parameters(self, state: RobotState, world, goal, reference=None) -> np.ndarray:
        """The flat parameter vector of one cycle (see :func:`nlp_graph.pack_parameters`)."""
        return flatten_parameters(pack_parameters(state, world, goal, self.config, self.sizes,
                                                  reference))

    def _choose(self, named, costs) -> list:
        """Indices to solve from: ``warm`` first, then the best distinct others by exact cost."""
        span = self.upper - self.lower
        order = [i for i, (name, _) in enumerate(named) if name == "warm"]
        for i in np.argsort(np.where(np.isfinite(costs), costs, np.inf), kind="stable"):
            if len(order) >= self.n_solved:
                break
            if i in order or not np.isfinite(costs[i]):
                continue
            if all(np.max(np.abs(named[i][1] - named[j][1]) / span) > self.solver_config.distinct
                   for j in order):
                order.append(int(i))
        return order

    def solve(self, cycle, starts: dict) -> list:
        """Screen every start exactly, run the NLP from the best few; one record per start.

        Parameters
        ----------
        cycle : Cycle
            The state, world, goal and configuration of this plan, prepared once.
        starts : dict of str to ndarray (4,)
            Named starts (e.g. from :func:`~dsmpepc_nlp.solve.sampling.structured_starts`); the
            ``n_spread`` box starts are added as ``spread-0``, ``spread-1``, ...

        Returns
        -------
        list of StartRecord
            In the order of ``starts``, the spread starts, then the screening samples, each
            with its ``exact_cost`` (from :func:`~dsmpepc_nlp.solve.sampling.evaluate_batch`).
            Starts the NLP did not run from have status ``screened``, ``nit`` 0 and
            ``z = z0`` (a candidate like any other: the plan is never worse than the best
            start). Solver trouble never raises: the
            record has ``success=False`` and a status saying why.
        """
        named = [(name, np.clip(np.where(np.isfinite(z), z, self.lower), self.lower,
                                self.upper))
                 for name, z in ((n, np.asarray(z, dtype=float)) for n, z in starts.items())]
        named += [(f"spread-{i}", z) for i, z in enumerate(self.spread)]
        named += [(f"screen-{i}", z) for i, z in enumerate(self.screen)]
        self.last_stats = []
        screened = evaluate_batch(np.array([z for _, z in named]), cycle)
        costs = screened.costs.total
        records = [StartRecord(name, z0, z0, "screened", False, 0, 0.0, math.nan,
                               float(costs[i])) for i, (name, z0) in enumerate(named)]
        best_cost, best_lam = math.inf, None
        if self._global is not None:
            self._global.bind(nlp_global.flatten_parameters(
                nlp_global.pack_parameters(cycle, self.global_sizes)))
        for i in self._choose(named, costs):
            name, z0 = named[i]
            if self._global is not None:
                records[i], lam_x = self._run_global(name, z0), None
                continue
            record, lam_x = self._run_outer(name, z0, screened.trajectories[i].poses, cycle,
                                            float(costs[i]))
            records[i] = record
            if record.success and record.smooth_cost < best_cost:
                best_cost, best_lam = record.smooth_cost, lam_x
        if best_lam is not None:
            self._lam_x = best_lam
        solved = [i for i, r in enumerate(records) if r.status != "screened"
                  and np.all(np.isfinite(r.z))]
        if solved:
            exact = evaluate_batch(np.array([records[i].z for i in solved]), cycle).costs.total
            for i, cost in zip(solved, exact):
                records[i] = dataclasses.replace(records[i], exact_cost=float(cost))
        return records

    def _run_global(self, name, z0) -> StartRecord:
        """One trust-region Newton solve on the global graph (parameters already bound)."""
        started = time.perf_counter()
        fn = self._global

        def f(z):
            return float(fn.call("F", z)[0].item())

        def f_g_h(z):
            value, gradient, hessian = fn.call("H", z)
            return value.item(), gradient.reshape(-1).copy(), hessian.copy()

        result = minimize(f, f_g_h, z0, self.lower, self.upper,
                          radius=self.solver_config.trust_radius,
                          max_iter=self.solver_config.max_iter, tol=self.solver_config.tol)
        elapsed = time.perf_counter() - started
        self.last_stats.append({"name": name, "outer": 0, "t_wall_total": elapsed,
                                "iter_count": result.nit, "nfev": result.nfev,
                                "nhev": result.nhev})
        if not (np.all(np.isfinite(result.x)) and math.isfinite(result.fun)):
            return StartRecord(name, z0, z0, f"non-finite result ({result.status})", False,
                               result.nit, elapsed)
        return StartRecord(name, z0, self._snap(result.x), result.status,
                           result.status != "non-finite", result.nit, elapsed, result.fun)

    def _run_outer(self, name, z0, poses, cycle, z0_cost=math.inf):
        """Solve from ``z0`` with models along ``poses``; re-take them while the solution
        leaves their trust radius.

        A solve that ran far past its models' trust radius can end where the models are wrong
        (seen on ``hall``: smooth cost -4.8, exact +1.9); each outer result is costed exactly
        and the record keeps the best of them and of ``z0`` (``z0_cost``), so a solve never
        loses the start it was run from.
        """
        started = time.perf_counter()
        z_start, lam_x = z0, (self._lam_x if name == "warm" else None)
        nit, record = 0, None
        best = (z0_cost, z0, math.nan, None)     # exact cost, z, smooth cost, lam_x
        for outer in range(self.solver_config.max_outer):
            packed = time.perf_counter()
            try:
                p = self.parameters(cycle.state, cycle.world, cycle.goal, poses)
            except (ValueError, FloatingPointError) as error:
                return StartRecord(name, z0, z0, f"parameters: {error}", False, nit,
                                   time.perf_counter() - started), None
            pack_s = time.perf_counter() - packed
            result = self._run(z_start, p, lam_x)
            self.last_stats.append({"name": name, "outer": outer, "pack_s": pack_s,
                                    **result["stats"]})
            nit += result["nit"]
            if result["z"] is None:
                record = StartRecord(name, z0, z_start, result["status"], False, nit,
                                     time.perf_counter() - started)
                return record, None
            z, lam_x = result["z"], result["lam_x"]
            record = StartRecord(name, z0, z, result["status"], result["usable"], nit,
                                 time.perf_counter() - started, result["cost"])
            exact = float(evaluate_batch(z[None], cycle).costs.total[0])
            if math.isfinite(exact) and not exact > best[0]:
                best = (exact, z, result["cost"], lam_x)
            moved = rollout(z, cycle.state, self.config).poses
            shift = np.max(np.linalg.norm(moved[:, :2] - poses[:, :2], axis=1))
            if shift <= self.solver_config.relinearise_radius:
                break
            z_start, poses = z, moved
        if record is not None and record.success and best[1] is not record.z:
            record = dataclasses.replace(record, z=best[1], smooth_cost=best[2])
            lam_x = best[3]
        return record, lam_x

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

    def _run(self, z_start, p, lam_x) -> dict:
        if self._newton is not None:
            return self._run_newton(z_start, p)
        warm = lam_x is not None
        solver = self._warm if warm else self._cold
        args = {"x0": z_start, "p": p, "lbx": self.lower, "ubx": self.upper}
        if warm:
            args["lam_x0"] = lam_x
        try:
            result = solver(**args)
            stats = solver.stats()
        except RuntimeError as error:
            message = str(error).strip().splitlines()[-1] if str(error).strip() else "error"
            return {"z": None, "status": f"exception: {message}", "nit": 0, "stats": {}}
        z = np.asarray(result["x"], dtype=float).reshape(-1)
        cost = float(result["f"])
        status = str(stats.get("return_status", "unknown"))
        nit = int(stats.get("iter_count", 0))
        timing = {key: stats[key] for key in ("t_wall_total", "t_wall_nlp_f", "t_wall_nlp_grad_f",
                                              "t_wall_nlp_hess_l") if key in stats}
        timing["iter_count"] = nit
        if not (np.all(np.isfinite(z)) and math.isfinite(cost)):
            return {"z": None, "status": f"non-finite result ({status})", "nit": nit,
                    "stats": timing}
        # A start stopped by the iteration limit still hands back a usable iterate: the
        # planner judges it by its exact cost like any other.
        usable = bool(stats.get("success", False)) or status in (
            "Maximum_Iterations_Exceeded", "Solved_To_Acceptable_Level",
            "Search_Direction_Becomes_Too_Small", "Maximum_Iterations_Reached",
            "SOLVER_RET_LIMITED")
        return {"z": self._snap(z), "status": status, "usable": usable, "nit": nit,
                "cost": cost, "lam_x": np.asarray(result["lam_x"], dtype=float).reshape(-1),
                "stats": timing}

    def _run_newton(self, z_start, p) -> dict:
        """One trust-region Newton solve (:func:`~dsmpepc_nlp.solve.newton.minimize`)."""
        f_only, fgh = self._newton
        p = ca.DM(p)
        timing = {"t_f": 0.0, "t_fgh": 0.0}

        def f(z):
            started = time.perf_counter()
            value = float(f_only(z, p))
            timing["t_f"] += time.perf_counter() - started
            return value

        def f_g_h(z):
            started = time.perf_counter()
            value, gradient, hessian = fgh(z, p)
            timing["t_fgh"] += time.perf_counter() - started
            return (float(value), np.asarray(gradient, dtype=float).reshape(-1),
                    np.asarray(hessian, dtype=float))

        started = time.perf_counter()
        result = minimize(f, f_g_h, z_start, self.lower, self.upper,
                          radius=self.solver_config.trust_radius,
                          max_iter=self.solver_config.max_iter, tol=self.solver_config.tol)
        timing.update({"t_wall_total": time.perf_counter() - started, "iter_count": result.nit,
                       "nfev": result.nfev, "nhev": result.nhev})
        if not (np.all(np.isfinite(result.x)) and math.isfinite(result.fun)):
            return {"z": None, "status": f"non-finite result ({result.status})",
                    "nit": result.nit, "stats": timing}
        return {"z": self._snap(result.x), "status": result.status,
                "usable": result.status != "non-finite", "nit": result.nit,
                "cost": result.fun, "lam_x": None, "stats": timing}
