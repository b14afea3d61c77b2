"""The verdicts: from what the search found to the plan. Every NLP start's result costed
exactly (:func:`verify`), the best of them (:func:`choose_nlp`) or of the sampler's rows
(:func:`from_evaluation`) made a :class:`~.plan.Plan` with its status and message
(:func:`plan_from`)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.config import PlannerConfig
from ..core.deadline import Deadline
from .exact.evaluator import Evaluation, Evaluator
from .optimize.multistart import SOLVES
from .plan import Plan
from .start_state import law_control, stop_plan


def verify(original, evaluator: Evaluator) -> tuple:
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
                 else dataclasses.replace(r, exact_cost=costs.get(id(r), math.nan))
                 for r in original)


def choose_nlp(records, evaluator: Evaluator, deadline: Deadline, config: PlannerConfig,
               nlp) -> Plan | None:
    """The best record by exact cost; with the solves cut by the deadline, whatever it is (a
    screened start is a candidate like any other), status ``deadline``. None when no record
    is usable (the sampler takes over). ``config``: the planner's (the robot's limits bound
    the command). ``nlp``: the NLP solver that made the records (while
    its ``kernel_loading``, it ran without its screen and polish: the message says so)."""
    usable = [r for r in records if math.isfinite(r.exact_cost)]
    cut = SOLVES in deadline.cut
    if not usable or not (cut or any(r.success for r in usable)):
        return None
    best = min(usable, key=lambda r: r.exact_cost)
    ev = evaluator.evaluate(best.z)       # read back from the batch that costed it
    nit = sum(r.nit for r in records)
    message = f"NLP: best of {len(records)} starts is '{best.name}' ({best.status})" + (
        "; no screen of the box, no polish: the compiled exact kernel is loading"
        if nlp.kernel_loading else "")
    if cut:
        return plan_from(ev, 0, "deadline", False, "the time budget cut the NLP's "
                         f"solves: {message[5:]}", nit, records, config)
    return plan_from(ev, 0, "nlp", True, message, nit, records, config)


def from_evaluation(evaluated: Evaluation, state, config: PlannerConfig, *, fallback: bool,
                    records, compiling: str = "", cut: bool = False) -> Plan:
    """The sampler's best row as the plan: while a library compiles (``compiling``, what),
    after every NLP start failed (``fallback``), cut by the deadline (``cut``) or as the
    chosen solver; the stop trajectory when no row is finite."""
    index = evaluated.best()
    if index is None:
        return stop_plan(state, records, config)
    if compiling:
        return plan_from(evaluated, index, "sampling-compiling", True,
                         f"{compiling}: best of {len(evaluated.z)} sampled trajectories used",
                         0, (), config)
    if fallback:
        return plan_from(evaluated, index, "sampling-fallback", False,
                         "every NLP start failed; best sampled trajectory used",
                         sum(r.nit for r in records), records, config)
    if cut:
        return plan_from(evaluated, index, "deadline", False, "the time budget cut the "
                         f"sampler: best of the {len(evaluated.z)} sampled trajectories "
                         "costed", 0, (), config)
    return plan_from(evaluated, index, "sampling", True,
                     f"best of {len(evaluated.z)} sampled trajectories", 0, (), config)


def plan_from(ev: Evaluation, index, status: str, success: bool, message: str, nit: int,
              records, config: PlannerConfig) -> Plan:
    """Row ``index`` of an evaluation as a :class:`Plan`: its z, exact cost, trajectory, the
    law's first command bounded to the robot's limits, its cost breakdown and records."""
    trajectory = ev.trajectories[index]
    return Plan(ev.z[index], float(ev.costs.total[index]), success, message, nit, trajectory,
                law_control(trajectory, config), ev.costs[index], status, tuple(records))
