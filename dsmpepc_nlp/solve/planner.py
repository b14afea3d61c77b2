"""``plan(state, world, goal) -> Plan``, whichever solver runs underneath, with its fallbacks."""

from __future__ import annotations

import dataclasses
import math
import os
import time
import warnings

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.deadline import BUDGET_ALLOWED, Deadline, budget_seconds, is_budget
from ..core.errors import InputError
from ..core.solver_config import SolverConfig
from ..core.world import World
from ..perception.standing import StandingPeople
from . import start_state
from .behaviours import chain, docking
from .behaviours.stall import StallMonitor
from .exact import loader as exact
from .exact.cycle import Cycle
from .exact.evaluator import Evaluation, Evaluator
from .optimize.multistart import SOLVES, NlpSolver
from .optimize.sampling import STAGE as SAMPLER
from .optimize.sampling import SamplingPlanner
from .optimize.starts import structured_starts
from .plan import Plan
from .start_state import as_goal, as_state, as_tolerance, law_control, start_overlap

CONFIGURED = object()
"""``Planner.plan``'s ``time_budget`` when not given: ``SolverConfig.time_budget``."""

TOOK_DECAY = 0.95
"""How much of a stage's slowest recent run is still expected of it a plan later (:meth:`Planner.
_timed`): a stage that took 50 ms is expected to take 25 ms fourteen quick runs later."""

FALLBACK_STATUSES = ("sampling-fallback", "stopped")
"""Statuses of a plan the chosen solver did not deliver."""

FALLBACK_WARNING = 3
"""Plans in a row that fall back before the planner warns (once, until :meth:`Planner.reset`)."""

QUICK_SAMPLES = 512
"""Samples of the stand-in sampler while a library compiles and the exact kernel is not loaded
(the numpy path: ~0.1 s a plan)."""

COMPILE_MODES = ("background", "wait")
"""What :meth:`Planner.plan` does when the NLP's library for a cycle is not compiled yet:
``background`` (default) compiles it in a child process and plans with the sampler meanwhile
(status ``sampling-compiling``); ``wait`` compiles it in the plan (seconds to a minute).
``$DSMPEPC_COMPILE`` sets the default; :meth:`Planner.prepare` compiles everything ahead."""


