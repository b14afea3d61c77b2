"""What a plan returns: the :class:`Plan`, and the record of what each start of the NLP's
multi-start search did (``nlp`` writes them, ``planner`` reads them and hands them on in the
plan), below both so that neither imports the other for them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.control_law import Trajectory
from ..core.exact_cost import CostBreakdown
from ..core.terms import TERM_NAMES
from .exact.evaluator import Evaluation


@dataclass(frozen=True)
class StartRecord:
    """One start of the multi-start search.

    ``z0`` the start, ``z`` where the solver ended (clipped to the box), ``status`` the solver's
    return status, ``nit`` iterations, ``time_s`` wall time, ``smooth_cost`` the NLP objective
    at ``z`` and ``exact_cost`` the exact cost of ``z`` (the verdict).
    """

    name: str
    z0: np.ndarray
    z: np.ndarray
    status: str
    success: bool
    nit: int
    time_s: float
    smooth_cost: float = math.nan
    exact_cost: float = math.nan


__all__ = ["STATUSES", "Plan", "StartRecord", "unmeasured"]


STATUSES = ("nlp", "sampling", "sampling-fallback", "docked", "stopped", "start-in-collision",
            "sampling-compiling", "backing-up", "dodging", "turning", "clearing", "deadline")
"""Where a plan came from: the NLP, the sampler as chosen solver, the sampler after every NLP
start failed, docking at a fixed goal, the stop trajectory when nothing finite was found, the
brake of a robot whose footprint already overlaps the map or an obstacle
(``start-in-collision``: it brakes as hard as its limits allow and nothing else moves it; the
message names the overlap), the sampler while the NLP's library for this cycle's structure
compiles in the background
(``sampling-compiling``), or the stall ladder's back-up rung (``backing-up``: a reverse
trajectory the law cannot make, cheaper by the exact cost than standing) and its dodges
(``dodging``: a hard turn, then ahead, against a plan that expects to be struck), its turn
in place toward the goal of a stalled robot facing away from it (``turning``), and its last
resort against a plan struck almost surely within the second, the way that keeps the widest
gap (``clearing``), or the best exact-costed candidate when the plan's time budget ran out
before the chosen solver finished (``deadline``). New statuses are appended, so stored indices
keep their meaning."""


@dataclass(frozen=True)
class Plan:
    """The outcome of one planning cycle. Field names follow ``scipy.optimize.OptimizeResult``.

    Attributes
    ----------
    x : ndarray, (4,)
        The chosen z = (r, theta, delta, v_max).
    fun : float
        Its exact cost.
    success : bool
        True when the chosen solver delivered the plan (no fallback to stopping or sampling).
    message : str
        What happened, in words.
    nit : int
        Iterations summed over the NLP starts (0 for sampling and docking).
    trajectory : Trajectory
        The exact rollout of ``x``.
    control : tuple of float
        ``(v, omega)`` for the first step, m/s and rad/s; always finite and within the limits.
    cost : CostBreakdown
        Exact cost of ``x`` with its per-term breakdown.
    status : str
        One of :data:`STATUSES`.
    starts : tuple of StartRecord
        Every NLP start, in order.
    wall_time : float
        Seconds spent in :meth:`Planner.plan`.
    evaluated : Evaluation or None
        The sampled z with their exact costs, when the sampler ran (for plots and cross-checks).
    fallbacks_in_row : int
        Plans in a row, this one included, with a status in :data:`FALLBACK_STATUSES` (0 when
        this plan is not a fallback).
    stall_level : int
        The stall monitor's ladder level this plan was made at (0: not stalled; see
        :class:`~dsmpepc_nlp.core.config.StallConfig`).
    cut : tuple of str
        The stages the time budget cut short or skipped (empty: none; see
        ``SolverConfig.time_budget``).
    """

    x: np.ndarray
    fun: float
    success: bool
    message: str
    nit: int
    trajectory: Trajectory
    control: tuple
    cost: CostBreakdown
    status: str
    starts: tuple = ()
    wall_time: float = 0.0
    evaluated: Evaluation | None = field(default=None, repr=False)
    fallbacks_in_row: int = 0
    stall_level: int = 0
    cut: tuple = ()

    @property
    def z(self) -> np.ndarray:
        """Alias of ``x``."""
        return self.x

    @property
    def breakdown(self) -> dict:
        """Per-term exact cost, ``{name: float}``."""
        return {name: float(value) for name, value in self.cost.terms.items()}


def unmeasured(trajectory: Trajectory) -> CostBreakdown:
    """The breakdown of a plan whose cost could not be measured: total inf, terms 0,
    survival 0 (a plan is never NaN)."""
    inf = np.full(1, math.inf)
    survival = np.zeros((1, trajectory.poses.shape[0]))
    return CostBreakdown(inf, {name: np.zeros(1) for name in TERM_NAMES}, survival,
                         np.full(1, -math.inf), inf, np.zeros(1))[0]
