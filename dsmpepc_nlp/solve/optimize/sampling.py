"""The sampling planner: the exact cost over a fixed low-discrepancy set of z and the named
starts, the best kept. The NLP's verifier and fallback."""

from __future__ import annotations

import time

import numpy as np

from ...core.config import PlannerConfig
from ...core.deadline import Deadline
from ...core.solver_config import SolverConfig
from ..exact.evaluator import Evaluation, Evaluator
from .starts import box_samples


class SamplingPlanner:
    """Exact cost over a fixed low-discrepancy set of z plus the structured starts.

    Parameters
    ----------
    config : PlannerConfig
    solver : SolverConfig
        ``n_samples`` and ``seed`` are read; the sample set is drawn once, here. (The
        evaluator a search is given sets how batches are costed.)
    """

    def __init__(self, config: PlannerConfig, solver: SolverConfig | None = None):
        solver = SolverConfig.sampling() if solver is None else solver
        self.config = config
        self.samples = box_samples(config, solver.n_samples, solver.seed)
        self.pace = None
        """Seconds a row took in the last search (None before the first)."""

    def search(self, evaluator: Evaluator, starts: dict | None = None,
               deadline: Deadline | None = None) -> Evaluation:
        """Evaluate ``starts`` (a dict of named z) and the sample set with the cycle's
        ``evaluator``; see :class:`~dsmpepc_nlp.solve.exact.evaluator.Evaluation`. With a
        ``deadline``: in one batch when the last search's pace says every row fits in half
        the time left, else :data:`CHUNK` rows first, then batches that fit the time left,
        until it passes (stage :data:`STAGE` recorded as cut when rows are left)."""
        extra = np.array(list(starts.values())) if starts else np.zeros((0, 4))
        rows = np.vstack([extra, self.samples])
        began = time.perf_counter()
        if deadline is None or (self.pace is not None
                                and self.pace * len(rows) < 0.5 * deadline.left()):
            evaluation = evaluator.evaluate(rows)
        else:
            evaluation = evaluator.evaluate_within(rows, deadline, CHUNK, STAGE)
        self.pace = (time.perf_counter() - began) / max(1, len(evaluation.z))
        return evaluation


CHUNK = 512
"""Rows the sampler costs first, before it looks at the plan's deadline (~3-5 ms on the demo
scene); the next batches are sized by their pace (:meth:`.Evaluator.evaluate_within`)."""

STAGE = "the sampler"
"""The stage a deadline cuts when the sampler's rows are not all costed."""
