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
from . import start_state, verdicts
from .behaviours import chain, docking
from .behaviours.stall import StallMonitor
from .exact import loader as exact
from .exact.cycle import Cycle
from .exact.evaluator import Evaluation, Evaluator
from .optimize.multistart import NlpSolver
from .optimize.sampling import STAGE as SAMPLER
from .optimize.sampling import SamplingPlanner
from .optimize.starts import structured_starts
from .plan import Plan
from .start_state import as_goal, as_state, as_tolerance, start_overlap

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
        # The stages, in order. Each runs inside the fallback chain: a stage that raises is
        # named in the message and the next one takes over; the stop trajectory is the last.
        work = _Work(state, goal, goal_tolerance, deadline)
        self._model(work, world)        # the stall level, the starts, the cycle
        if dock:
            self._dock(work)            # docking, instead of the optimiser
        self._optimise(work)            # the NLP, else the sampler, else a stop
        self._on_plan(work, sample)     # the behaviours on the plan (:mod:`.behaviours.chain`)
        return self._finish(work, started)

    def _model(self, work: _Work, world: World) -> None:
        """What the plan sees: the stall level (and its config), the named starts, the cycle
        and its one evaluator, the door to the exact cost for every stage that follows."""
        state, goal, trouble = work.state, work.goal, work.trouble
        work.level = self._try(trouble, "the stall monitor", self.stall.update, state, goal) or 0
        work.starts = self._try(trouble, "the starts", structured_starts, state, goal,
                                self.config, self._previous_target, self.solver) or {}
        cycle = self._try(trouble, "the cycle", Cycle.prepare, state, world, goal,
                          self.stall.config_for(work.level))
        work.evaluator = None if cycle is None else Evaluator(cycle, self.solver)
        self.last_evaluator = work.evaluator

    def _dock(self, work: _Work) -> None:
        """``docking`` when the chain names it: the plan, if a docking way is safe enough."""
        if work.evaluator is not None and "docking" in self.instead:
            work.plan = self._timed(work.trouble, work.deadline, "docking", self._docked,
                                    work.evaluator, work.goal_tolerance)

    def _optimise(self, work: _Work) -> None:
        """The chosen solver when nothing took its place: the NLP (unless its library is
        still compiling), else or then the sampler, else the stop trajectory."""
        trouble, evaluator, deadline = work.trouble, work.evaluator, work.deadline
        if work.plan is not None:
            return
        compiling = ""
        if self.nlp is not None and evaluator is not None and self.compile == "background":
            _, compiling = self._try(trouble, "the NLP's readiness", self.nlp.readiness,
                                    evaluator.cycle) or (True, "")
        if self.nlp is not None and evaluator is not None and not compiling:
            work.records = self._try(trouble, "the NLP", self._solve_nlp, evaluator,
                                     work.starts, deadline) or ()
            work.plan = self._try(trouble, "the NLP's verdict", verdicts.choose_nlp,
                                  work.records, evaluator, deadline, self.config, self.nlp)
        if work.plan is None and evaluator is not None:
            sampler = self.sampler if not compiling else self._quick_sampler()
            work.evaluated = self._try(trouble, "the sampler", sampler.search, evaluator,
                                       work.starts, deadline)
            if work.evaluated is not None:
                work.plan = self._try(trouble, "the sampled verdict", verdicts.from_evaluation,
                                      work.evaluated, work.state, self.config,
                                      fallback=self.nlp is not None, records=work.records,
                                      compiling=compiling, cut=SAMPLER in deadline.cut)
        if work.plan is None:
            work.plan = self._stop(work.state, work.records)
            work.stopped = True

    def _on_plan(self, work: _Work, sample: bool) -> None:
        """The behaviours that run on the plan (none on a stop), and with ``sample`` the
        sampler's diagnostic run beside a docked or NLP plan."""
        if work.stopped or work.evaluator is None:
            return
        work.plan = self._recover(work.trouble, work.deadline, work.plan, work.state,
                                  work.evaluator, work.level, work.goal_tolerance)
        if sample and work.evaluated is None:
            work.evaluated = self._try(work.trouble, "the sampler", self.sampler.search,
                                       work.evaluator, work.starts)

    def _finish(self, work: _Work, started: float) -> Plan:
        """The plan with what happened said: stages that raised, the stall level, what the
        time budget cut; its wall time and records; the next plan's warm start kept."""
        plan, deadline, level = work.plan, work.deadline, work.level
        if work.trouble:
            plan = _replace(plan, message="; ".join(work.trouble) + "; " + plan.message,
                            success=False)
        if level:
            plan = _replace(plan, message=f"{self.stall.describe(level)}; {plan.message}")
        if deadline.cut:
            plan = _replace(plan, cut=tuple(deadline.cut), message=(
                f"time budget of {deadline.seconds * 1e3:.0f} ms spent, cut: "
                f"{', '.join(deadline.cut)}; {plan.message}"))
        plan = _replace(plan, wall_time=time.perf_counter() - started, evaluated=work.evaluated,
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
        def timed(stage, behaviour, recovery):
            return self._timed(trouble, deadline, stage, behaviour, recovery)

        return chain.recover(plan, state, evaluator, level, goal_tolerance, self.on_plan,
                             timed) or plan

    def _count_fallback(self, plan: Plan) -> int:
        self._fallbacks = self._fallbacks + 1 if plan.status in FALLBACK_STATUSES else 0
        if self._fallbacks >= FALLBACK_WARNING and not self._warned:
            self._warned = True
            warnings.warn(f"{self._fallbacks} plans in a row fell back ({plan.status}): "
                          f"{plan.message}", RuntimeWarning, stacklevel=3)
        return self._fallbacks

    # -- the pieces of plan() ---------------------------------------------------------------

    def _docked(self, evaluator: Evaluator, goal_tolerance: float) -> Plan | None:
        docked = docking.dock(evaluator, self.config, goal_tolerance)
        return None if docked is None else verdicts.plan_from(
            docked[0], 0, "docked", True, docked[1], 0, (), self.config)

    def _solve_nlp(self, evaluator: Evaluator, starts, deadline: Deadline) -> tuple:
        """Every NLP start's record with its exact cost."""
        return verdicts.verify(self.nlp.solve(evaluator, starts, deadline), evaluator)

    def _in_collision(self, state, world, goal, overlap: str, started: float) -> Plan:
        """The brake of a robot whose footprint already overlaps the map or an object
        (:func:`.start_state.braking_plan`: Lemma 3, whatever the preset, solver or ladder)."""
        plan = start_state.braking_plan(state, world, goal, overlap, self.config)
        self._previous_target = None
        return _replace(plan, wall_time=time.perf_counter() - started,
                        fallbacks_in_row=self._count_fallback(plan))

    def _stop(self, state, records) -> Plan:
        return start_state.stop_plan(state, records, self.config)

def _replace(obj, **changes):
    return dataclasses.replace(obj, **changes)


@dataclasses.dataclass
class _Work:
    """One plan's work as its stages hand it on (:meth:`Planner.plan`)."""

    state: RobotState
    goal: np.ndarray
    goal_tolerance: float
    deadline: Deadline
    trouble: list = dataclasses.field(default_factory=list)
    level: int = 0
    starts: dict = dataclasses.field(default_factory=dict)
    evaluator: Evaluator | None = None
    plan: Plan | None = None
    stopped: bool = False
    records: tuple = ()
    evaluated: Evaluation | None = None
