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
        :attr:`~dsmpepc_nlp.solve.records.Plan.status` of each NLP plan.
    tol : float
        The tolerance of :attr:`share_within_tol`.
    """

    nlp_cost: np.ndarray
    sampled_cost: np.ndarray
    gap: np.ndarray
    nlp_status: tuple = field(default=())
    tol: float = 0.01

    @property
    def cycles(self) -> int:
        return int(self.gap.size)

    @property
    def share_within_tol(self) -> float:
        """Share of cycles with ``gap <= tol`` (non-finite gaps count as misses)."""
        if self.gap.size == 0:
            return math.nan
        return float(np.mean(np.where(np.isfinite(self.gap), self.gap <= self.tol, False)))

    def to_dict(self) -> dict:
        """Summary: ``cycles``, ``gap_median``, ``gap_p95``, ``share_within_tol``, ``tol``."""
        finite = self.gap[np.isfinite(self.gap)]
        return {
            "cycles": self.cycles,
            "gap_median": float(np.median(finite)) if finite.size else math.nan,
            "gap_p95": float(np.percentile(finite, 95)) if finite.size else math.nan,
            "share_within_tol": self.share_within_tol,
            "tol": self.tol,
        }


def crosscheck(cycles, config: PlannerConfig, solver_config: SolverConfig | None = None,
               n_samples: int = 4096, tol: float = 0.01) -> CrosscheckResult:
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

    Notes
    -----
    Docking is off for both planners: near the goal it would bypass both solvers. So is the
    stall monitor: its ladder changes the cost from one cycle to the next (the progress weight
    up to x8, and the gaps in cost units with it), and the two solvers are compared on one cost.
    """
    from ..solve.planner import Planner

    config = dataclasses.replace(config, stall=dataclasses.replace(config.stall, levels=0))
    solver_config = SolverConfig() if solver_config is None else solver_config
    nlp = Planner(config, solver_config)
    nlp.prepare()
    sampler = Planner(config, SolverConfig.sampling(n_samples=n_samples,
                                                    seed=solver_config.seed))
    nlp_cost, sampled_cost, statuses = [], [], []
    for state, world, goal in cycles:
        plan = nlp.plan(state, world, goal, dock=False)
        reference = sampler.plan(state, world, goal, dock=False)
        nlp_cost.append(plan.fun)
        sampled_cost.append(reference.fun)
        statuses.append(plan.status)
    nlp_cost, sampled_cost = np.array(nlp_cost, dtype=float), np.array(sampled_cost, dtype=float)
    return CrosscheckResult(nlp_cost, sampled_cost, nlp_cost - sampled_cost, tuple(statuses),
                            tol)