class Planner:
    """Plans one cycle at a time and keeps the last target for MPEPC's warm start.

    Parameters
    ----------
    config : PlannerConfig
        The method (MPEPC, DS-MPEPC or an ablation) and its parameters.
    solver : SolverConfig
        IPOPT by default; ``SolverConfig.fast()`` or ``SolverConfig.sampling()``.

    compile : str, optional
        One of :data:`COMPILE_MODES` (default: ``$DSMPEPC_COMPILE``, else ``background``).
    strict : bool, optional
        Re-raise an exception of any stage of :meth:`plan` instead of falling back to the
        next (default: ``$DSMPEPC_STRICT`` set to ``1``; the test suite runs strict, so that a
        bug is not hidden by a fallback plan). A robot's loop wants the default, False.

    The NLP solver is built here, once; the compiled problem of each object bucket is loaded
    on first use (or by :meth:`prepare`), and :meth:`plan` only sets parameters. A plan never
    waits for a compiler unless ``compile="wait"``.

    Attributes
    ----------
    last_evaluator : Evaluator or None
        The last plan's exact evaluator (:class:`~dsmpepc_nlp.solve.exact.evaluator.Evaluator`, one
        per plan, the one door every stage costed through): what it costed and how often.
    """

    def __init__(self, config: PlannerConfig | None = None, solver: SolverConfig | None = None,
                 *, compile: str | None = None, strict: bool | None = None):
        self.config = PlannerConfig() if config is None else config
        self.solver = SolverConfig() if solver is None else solver
        mode = os.environ.get("DSMPEPC_COMPILE", "background") if compile is None else compile
        if mode not in COMPILE_MODES:
            raise InputError(f"compile = {mode!r} (or $DSMPEPC_COMPILE): must be one of "
                             f"{', '.join(COMPILE_MODES)}")
        self.compile = mode
        self.strict = os.environ.get("DSMPEPC_STRICT", "") == "1" if strict is None else strict
        self._quick = None
        if mode == "background":
            exact.defer()      # the first plan on the numpy path; numba loads after it
        self.sampler = SamplingPlanner(self.config, self.solver)
        self.nlp = None
        if self.solver.method != "sampling":
            self.nlp = NlpSolver(self.config, self.solver)
        self._previous_target = None
        self._fallbacks, self._warned = 0, False
        self.instead, self.on_plan = chain.configured(self.config)
        self.stall = StallMonitor(self.config)
        self.standing = StandingPeople(self.config)
        self.last_evaluator = None
        self._took = {}

    def prepare(self, max_objects: int | None = None) -> dict:
        """Compile (or load) everything a plan may need, now: the NLP's problem of every object
        bucket (up to the one that holds ``max_objects`` dynamic objects, when the caller knows
        there are never more) and the compiled exact evaluator. Call it before a control loop
        (simulations and benchmarks do) so that no plan runs on a fallback while a library
        compiles; missing libraries compile in parallel child processes.

        Returns ``{"nlp_s": seconds, "exact_s": seconds}``.
        """
        started = time.perf_counter()
        exact.preload()        # numba compiles (or loads) the kernel while the C compiles run
        nlp_s = self.nlp.prepare(max_objects) if self.nlp is not None else 0.0
        exact.warm_up()        # the kernel's code loaded (or compiled) now, not in a plan
        if self.nlp is not None:
            self.nlp.warm_up()
        return {"nlp_s": nlp_s, "exact_s": time.perf_counter() - started - nlp_s}

    def _quick_sampler(self) -> SamplingPlanner:
        """The sampler while a library compiles: the configured one when the compiled exact
        kernel is loaded, else one of :data:`QUICK_SAMPLES` samples (the numpy path costs
        4,096 in ~1 s, past the control period)."""
        if exact.kernel() is not None:
            return self.sampler
        if self._quick is None:
            self._quick = SamplingPlanner(self.config, dataclasses.replace(
                self.solver, n_samples=min(QUICK_SAMPLES, self.solver.n_samples)))
        return self._quick

    def reset(self) -> None:
        """Forget the warm start, the fallback count and the stall monitor (a new episode)."""
        self._previous_target = None
        self._fallbacks, self._warned = 0, False
        self.stall.reset()
        self.standing.reset()

    def plan(self, state: RobotState, world: World, goal, *, dock: bool = True,
             sample: bool = False, goal_tolerance: float = 0.0,
             time_budget=CONFIGURED) -> Plan:
        """Plan from ``state`` toward ``goal`` in ``world``.

        Parameters
        ----------
        state : RobotState or array_like
            A :class:`RobotState`, or ``(x, y, phi[, v, omega])`` in m, rad, m/s, rad/s.
        world : World
            Static map and the dynamic obstacles now.
        goal : array_like, (2,)
            Goal position, m.
        dock : bool
            Dock at the goal within the docking radius (:func:`.docking.docking_radius`). The
            simulator docks at a moving (followed) goal only with ``docking.follow``.
        sample : bool
            Also run the sampler when the NLP or docking made the plan (for cross-checks and
            plots).
        goal_tolerance : float
            How near the goal counts as arrived, m (the task's; 0: the goal point). With
            ``docking.region_points``, docking may head for a point that near the goal when
            the way to the goal point itself is not safe enough (:func:`.docking.dock`).
        time_budget : float, "auto" or None
            This plan's time budget in seconds (:class:`~dsmpepc_nlp.core.deadline.Deadline`;
            default ``SolverConfig.time_budget``): when it runs out, no further solve, polish
            round, sampler chunk or recovery starts, and the best exact-costed candidate so
            far is the plan (status ``deadline`` when it cut the chosen solver; ``Plan.cut``
            names every stage it cut). ``sample=True``'s extra sampler run (a diagnostic)
            is not bounded.

        Returns
        -------
        Plan
            Never NaN. A stage that raises (starts, cycle, docking, NLP, verdicts, sampler) is
            named in ``message`` and the next one takes over, down to the stop trajectory.

        Raises
        ------
        InputError
            Only for a ``goal`` that is not a finite (x, y) pair, a ``goal_tolerance`` that is
            not a finite number >= 0, a ``time_budget`` that is not one, or a ``state`` that
            is neither a RobotState nor 3 or 5 finite numbers.

        Warns
        -----
        RuntimeWarning
            Once (until :meth:`reset`), when :data:`FALLBACK_WARNING` plans in a row fell back.
        """
        started = time.perf_counter()
        state, goal, goal_tolerance = as_state(state), as_goal(goal), as_tolerance(goal_tolerance)
        budget = self.solver.time_budget if time_budget is CONFIGURED else time_budget
        if not is_budget(budget):
            raise InputError(f"time_budget = {budget!r}: must be {BUDGET_ALLOWED}")
        deadline = Deadline(budget_seconds(budget, self.config.horizon.dt), started)
        if self.compile == "wait" and math.isfinite(deadline.seconds):
            loading = time.perf_counter()       # the exact kernel loaded (or compiled) now
            exact.warm_up()                     # is prepare()'s work: not counted
            deadline.extend(time.perf_counter() - loading)
        with np.errstate(all="ignore"):     # a start at 1e300 m overflows; it is no overlap
            overlap = self._try([], "the overlap", start_overlap, state, world, self.config)
        if overlap:                         # Lemma 3: brake, and nothing else moves the robot
            return self._in_collision(state, world, goal, overlap, started)
        # Every stage runs inside the fallback chain: a stage that raises is reported in the
        # message and the next one takes over; the stop trajectory is the last resort.
        trouble = []
        level = self._try(trouble, "the stall monitor", self.stall.update, state, goal) or 0
        config = self.stall.config_for(level)
        world = self._try(trouble, "the standing people", self.standing.update, world,
                          (state.x, state.y), goal) or world
        starts = self._try(trouble, "the starts", structured_starts, state, goal, self.config,
                          self._previous_target, self.solver) or {}
        cycle = self._try(trouble, "the cycle", Cycle.prepare, state, world, goal, config)
        # The one door to the exact cost for this plan: every stage below costs through it.
        evaluator = None if cycle is None else Evaluator(cycle, self.solver)
        self.last_evaluator = evaluator
        plan, evaluated, records = None, None, ()
        if dock and cycle is not None and "docking" in self.instead:
            plan = self._timed(trouble, deadline, "docking", self._dock, evaluator,
                               goal_tolerance)
        compiling = ""
        if plan is None and self.nlp is not None and cycle is not None \
                and self.compile == "background":
            _, compiling = self._try(trouble, "the NLP's readiness", self.nlp.readiness,
                                    cycle) or (True, "")
        if plan is None and self.nlp is not None and cycle is not None and not compiling:
            records = self._try(trouble, "the NLP", self._solve_nlp, evaluator, starts,
                                deadline) or ()
            plan = self._try(trouble, "the NLP's verdict", self._choose_nlp, records, evaluator,
                             deadline)
        if plan is None and cycle is not None:
            sampler = self.sampler if not compiling else self._quick_sampler()
            evaluated = evaluated or self._try(trouble, "the sampler", sampler.search,
                                              evaluator, starts, deadline)
            if evaluated is not None:
                plan = self._try(trouble, "the sampled verdict", self._from_evaluation,
                                evaluated, state, fallback=self.nlp is not None, records=records,
                                compiling=compiling, cut=SAMPLER in deadline.cut)
        if plan is None:
            plan = self._stop(state, records)
        else:
            if cycle is not None:
                plan = self._recover(trouble, deadline, plan, state, evaluator, level,
                                     goal_tolerance)
            if sample and evaluated is None and cycle is not None:    # docked or the NLP's
                evaluated = self._try(trouble, "the sampler", self.sampler.search, evaluator,
                                      starts)
        if trouble:
            plan = _replace(plan, message="; ".join(trouble) + "; " + plan.message,
                            success=False)
        if level:
            plan = _replace(plan, message=f"{self.stall.describe(level)}; {plan.message}")
        if deadline.cut:
            plan = _replace(plan, cut=tuple(deadline.cut), message=(
                f"time budget of {deadline.seconds * 1e3:.0f} ms spent, cut: "
                f"{', '.join(deadline.cut)}; {plan.message}"))
        plan = _replace(plan, wall_time=time.perf_counter() - started, evaluated=evaluated,
                        fallbacks_in_row=self._count_fallback(plan), stall_level=level)
        self._previous_target = (plan.trajectory.target, float(plan.x[3]))
        if self.compile == "background":
            exact.preload()    # once: the compiled kernel loads in a thread after a first plan
        return plan

    def _try(self, trouble, stage, function, *args, **kwargs):
        """A stage of :meth:`plan`: ``function(*args, **kwargs)``; when it raises, None and a
        line in ``trouble`` (the next stage takes over), or, with ``strict``, the exception."""
        try:
            return function(*args, **kwargs)
        except Exception as error:  # noqa: BLE001 - a failing stage must not stop planning
            if self.strict:
                raise
            trouble.append(f"{stage} raised {type(error).__name__}: {error}")
            return None

    def _timed(self, trouble, deadline: Deadline, stage: str, function, *args):
        """A stage that cannot stop once started (docking, a behaviour on the plan): :meth:`_try`
        when the time left covers what it took lately (its slowest run, decaying by
        :data:`TOOK_DECAY` a plan, run or skipped: one slow run does not keep it off), else
        skipped and recorded as cut."""
        took = self._took.get(stage, 0.0)
        if not deadline.check(stage, took):
            self._took[stage] = TOOK_DECAY * took
            return None
        began = time.perf_counter()
        result = self._try(trouble, stage, function, *args)
        self._took[stage] = max(time.perf_counter() - began, TOOK_DECAY * took)
        return result

    def _recover(self, trouble, deadline: Deadline, plan: Plan, state, evaluator: Evaluator,
                 level: int, goal_tolerance: float) -> Plan:
        """The behaviours that run on ``plan`` (:mod:`.behaviours.chain`), in the configured
        order, each a stage under the time budget (:meth:`_timed`); the first plan one returns
        replaces ``plan``."""
        recovery = chain.Recovery(plan, state, evaluator, level, goal_tolerance)
        for name in self.on_plan:
            stage = f"the {name.replace('-', ' ')}"
            replaced = self._timed(trouble, deadline, stage, chain.ON_PLAN[name], recovery)
            if replaced is not None:
                return replaced
        return plan

    def _count_fallback(self, plan: Plan) -> int:
        self._fallbacks = self._fallbacks + 1 if plan.status in FALLBACK_STATUSES else 0
        if self._fallbacks >= FALLBACK_WARNING and not self._warned:
            self._warned = True
            warnings.warn(f"{self._fallbacks} plans in a row fell back ({plan.status}): "
                          f"{plan.message}", RuntimeWarning, stacklevel=3)
        return self._fallbacks

    # -- the pieces of plan() ---------------------------------------------------------------

    def _dock(self, evaluator: Evaluator, goal_tolerance: float) -> Plan | None:
        docked = docking.dock(evaluator, self.config, goal_tolerance)
        return None if docked is None else self._plan_from(docked[0], 0, "docked", True,
                                                           docked[1], 0, ())

    def _solve_nlp(self, evaluator: Evaluator, starts, deadline: Deadline) -> tuple:
        """Every NLP start's record with its exact cost."""
        return self._verify(self.nlp.solve(evaluator, starts, deadline), evaluator)

    def _verify(self, original, evaluator: Evaluator) -> tuple:
        """Exact cost of every start's result: the verdict on the NLP.

        Records that arrive with a finite ``exact_cost`` (the NLP solver costs its screened
        starts and results through the same evaluator) are not costed twice.
        """
        records = [r for r in original if not math.isfinite(r.exact_cost)]
        finite = [r for r in records if np.all(np.isfinite(r.z))]
        costs = {}
        if finite:
            totals = evaluator.totals(np.array([r.z for r in finite]))
            costs = {id(r): float(c) for r, c in zip(finite, totals)}
        return tuple(r if math.isfinite(r.exact_cost)
                     else _replace(r, exact_cost=costs.get(id(r), math.nan)) for r in original)

    def _choose_nlp(self, records, evaluator: Evaluator, deadline: Deadline) -> Plan | None:
        """The best record by exact cost; with the solves cut by the deadline, whatever it
        is (a screened start is a candidate like any other), status ``deadline``."""
        usable = [r for r in records if math.isfinite(r.exact_cost)]
        cut = SOLVES in deadline.cut
        if not usable or not (cut or any(r.success for r in usable)):
            return None
        best = min(usable, key=lambda r: r.exact_cost)
        ev = evaluator.evaluate(best.z)       # read back from the batch that costed it
        nit = sum(r.nit for r in records)
        message = f"NLP: best of {len(records)} starts is '{best.name}' ({best.status})" + (
            "; no screen of the box, no polish: the compiled exact kernel is loading"
            if self.nlp.kernel_loading else "")
        if cut:
            return self._plan_from(ev, 0, "deadline", False, "the time budget cut the NLP's "
                                   f"solves: {message[5:]}", nit, records)
        return self._plan_from(ev, 0, "nlp", True, message, nit, records)

    def _from_evaluation(self, evaluated: Evaluation, state, *, fallback: bool, records,
                         compiling: str = "", cut: bool = False) -> Plan:
        index = evaluated.best()
        if index is None:
            return self._stop(state, records)
        if compiling:
            return self._plan_from(evaluated, index, "sampling-compiling", True,
                                   f"{compiling}: best of {len(evaluated.z)} sampled "
                                   "trajectories used", 0, ())
        if fallback:
            return self._plan_from(evaluated, index, "sampling-fallback", False,
                                   "every NLP start failed; best sampled trajectory used",
                                   sum(r.nit for r in records), records)
        if cut:
            return self._plan_from(evaluated, index, "deadline", False, "the time budget "
                                   f"cut the sampler: best of the {len(evaluated.z)} sampled "
                                   "trajectories costed", 0, ())
        return self._plan_from(evaluated, index, "sampling", True,
                               f"best of {len(evaluated.z)} sampled trajectories", 0, ())

    def _in_collision(self, state, world, goal, overlap: str, started: float) -> Plan:
        """The brake of a robot whose footprint already overlaps the map or an object
        (:func:`.start_state.braking_plan`: Lemma 3, whatever the preset, solver or ladder)."""
        plan = start_state.braking_plan(state, world, goal, overlap, self.config)
        self._previous_target = None
        return _replace(plan, wall_time=time.perf_counter() - started,
                        fallbacks_in_row=self._count_fallback(plan))

    def _stop(self, state, records) -> Plan:
        return start_state.stop_plan(state, records, self.config)

    def _plan_from(self, ev: Evaluation, index, status, success, message, nit, records) -> Plan:
        trajectory = ev.trajectories[index]
        return Plan(ev.z[index], float(ev.costs.total[index]), success, message, nit,
                    trajectory, law_control(trajectory, self.config), ev.costs[index], status,
                    tuple(records))


def _replace(obj, **changes):
    return dataclasses.replace(obj, **changes)
