"""The multi-start NLP over z: screen many starts exactly, solve from the best few, choose exactly.

:class:`NlpSolver` is the multistart of the split (``graph`` the problem's graph, ``solvers``
the problem compiled and its solvers built once per configuration, :mod:`.polish` the
exact-cost polish, this module the starts, the screening and the choice). Per cycle it costs
the named starts and ``n_screen`` low-discrepancy z with the compiled exact evaluator, binds the
cycle's parameters to the compiled global graph once, runs the solver (IPOPT or the
trust-region Newton method) from the warm start and the best distinct others (``n_solved``),
polishes the best candidates on the exact cost, and hands back one
:class:`~dsmpepc_nlp.solve.plan.StartRecord` per start with its exact cost: the verdict is
the exact cost. Every knob is a ``SolverConfig`` field; why these settings: ``docs/design.md``.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ...core.config import PlannerConfig
from ...core.deadline import Deadline, budget_seconds
from ...core.solver_config import SolverConfig
from .. import problem as graph
from ..build import library as problems
from ..build.library import NOT_RUN, readiness
from ..exact import loader as exact
from ..exact.evaluator import Evaluator
from ..plan import StartRecord
from ..problem import GraphSizes
from . import solvers
from .polish import Polish
from .starts import box_samples
from .threads import StartExecutor


class Overlap(StartExecutor):
    """The multistart's executor (:class:`.threads.StartExecutor`): the solver runs the starts
    it is given, and meanwhile ``further(busy)`` (the screen of the other starts, on one core
    while the warm start solves) lists the starts that follow, and ``ahead(done, busy)`` (the
    polish ahead, :meth:`.polish.Polish.ahead`) uses a thread left without a start."""

    def __init__(self, threads: int, further=None, ahead=None):
        super().__init__(threads)
        self._further = further
        self.open_ended = further is not None
        self.idle_work = ahead

    def further(self, busy: bool) -> list:
        return self._further(busy)


__all__ = ["CUT_STATUSES", "NlpSolver", "Overlap", "SOLVES"]

SOLVES = "the NLP's solves"
"""The stage a deadline cut when a solve stopped at its wall limit or was not run."""

CUT_STATUSES = (NOT_RUN, "Maximum_WallTime_Exceeded")
"""Solver statuses that mean the plan's deadline cut the solve."""


