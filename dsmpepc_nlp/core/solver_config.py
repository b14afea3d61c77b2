"""How a plan is searched for: the solver's configuration, one settings object per concern (the
local solver, the multistart, the polish, the parallelism), and the solver names, in one place.

``SolverConfig()`` is IPOPT, ``SolverConfig.fast()`` the fast NLP configuration,
``SolverConfig.sampling()`` the batched exact-cost sampler alone; a concern is changed by giving
its settings, e.g. ``SolverConfig(multistart=MultistartSettings(n_screen=64))``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from .deadline import AUTO, BUDGET_ALLOWED, is_budget
from .errors import InputError
from .validation import check_booleans, check_integers, fail, validate_fields

SOLVER_METHODS = ("ipopt", "newton", "sampling")


SOLVER_NAMES = ("nlp", "fast", "sampling")
"""The solvers by name, as on the command line (:meth:`SolverConfig.named`): the one list."""

HESSIANS = ("differences", "exact", "quasi-newton")


@dataclass(frozen=True)
class LocalSolverSettings:
    """The local solver each start runs: IPOPT (CasADi ``nlpsol``) or our trust-region Newton
    method, and its Hessian."""

    max_iter: int = 40
    """Iteration limit per start."""
    tol: float = 1e-5
    """Convergence tolerance passed to the plugin (``newton``: the predicted decrease counted
    as converged)."""
    options: tuple = ()
    """Extra ``(key, value)`` pairs for ``casadi.nlpsol`` (plugin options as ``"ipopt.key"``)."""
    hessian: str = "quasi-newton"
    """The Hessian the solvers use: ``quasi-newton`` (gradients only: IPOPT's limited-memory
    update; for ``newton`` symmetric rank-one updates started from the differences),
    ``differences`` of the compiled gradient (4 more gradients per Hessian) or ``exact``
    (compiled forward over reverse; minutes to compile, no faster than the differences)."""
    fd_step: float = 1e-6
    """Forward-difference step of the Hessian of the gradient, as a share of each variable's
    range (``hessian="differences"``)."""
    trust_radius: float = 0.25
    """Initial trust radius of ``newton``, as a share of each variable's range."""

    def __post_init__(self):
        check_integers(self, {"max_iter": 1})
        positive = dict(low=0.0, low_open=True)
        validate_fields(self, {"tol": positive, "fd_step": positive,
                               "trust_radius": dict(low=0.0, low_open=True, high=1.0)})
        if self.hessian not in HESSIANS:
            fail("LocalSolverSettings", "hessian", self.hessian, " or ".join(map(repr, HESSIANS)))
        try:
            options = tuple((str(k), v) for k, v in
                            (self.options.items() if isinstance(self.options, dict)
                             else self.options))
        except (TypeError, ValueError):
            fail("LocalSolverSettings", "options", self.options,
                 "a dict or sequence of (key, value)")
        object.__setattr__(self, "options", options)


@dataclass(frozen=True)
class MultistartSettings:
    """Where the solves start: the named starts' shapes, the starts spread over the box, the
    screen that costs them all exactly, and how many the solver runs from."""

    n_spread: int = 4
    """Starts spread over the z box in addition to the structured ones."""
    n_screen: int = 256
    """Low-discrepancy z costed exactly with the named starts before any solve (the landscape
    is multimodal: the NLP only runs from the best of them)."""
    n_solved: int = 3
    """Starts the NLP runs from (the warm start, then the best distinct others); fewer lost
    BARN worlds (docs/experiments/2026-11-23-screen-beside-the-warm-solve.md)."""
    distinct: float = 0.05
    """Two starts closer than this share of the box (max norm) count as one."""
    soft_turn: float = 0.6
    """|delta| of the soft-turn starts, rad (about a third of the box)."""
    hard_turn: float = 1.5
    """|delta| of the hard-turn starts, rad (near the box's edge)."""
    turn_distance: float = 2.0
    """Target distance r of the turn starts, m."""

    def __post_init__(self):
        check_integers(self, {"n_spread": 0, "n_screen": 0, "n_solved": 1})
        validate_fields(self, {"distinct": dict(low=0.0, high=1.0),
                               "soft_turn": dict(low=0.0), "hard_turn": dict(low=0.0),
                               "turn_distance": dict(low=0.0, low_open=True)})


