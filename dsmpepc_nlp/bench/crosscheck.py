"""Cross-check of the NLP against the exact sampling planner, cycle by cycle, on exact costs."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..core.config import PlannerConfig
from ..core.solver_config import SolverConfig


@dataclass(frozen=True)
class CrosscheckResult:
    """Per-cycle exact costs of the NLP plan and of the best sampled plan.

    Attributes
    ----------
    nlp_cost, sampled_cost : ndarray, (cycles,)
        Exact cost of the NLP's chosen z and of the best of the samples plus structured starts.
    gap : ndarray, (cycles,)
        ``nlp_cost - sampled_cost``; <= 0 when the NLP is as good or better.
    nlp_status : tuple of str
        :attr:`~dsmpepc_nlp.solve.plan.Plan.status` of each NLP plan.
    tol : float
        The tolerance of :attr:`share_within_tol`.
    docked : ndarray of bool, (cycles,)
        Whether the planner with docking on would have docked in each cycle: there the robot's
        plan is the docking trajectory and the NLP is never asked (empty when not known).
    """

    nlp_cost: np.ndarray
    sampled_cost: np.ndarray
    gap: np.ndarray
    nlp_status: tuple = field(default=())
    tol: float = 0.01
    docked: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    @property
    def cycles(self) -> int:
        return int(self.gap.size)

    @property
    def share_within_tol(self) -> float:
        """Share of cycles with ``gap <= tol`` (non-finite gaps count as misses): every cycle,
        docked or not (the command's headline figure)."""
        return _share(self.gap, self.tol)

    @property
    def share_within_tol_undocked(self) -> float:
        """:attr:`share_within_tol` over the cycles the planner would not dock in, the ones
        where the NLP's plan is the robot's (NaN when :attr:`docked` is not known)."""
        if self.docked.size != self.gap.size:
            return math.nan
        return _share(self.gap[~self.docked], self.tol)

    def describe(self) -> str:
        """One line: the gap's median and p95, and the shares within ``tol``."""
        d = self.to_dict()
        return (f"{d['cycles']} cycles: gap (NLP - sampling) median {d['gap_median']:.4g}, p95 "
                f"{d['gap_p95']:.4g}, within {self.tol:g}: {100 * d['share_within_tol']:.1f}% "
                f"(the planner docks in {d['docked_cycles']}, where the NLP is not asked; in "
                f"the other {d['cycles'] - d['docked_cycles']}: "
                f"{100 * d['share_within_tol_undocked']:.1f}%)")

    def to_dict(self) -> dict:
        """Summary: ``cycles``, ``gap_median``, ``gap_p95``, ``share_within_tol``, ``tol``,
        ``docked_cycles`` and ``share_within_tol_undocked``."""
        finite = self.gap[np.isfinite(self.gap)]
        return {
            "cycles": self.cycles,
            "gap_median": float(np.median(finite)) if finite.size else math.nan,
            "gap_p95": float(np.percentile(finite, 95)) if finite.size else math.nan,
            "share_within_tol": self.share_within_tol,
            "tol": self.tol,
            "docked_cycles": int(np.sum(self.docked)),
            "share_within_tol_undocked": self.share_within_tol_undocked,
        }


def _share(gap: np.ndarray, tol: float) -> float:
    """Share of ``gap <= tol``, non-finite gaps counted as misses; NaN for no gaps."""
    if gap.size == 0:
        return math.nan
    return float(np.mean(np.where(np.isfinite(gap), gap <= tol, False)))


def crosscheck(cycles, config: PlannerConfig, solver_config: SolverConfig | None = None,
               n_samples: int = 4096, tol: float = 0.01, dock: bool = True) -> CrosscheckResult:
    """Plan every cycle with the NLP and with the sampler; compare exact costs.

    Parameters
    ----------
    cycles : iterable of (RobotState, World, array_like (2,))
        ``(state, world, goal)`` per cycle, in order (the NLP keeps its warm start across them).
    config : PlannerConfig
    solver_config : SolverConfig, optional
        The NLP's configuration (IPOPT by default).
    n_samples : int
        Samples of the reference sampling planner (plus its structured starts).
    tol : float
        Gap counted as "as good", in cost units.
    dock : bool
        Whether the planner would dock at these cycles' goal (a fixed goal, or a followed one
        with ``docking.follow``): each cycle's :attr:`CrosscheckResult.docked` says whether
        ``config``'s docking test would then take it.

    Notes
    -----
    Docking is off for both planners: near the goal it would bypass both solvers. So is the
    stall monitor: its ladder changes the cost from one cycle to the next (the progress weight
    up to x8, and the gaps in cost units with it), and the two solvers are compared on one cost.
    """
    from ..solve.behaviours import docking
    from ..solve.planner import Planner

    config = dataclasses.replace(config, stall=dataclasses.replace(config.stall, levels=0))
    solver_config = SolverConfig() if solver_config is None else solver_config
    nlp = Planner(config, solver_config)
    nlp.prepare()
    sampler = Planner(config, SolverConfig.sampling(n_samples=n_samples,
                                                    seed=solver_config.seed))
    nlp_cost, sampled_cost, statuses, docked = [], [], [], []
    for state, world, goal in cycles:
        plan = nlp.plan(state, world, goal, dock=False)
        # The same test the planner docks by, on this cycle's exact cost.
        docked.append(dock and nlp.last_evaluator is not None
                      and docking.dock(nlp.last_evaluator, config) is not None)
        reference = sampler.plan(state, world, goal, dock=False)
        nlp_cost.append(plan.fun)
        sampled_cost.append(reference.fun)
        statuses.append(plan.status)
    nlp_cost, sampled_cost = np.array(nlp_cost, dtype=float), np.array(sampled_cost, dtype=float)
    return CrosscheckResult(nlp_cost, sampled_cost, nlp_cost - sampled_cost, tuple(statuses),
                            tol, np.array(docked, dtype=bool))