class NlpSolver:
    """Multi-start NLP over z for one configuration; built once, solved every cycle.

    Every start (the named ones, ``n_spread`` spread over the box and ``n_screen`` screening
    samples) is first costed exactly (compiled, batched); the solver then runs from the warm
    start and the best distinct others (``n_solved`` in all) on the compiled global graph,
    whose parameters are bound once per cycle. The graph's per-pose object block is the
    smallest of ``SolverConfig.pose_object_buckets`` that holds the objects in reach.

    Parameters
    ----------
    config : PlannerConfig
    solver : SolverConfig
        ``ipopt`` or ``newton`` (``SolverConfig.fast()``: the trust-region method of
        :mod:`.newton`, whose ``tol`` is the predicted decrease counted as
        converged), options, iteration limit, starts and seed.
    sizes : graph.GraphSizes, optional
        Terminal objects, table window and ray samples (``pose_objects`` is chosen per cycle).

    Attributes
    ----------
    build_s : float
        Seconds spent building (or loading) the compiled graphs so far.
    last_stats : list of dict
        Per solve of the last cycle: name, iterations (``iter_count``), cost and derivative
        evaluations (``nfev``, ``ngev``), wall time, packing time, object bucket.
    last_screen : dict
        The last cycle's screen: ``rows`` costed, and ``one_thread`` (True when it ran on one
        core beside the warm start's solve).
    polish : Polish
        The exact-cost polish (:mod:`.polish`); ``polish.last`` says where its rounds ran.
    kernel_loading : bool
        The last cycle was solved while the compiled exact kernel loaded (a fresh process's
        first plan): the screen costed the named and spread starts only, and no polish ran.
    """

    def __init__(self, config: PlannerConfig, solver: SolverConfig | None = None,
                 sizes: GraphSizes | None = None):
        started = time.perf_counter()
        self.config = config
        self.solver_config = SolverConfig() if solver is None else solver
        self.sizes = GraphSizes() if sizes is None else sizes
        self.n_solved = self.solver_config.multistart.n_solved
        self.lower = np.array(config.z_lower, dtype=float)
        self.upper = np.array(config.z_upper, dtype=float)
        self.span = self.upper - self.lower
        self.polish = Polish(self.solver_config, self.lower, self.upper)
        self._solver = solvers.make_solver(self.solver_config)
        starts = self.solver_config.multistart
        self.spread = box_samples(config, starts.n_spread, self.solver_config.seed)
        self.use_screen(box_samples(config, starts.n_screen, self.solver_config.seed + 1))
        self._lam_x = None
        self._seen = set()
        self._ready = set()
        self.last_stats = []
        self.last_screen = {}
        self.kernel_loading = False
        self.solver_s = 0.0
        """Seconds spent inside the solver's runs (``solve_many``: the solves of a plan, and
        what its executor overlaps with them), summed over every plan of this object."""
        self.build_s = time.perf_counter() - started

    def sizes_for(self, cycle) -> GraphSizes:
        """The graph sizes of ``cycle``: the least bucket holding its objects, else the largest."""
        in_reach = graph.objects_in_reach(cycle)
        buckets = self.solver_config.pose_object_buckets
        bucket = next((b for b in buckets if b >= in_reach), buckets[-1])
        return dataclasses.replace(self.sizes, pose_objects=bucket)

    def readiness(self, cycle) -> tuple:
        """``(ready, note)`` of ``cycle``'s problem (:func:`.problem.readiness`); a bucket
        found ready stays ready, so a plan asks the cache only until then."""
        sizes = self.sizes_for(cycle)
        if sizes in self._ready:
            return True, ""
        ready, note = readiness(self.config, sizes, self.solver_config)
        if ready:
            self._ready.add(sizes)
        return ready, note

    def prepare(self, max_objects: int | None = None) -> float:
        """Build (compile, or load) the problem of every object bucket a cycle may use now
        (with ``max_objects``, the most dynamic objects a cycle can hold, only the buckets up
        to the first that holds them); seconds spent."""
        started = time.perf_counter()
        buckets = list(self.solver_config.pose_object_buckets)
        if max_objects is not None:
            first = next((i for i, b in enumerate(buckets) if b >= max_objects), len(buckets))
            buckets = buckets[:first + 1]
        every = [dataclasses.replace(self.sizes, pose_objects=bucket) for bucket in buckets]
        solvers.compile_missing([(self.config, sizes) for sizes in every], self.solver_config)
        for sizes in every:
            self._seen.add(problems.problem(self.config, sizes, self.solver_config))
        return time.perf_counter() - started

    def warm_up(self) -> None:
        """Load (or compile) now what a solve runs beyond the problem's library, so that no
        plan does: the fast method's Newton loop (numba); IPOPT's ``nlpsol`` of every thread,
        start kind and wall limit the default time budget may give a solve."""
        if self.solver_config.method == "newton" and self._seen:
            solvers.warm_newton_loop(next(iter(self._seen)))
        if self.solver_config.method == "ipopt":
            left = budget_seconds(self.solver_config.time_budget, self.config.horizon.dt)
            for problem in self._seen:
                self._solver.prebuild(problem, self.solver_config.parallel.solve_threads,
                                      left=left)

    def problem(self, cycle) -> problems.Problem:
        """The compiled problem for ``cycle`` (built or loaded on first use)."""
        started = time.perf_counter()
        problem = problems.problem(self.config, self.sizes_for(cycle), self.solver_config)
        if problem not in self._seen:
            self._seen.add(problem)
            self.build_s += time.perf_counter() - started
        return problem

    def use_screen(self, screen) -> None:
        """Screen ``screen`` (n, 4) from now on instead of the configured Sobol points (tools
        that try other screens call it). The box starts are the same every cycle: named and
        stacked here, once."""
        self.screen = np.asarray(screen, dtype=float).reshape(-1, 4)
        self._box_starts = ([(f"spread-{i}", z) for i, z in enumerate(self.spread)]
                            + [(f"screen-{i}", z) for i, z in enumerate(self.screen)])
        self._box_z = np.vstack([self.spread, self.screen]).reshape(-1, 4)

    def _choose(self, named, costs) -> list:
        """Indices to solve from: ``warm`` first, then the best distinct others by exact cost."""
        order = [i for i, (name, _) in enumerate(named) if name == "warm"]
        for i in np.argsort(np.where(np.isfinite(costs), costs, np.inf), kind="stable"):
            if len(order) >= self.n_solved:
                break
            if i in order or not np.isfinite(costs[i]):
                continue
            if all(self.polish.distinct(named[i][1], named[j][1]) for j in order):
                order.append(int(i))
        return order

    def solve(self, evaluator: Evaluator, starts: dict, deadline: Deadline | None = None) -> list:
        """Screen every start exactly, run the NLP from the best few; one record per start.

        Parameters
        ----------
        evaluator : Evaluator
            The exact cost of this plan's cycle (:class:`~dsmpepc_nlp.solve.exact.evaluator.
            Evaluator`, built once per plan; its ``cycle``: the state, world, goal and
            configuration). Every exact cost of the screen, the verdicts and the polish is
            costed through it.
        starts : dict of str to ndarray (4,)
            Named starts (e.g. from :func:`.starts.structured_starts`); the
            ``n_spread`` box starts are added as ``spread-0``, ``spread-1``, ...
        deadline : Deadline, optional
            The plan's deadline: no solve starts after it, IPOPT stops at it, the polish ends
            its walks there; the cut stages are recorded in it (``SOLVES``, ``POLISH``).

        Returns
        -------
        list of StartRecord
            In the order of ``starts``, the spread starts, then the screening samples, each
            with its ``exact_cost`` (``evaluator.totals``).
            Starts the NLP did not run from have status ``screened``, ``nit`` 0 and
            ``z = z0`` (a candidate like any other: the plan is never worse than the best
            start). Solver trouble never raises: the record has ``success=False`` and a
            status saying why. A last record ``polish`` is added when the exact-cost polish
            found a better z than every start.
        """
        named = [(name, np.clip(np.where(np.isfinite(z), z, self.lower), self.lower,
                                self.upper))
                 for name, z in ((n, np.asarray(z, dtype=float)) for n, z in starts.items())]
        z_named = np.array([z for _, z in named]).reshape(-1, 4)
        # While the compiled kernel loads (a fresh process's first plan), the numpy path costs
        # the named and spread starts, not the screen's Sobol points, and nothing is polished.
        self.kernel_loading = exact.standing_in()
        box = len(self.spread) if self.kernel_loading else len(self._box_z)
        named += self._box_starts[:box]
        box_z = self._box_z[:box]
        self.last_stats = []
        self.polish.reset(deadline)
        problem, pack_s = self._bound(evaluator.cycle, deadline)
        records, chosen, screened = [], [], []

        def screen(one_thread=False):
            """Cost every start exactly; the starts to solve from."""
            z = np.vstack([z_named, box_z])
            self.last_screen = {"rows": len(z), "one_thread": one_thread}
            screened.append(evaluator.totals(z, one_thread))
            chosen.extend(self._choose(named, screened[0]))

        def listed():
            """``records``, one per start, made on first use (the solves need not wait)."""
            if not records:
                records.extend(StartRecord(name, z0, z0, "screened", False, 0, 0.0, math.nan,
                                           float(cost))
                               for (name, z0), cost in zip(named, screened[0]))
            return records

        # The warm start is solved whatever the screen finds (it is always first), so with
        # ``screen_ahead`` it starts at once and a second thread screens meanwhile, then
        # takes the best distinct others: every solve and record is the same, earlier.
        first = [i for i, (name, _) in enumerate(named) if name == "warm"]
        parallel = self.solver_config.parallel
        further = None
        if first and parallel.screen_ahead and parallel.solve_threads > 1:
            def further(busy):     # on one core while the warm start solves on the other
                screen(one_thread=busy)
                return [self._start(*named[i]) for i in chosen[1:]]
        else:
            screen()
            first = chosen
        walks = {}
        ahead = None
        if parallel.polish_ahead and not self.kernel_loading:
            def ahead(done, busy):       # once the screen is done (threads.run_starts)
                guesses = list(listed())
                for index, result in done.items():
                    guesses[chosen[index]] = self._solved_record(named[chosen[index]], result)
                self._verdicts(guesses, evaluator, one_thread=True)
                self.polish.ahead(guesses, evaluator, walks, busy)
        began = time.perf_counter()
        executor = Overlap(parallel.solve_threads, further, ahead)
        executor.deadline = deadline
        results = self._solver.solve_many(problem, [self._start(*named[i]) for i in first],
                                          executor)
        self.solver_s += time.perf_counter() - began
        if deadline is not None and any(r.status in CUT_STATUSES for r in results):
            deadline.spent(SOLVES)
        self._solved(listed(), [(i, named[i], r) for i, r in zip(chosen, results)], pack_s,
                     problem)
        self._verdicts(records, evaluator)
        polished = None if self.kernel_loading else self.polish.run(records, evaluator, walks)
        return records + ([polished] if polished is not None else [])

    def _bound(self, cycle, deadline) -> tuple:
        """``(problem, seconds packing)``: ``cycle``'s compiled problem, its parameters bound
        (time spent loading or compiling it is ``prepare()``'s work: not counted against the
        ``deadline``)."""
        built = self.build_s
        problem = self.problem(cycle)
        if deadline is not None:
            deadline.extend(self.build_s - built)
        packed = time.perf_counter()
        problem.bind(problem.pack(cycle))
        return problem, time.perf_counter() - packed

    def _solved(self, records, solves, pack_s: float, problem) -> None:
        """Each solve ``(index, (name, z0), result)`` into its record, in place, with its
        stats; the cheapest successful solve's multipliers warm the next plan."""
        best_cost, best_lam = math.inf, None
        for i, start, result in solves:
            self.last_stats.append({"name": start[0], "iter_count": result.nit,
                                    "nfev": result.nfev, "ngev": result.ngev,
                                    "t_wall_total": result.time_s, "pack_s": pack_s,
                                    "pose_objects": problem.sizes.k_pose})
            records[i] = self._solved_record(start, result)
            if result.success and result.lam_x is not None and result.fun < best_cost:
                best_cost, best_lam = result.fun, result.lam_x
        if best_lam is not None:
            self._lam_x = best_lam

    @staticmethod
    def _solved_record(start, result) -> StartRecord:
        """The record of a solve from ``start`` (name, z0), its exact cost not yet known."""
        name, z0 = start
        return StartRecord(name, z0, result.x, result.status, result.success, result.nit,
                           result.time_s, result.fun)


    def _verdicts(self, records, evaluator, one_thread=False) -> None:
        """Cost the solved records exactly, in place (one exact batch; every row is costed
        as it would be alone, so the polish ahead and the final verdict agree to the bit)."""
        solved = [i for i, r in enumerate(records) if r.status != "screened"
                  and math.isnan(r.exact_cost) and np.all(np.isfinite(r.z))]
        if solved:
            exact = evaluator.totals(np.array([records[i].z for i in solved]), one_thread)
            for i, cost in zip(solved, exact):
                records[i] = dataclasses.replace(records[i], exact_cost=float(cost))


    def _start(self, name, z0) -> tuple:
        """The solver's start ``(z0, lam_x)`` for a named start: the warm start reuses the last
        plan's multipliers."""
        return z0, self._lam_x if name == "warm" else None