@dataclass(frozen=True)
class PolishSettings:
    """The exact-cost polish after the solves (``solve/optimize/polish.py``)."""

    rounds: int = 8
    """Rounds of the pattern search: the best candidate's 24 neighbours (a step of ``step``
    along one variable, or along all four at once; share of each range) are costed exactly and
    the best kept, then the step halves; 0 turns the polish off
    (docs/experiments/2026-11-23-a-polish-of-half-the-size.md)."""
    step: float = 0.04
    """First step, as a share of each variable's range."""
    starts: int = 5
    """Best distinct candidates (solved or screened, by exact cost) the polish starts from."""
    margin: float = 1.0
    """Candidates whose exact cost trails the best one's by more than this are not polished
    (``inf``: every one of the ``starts``): no polish gain measured ever came near it
    (docs/experiments/2026-11-23-a-polish-of-half-the-size.md)."""
    scouts: int = 11
    """Distinct candidates after the ``starts`` (the same order and margin) walked only
    ``scout_rounds`` rounds, in one batch, before the best ``promoted`` of them walk the rest
    with the others (0: none). On the hall's cross-check cycles the exact best lay next to a
    candidate ranked 6th to 16th in 22 of 150 plans, so 5 + 11 seeds reach them all
    (docs/experiments/2026-11-29-scouts-in-the-polish.md)."""
    scout_rounds: int = 2
    """Rounds every scout walks before the best are promoted: in 17 of those 22 plans the
    scout that won already led the scouts after two rounds."""
    promoted: int = 2
    """Scouts, the cheapest after their rounds, that walk all ``rounds``."""

    def __post_init__(self):
        check_integers(self, {"rounds": 0, "starts": 1, "scouts": 0, "scout_rounds": 1,
                              "promoted": 0})
        validate_fields(self, {"step": dict(low=0.0, high=1.0),
                               "margin": dict(low=0.0, allow_inf=True)})


@dataclass(frozen=True)
class ParallelSettings:
    """How a plan uses the cores. Every solve, walk and cost is the same whatever these are
    (held by tests); only the plan's wall time changes."""

    solve_threads: int = 2
    """Threads the solves of one plan run on at once (IPOPT: each with its own ``nlpsol``,
    which releases Python's lock while it runs; ``newton``: its compiled loop, which does too);
    1 runs them one after another. Two is this project's 2-core reference machine."""
    parallel_rows: int = 64
    """Smallest batch the compiled exact evaluator spreads over every core; smaller batches run
    on the calling thread, where waking the thread pool would cost more than it saves."""
    pair_budget: int = 2_000_000
    """Largest (trajectory, pose, footprint circle, obstacle circle) count the numpy exact cost
    handles in one chunk: keeps its temporaries near 100 MB however crowded the world."""
    screen_ahead: bool = True
    """Solve from the warm start at once, while a second thread costs the other starts
    exactly (the screen): the warm start is solved whatever the screen finds, and the solves
    from the best other starts follow it (with ``solve_threads`` above 1)."""
    polish_ahead: bool = True
    """Polish on the thread the solves leave idle: three solves on two threads end with one
    thread waiting for the last solve, and there it walks from the seeds known so far. The
    final polish continues those walks whose seed is still a seed."""

    def __post_init__(self):
        check_integers(self, {"solve_threads": 1, "parallel_rows": 1,
                                             "pair_budget": 1})
        check_booleans(self, ("screen_ahead", "polish_ahead"))


