"""A plan's deadline: when its time budget ends, and which stages it cut short.

A :class:`Deadline` is made at the start of :meth:`~dsmpepc_nlp.solve.planner.Planner.plan`
from the solver's time budget (:func:`budget_seconds`); each stage that can stop early asks
:meth:`Deadline.check` before its next piece of work (an IPOPT solve is given the time left as
its own wall-time limit), and the plan says which stages the budget cut.
"""

from __future__ import annotations

import math
import os
import threading
import time

from .errors import InputError

BUDGET_SHARE = 0.75
"""The default time budget as a share of the control period (``HorizonConfig.dt``): a plan
by three quarters of the period leaves a quarter for perception and for sending the command."""

MAX_BUDGET = 0.2
"""s: the default budget is never longer than this, whatever the period."""

AUTO = "auto"
"""``SolverConfig.time_budget``'s default: :data:`BUDGET_SHARE` of the control period, at most
:data:`MAX_BUDGET`."""


BUDGET_VARIABLE = "DSMPEPC_TIME_BUDGET"
"""The environment variable that decides what ``"auto"`` (the default budget) means: ``none``
or seconds; unset or ``auto``, :data:`BUDGET_SHARE` of the period. The test suite sets
``none``, so that no test's outcome depends on how loaded the machine is (the tests of the
deadline give their budgets themselves)."""


BUDGET_TEXT = "auto, none or a number of seconds > 0"
"""What a budget written as text (the command line's, :data:`BUDGET_VARIABLE`'s) may be."""


def budget_from_text(text: str):
    """A budget written as text: ``"auto"``, None for ``none``, or seconds > 0; ValueError for
    anything else (:data:`BUDGET_TEXT`)."""
    word = str(text).strip().lower()
    if word in (AUTO, "none"):
        return None if word == "none" else AUTO
    try:
        seconds = float(word)
    except ValueError:
        seconds = math.nan
    if not seconds > 0.0:
        raise ValueError(f"{text!r}: must be {BUDGET_TEXT}")
    return seconds


def _auto_seconds(period: float) -> float:
    """What ``"auto"`` means now (:data:`BUDGET_VARIABLE`), in seconds; InputError naming the
    variable for a value that is not a budget."""
    try:
        budget = budget_from_text(os.environ.get(BUDGET_VARIABLE, AUTO))
    except ValueError as error:
        raise InputError(f"${BUDGET_VARIABLE} = {error}") from None
    if budget == AUTO:
        return min(BUDGET_SHARE * float(period), MAX_BUDGET)
    return math.inf if budget is None else budget


def budget_seconds(budget, period: float) -> float:
    """Seconds of a time budget: ``"auto"`` is :data:`BUDGET_SHARE` of ``period`` (at most
    :data:`MAX_BUDGET`; :data:`BUDGET_VARIABLE` may say otherwise), None is no deadline (inf),
    a number is itself."""
    if budget is None:
        return math.inf
    if budget == AUTO:
        return _auto_seconds(period)
    return float(budget)


BUDGET_ALLOWED = "'auto', None (no deadline) or a number of seconds > 0"
"""What a time budget may be, for messages."""


def is_budget(budget) -> bool:
    """True for a time budget: ``"auto"``, None, or a number of seconds > 0 (inf allowed)."""
    if budget is None or budget == AUTO:
        return True
    if isinstance(budget, (bool, str)):
        return False
    try:
        return float(budget) > 0.0      # NaN is not
    except (TypeError, ValueError):
        return False


class Deadline:
    """The end of a plan's time budget, on ``time.perf_counter``'s clock.

    Parameters
    ----------
    seconds : float
        The budget (inf: no deadline).
    started : float, optional
        When the plan started (default: now).

    Attributes
    ----------
    cut : list of str
        The stages the budget cut short or skipped, in the order they found it spent.
    """

    def __init__(self, seconds: float = math.inf, started: float | None = None):
        self.seconds = float(seconds)
        self.started = time.perf_counter() if started is None else float(started)
        self.at = self.started + self.seconds
        self.cut = []
        self._lock = threading.Lock()

    def left(self) -> float:
        """Seconds left (inf without a deadline; negative once it has passed)."""
        return self.at - time.perf_counter()

    def check(self, stage: str, need: float = 0.0) -> bool:
        """True while time is left (at least ``need`` seconds: a stage that cannot stop once
        started asks for what it is expected to take); else False, and ``stage`` is recorded
        as cut (once)."""
        if time.perf_counter() + need < self.at:
            return True
        with self._lock:
            if stage not in self.cut:
                self.cut.append(stage)
        return False

    def extend(self, seconds: float) -> None:
        """Move the deadline ``seconds`` later: time a plan spent building what
        :meth:`~dsmpepc_nlp.solve.planner.Planner.prepare` would have built ahead (a library
        loaded or compiled in the plan, a solver's instances) is not counted."""
        self.at += max(0.0, float(seconds))

    def spent(self, stage: str) -> None:
        """Record ``stage`` as cut by the budget (a solver that stopped at its wall limit)."""
        with self._lock:
            if stage not in self.cut:
                self.cut.append(stage)


__all__ = ["AUTO", "BUDGET_ALLOWED", "BUDGET_SHARE", "BUDGET_VARIABLE", "MAX_BUDGET", "Deadline",
           "budget_from_text", "budget_seconds", "is_budget"]
