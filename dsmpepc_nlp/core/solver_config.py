"""How a plan is searched for: the solver's configuration (the NLP plugin and its options, the
multistart, the polish, the sampler), and the solver names, in one place."""

from __future__ import annotations

from dataclasses import dataclass

from .errors import InputError
from .validation import fail, validate_fields

SOLVER_METHODS = ("ipopt", "newton", "sampling")


SOLVER_NAMES = ("nlp", "fast", "sampling")
"""The solvers by name, as on the command line (:meth:`SolverConfig.named`): the one list."""


@dataclass(frozen=True)
class SolverConfig:
    """How a plan is searched for: the NLP plugin and its options, or the sampling planner.

    ``SolverConfig()`` is IPOPT (default), ``SolverConfig.fast()`` the fast NLP configuration,
    ``SolverConfig.sampling()`` the batched exact-cost sampler alone.
    """

    method: str = "ipopt"
    """``ipopt`` (CasADi ``nlpsol`` on the compiled graph), ``newton`` (our trust-region Newton
    on the 4-D box over the same compiled graph) or ``sampling``."""
    max_iter: int = 40
    """Iteration limit per start."""
    tol: float = 1e-5
    """Convergence tolerance passed to the plugin."""
    options: tuple = ()
    """Extra ``(key, value)`` pairs for ``casadi.nlpsol`` (plugin options as ``"ipopt.key"``)."""
    n_spread: int = 4
    """Starts spread over the z box in addition to the structured ones."""
    n_samples: int = 4096
    """Samples of z for the sampling planner (low-discrepancy)."""
    seed: int = 0
    """Seed of the low-discrepancy sequence and of the spread starts."""
    pair_budget: int = 2_000_000
    """Largest (trajectory, pose, footprint circle, obstacle circle) count the numpy exact cost
    handles in one chunk: keeps its temporaries near 100 MB however crowded the world."""
    parallel_rows: int = 64
    """Smallest batch the compiled exact evaluator spreads over every core; smaller batches run
    on the calling thread, where waking the thread pool would cost more than it saves."""
    n_screen: int = 256
    """Low-discrepancy z costed exactly with the named starts before any solve (the landscape
    is multimodal: the NLP only runs from the best of them)."""
    n_solved: int = 3
    """Starts the NLP runs from (the warm start, then the best distinct others); fewer lost
    BARN worlds (docs/nlp.md, "Pass 8")."""
    solve_threads: int = 2
    """Threads the solves of one plan run on at once (IPOPT: each with its own ``nlpsol``,
    which releases Python's lock while it runs; ``newton``: its compiled loop, which does too);
    1 runs them one after another. Every solve is the same whatever the count; only the
    plan's wall time changes. Two is this project's 2-core reference machine."""
    distinct: float = 0.05
    """Two starts closer than this share of the box (max norm) count as one."""
    fd_step: float = 1e-6
    """Forward-difference step of the Hessian of the gradient, as a share of each variable's
    range (``hessian="differences"``)."""
    hessian: str = "quasi-newton"
    """The Hessian the solvers use: ``quasi-newton`` (gradients only: IPOPT's limited-memory
    update; for ``newton`` symmetric rank-one updates started from the differences),
    ``differences`` of the compiled gradient (4 more gradients per Hessian) or ``exact``
    (compiled forward over reverse; minutes to compile, no faster than the differences)."""
    pose_object_buckets: tuple = (0, 4, 12)
    """Object counts the graph is compiled for at every pose; a cycle uses the smallest that
    holds the objects in its reach (the largest when none does). Each is compiled on first
    use and cached."""
    polish_rounds: int = 8
    """Rounds of the exact-cost polish after the solves: the best candidate's 24 neighbours
    (a step of ``polish_step`` along one variable, or along all four at once; share of each
    range) are costed exactly and the best kept, then the step halves; 0 turns it off
    (docs/nlp.md, "Pass 6")."""
    polish_step: float = 0.04
    """First step of the polish, as a share of each variable's range."""
    polish_starts: int = 5
    """Best distinct candidates (solved or screened, by exact cost) the polish starts from."""
    polish_margin: float = 1.0
    """Candidates whose exact cost trails the best one's by more than this are not polished
    (``inf``: every one of the ``polish_starts``): no polish gain measured ever came near it
    (docs/nlp.md, "Pass 6")."""
    polish_ahead: bool = True
    """Polish on the thread the solves leave idle: three solves on two threads end with one
    thread waiting for the last solve, and there it walks from the seeds known so far (the
    screened starts and the finished solves). The final polish continues those walks whose
    seed is still a seed. Every walk is the same wherever it runs, so the plan is the same
    either way (held by a test); only the wall time changes."""
    screen_ahead: bool = True
    """Solve from the warm start at once, while a second thread costs the other starts
    exactly (the screen): the warm start is solved whatever the screen finds, and the solves
    from the best other starts follow it (with ``solve_threads`` above 1). Every solve and
    record is the same either way (held by a test); only the wall time changes."""
    trust_radius: float = 0.25
    """Initial trust radius of ``newton``, as a share of each variable's range."""
    soft_turn: float = 0.6
    """|delta| of the soft-turn starts, rad (about a third of the box)."""
    hard_turn: float = 1.5
    """|delta| of the hard-turn starts, rad (near the box's edge)."""
    turn_distance: float = 2.0
    """Target distance r of the turn starts, m."""

    def __post_init__(self):
        if self.method not in SOLVER_METHODS:
            fail("SolverConfig", "method", self.method, f"one of {', '.join(SOLVER_METHODS)}")
        for name, low in (("max_iter", 1), ("n_spread", 0), ("n_samples", 1), ("seed", 0),
                          ("pair_budget", 1), ("parallel_rows", 1),
                          ("n_screen", 0), ("n_solved", 1), ("solve_threads", 1),
                          ("polish_rounds", 0),
                          ("polish_starts", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                fail("SolverConfig", name, value, f"an integer >= {low}")
        positive = dict(low=0.0, low_open=True)
        validate_fields(self, {"tol": positive, "distinct": dict(low=0.0, high=1.0),
                                "fd_step": positive, "polish_step": dict(low=0.0, high=1.0),
                                "polish_margin": dict(low=0.0, allow_inf=True),
                                "trust_radius": dict(low=0.0, low_open=True, high=1.0),
                                "soft_turn": dict(low=0.0), "hard_turn": dict(low=0.0),
                                "turn_distance": positive})
        for name in ("polish_ahead", "screen_ahead"):
            if not isinstance(getattr(self, name), bool):
                fail("SolverConfig", name, getattr(self, name), "True or False")
        hessians = ("differences", "exact", "quasi-newton")
        if self.hessian not in hessians:
            fail("SolverConfig", "hessian", self.hessian, " or ".join(map(repr, hessians)))
        try:
            buckets = tuple(sorted({int(b) for b in self.pose_object_buckets}))
        except (TypeError, ValueError):
            buckets = ()
        if not buckets or buckets[0] < 0 or any(
                isinstance(b, bool) or b != int(b) for b in self.pose_object_buckets):
            fail("SolverConfig", "pose_object_buckets", self.pose_object_buckets,
                  "a non-empty sequence of integers >= 0")
        object.__setattr__(self, "pose_object_buckets", buckets)
        try:
            options = tuple((str(k), v) for k, v in
                            (self.options.items() if isinstance(self.options, dict)
                             else self.options))
        except (TypeError, ValueError):
            fail("SolverConfig", "options", self.options, "a dict or sequence of (key, value)")
        object.__setattr__(self, "options", options)

    @classmethod
    def fast(cls, **changes) -> SolverConfig:
        """Trust-region Newton on the 4-D box: exact box-QP step, quasi-Newton (SR1) Hessian.

        On 4 variables it needs no barrier and no per-call ``nlpsol`` overhead; ``tol`` is the
        predicted decrease counted as converged (1e-3, against the 0.01 cost tolerance). The
        exact polish starts from the 3 best candidates instead of 5: two fifths of the polish
        saved for about the same plans (docs/nlp.md, "Pass 6").
        """
        changes.setdefault("tol", 1e-3)
        changes.setdefault("polish_starts", 3)
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