@dataclass(frozen=True)
class SolverConfig:
    """How a plan is searched for: the method, the settings of each concern, the sampler's
    size and the seed both draw from, and the object buckets the graph is compiled for."""

    method: str = "ipopt"
    """``ipopt`` (CasADi ``nlpsol`` on the compiled graph), ``newton`` (our trust-region Newton
    on the 4-D box over the same compiled graph) or ``sampling``."""
    local: LocalSolverSettings = field(default_factory=LocalSolverSettings)
    multistart: MultistartSettings = field(default_factory=MultistartSettings)
    polish: PolishSettings = field(default_factory=PolishSettings)
    parallel: ParallelSettings = field(default_factory=ParallelSettings)
    n_samples: int = 4096
    """Samples of z for the sampling planner (low-discrepancy)."""
    seed: int = 0
    """Seed of the low-discrepancy sequences (the sampler's, the spread and screen starts)."""
    pose_object_buckets: tuple = (0, 4, 12)
    """Object counts the graph is compiled for at every pose; a cycle uses the smallest that
    holds the objects in its reach (the largest when none does). Each is compiled on first
    use and cached."""
    time_budget: float | str | None = AUTO
    """Seconds a plan may take (:class:`~dsmpepc_nlp.core.deadline.Deadline`): ``"auto"``
    (default; ``$DSMPEPC_TIME_BUDGET`` may make it ``none`` or seconds) is three quarters of
    the control period, at most 0.2 s (0.15 s at the 0.2 s period); None plans without a
    deadline. When it runs out, the best exact-costed candidate so far is the plan (status
    ``deadline``), and no later stage starts."""

    def __post_init__(self):
        if self.method not in SOLVER_METHODS:
            fail("SolverConfig", "method", self.method, f"one of {', '.join(SOLVER_METHODS)}")
        check_integers(self, {"n_samples": 1, "seed": 0})
        if not is_budget(self.time_budget):
            fail("SolverConfig", "time_budget", self.time_budget, BUDGET_ALLOWED)
        for name, kind in (("local", LocalSolverSettings), ("multistart", MultistartSettings),
                           ("polish", PolishSettings), ("parallel", ParallelSettings)):
            if not isinstance(getattr(self, name), kind):
                fail("SolverConfig", name, getattr(self, name), f"a {kind.__name__}")
        try:
            buckets = tuple(sorted({int(b) for b in self.pose_object_buckets}))
        except (TypeError, ValueError):
            buckets = ()
        if not buckets or buckets[0] < 0 or any(
                isinstance(b, bool) or b != int(b) for b in self.pose_object_buckets):
            fail("SolverConfig", "pose_object_buckets", self.pose_object_buckets,
                 "a non-empty sequence of integers >= 0")
        object.__setattr__(self, "pose_object_buckets", buckets)

    @classmethod
    def fast(cls, **changes) -> SolverConfig:
        """Trust-region Newton on the 4-D box: exact box-QP step, quasi-Newton (SR1) Hessian.

        On 4 variables it needs no barrier and no per-call ``nlpsol`` overhead; its ``tol`` is
        the predicted decrease counted as converged (1e-3, against the 0.01 cost tolerance). The
        polish starts from the 3 best candidates instead of 5: two fifths of the polish saved
        for about the same plans (docs/experiments/2026-11-23-a-polish-of-half-the-size.md).
        ``changes`` replace whole settings.
        """
        changes.setdefault("local", LocalSolverSettings(tol=1e-3))
        changes.setdefault("polish", PolishSettings(starts=3))
        return cls(method="newton", **changes)

    @classmethod
    def sampling(cls, **changes) -> SolverConfig:
        """The batched exact-cost sampling planner alone."""
        return cls(method="sampling", **changes)

    @classmethod
    def named(cls, name: str) -> SolverConfig:
        """One of :data:`SOLVER_NAMES`: ``nlp`` (IPOPT), ``fast`` or ``sampling``."""
        makers = dict(zip(SOLVER_NAMES, (cls, cls.fast, cls.sampling)))
        if name not in makers:
            raise InputError(f"solver = {name!r}: must be one of {', '.join(makers)}")
        return makers[name]()

    def replace(self, **changes) -> SolverConfig:
        """This configuration with fields of its settings changed, by name: ``max_iter=4``
        changes ``local.max_iter``, ``n_screen=16`` ``multistart.n_screen``, ``polish_rounds=2``
        ``polish.rounds``; top-level fields (``method``, ``n_samples``, ``seed``, a whole
        settings object) as they are. An unknown name is an InputError."""
        top, parts = {}, {}
        for name, value in changes.items():
            section, inner = _SECTION_OF.get(name, (None, name))
            if section is None:
                if name not in {f.name for f in dataclasses.fields(self)}:
                    raise InputError(f"SolverConfig has no field {name!r}")
                top[name] = value
            else:
                parts.setdefault(section, {})[inner] = value
        for section, values in parts.items():
            top[section] = dataclasses.replace(top.get(section, getattr(self, section)), **values)
        return dataclasses.replace(self, **top)


_SECTION_OF = {
    **{f.name: ("local", f.name) for f in dataclasses.fields(LocalSolverSettings)},
    **{f.name: ("multistart", f.name) for f in dataclasses.fields(MultistartSettings)},
    **{f"polish_{f.name}": ("polish", f.name) for f in dataclasses.fields(PolishSettings)},
    **{f.name: ("parallel", f.name) for f in dataclasses.fields(ParallelSettings)},
}
"""Each settings field's flat name for :meth:`SolverConfig.replace` (the polish's prefixed)."""
