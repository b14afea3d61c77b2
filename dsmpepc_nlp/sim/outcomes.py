"""Per-robot outcomes of the closed loop (docs/method.md section 7.3) as pure functions.

The loop measures (overlaps, distance to the goal, progress) and these functions decide; so the
rules can be tested on numbers, without running an episode.

``collision``
    Any overlap of the robot's footprint with the map, a pedestrian, another robot or a parked
    robot. Checked first.
``success``
    Fixed goal: the reference point within the goal's tolerance. Follow goal (a moving target):
    decided when the duration ends, at most ``distance + tolerance`` behind the pedestrian.
``deadlock``
    Not at the goal and less than ``OutcomeConfig.deadlock_progress`` of progress over the
    last ``OutcomeConfig.deadlock_window``. Progress toward a fixed goal is the decrease of the
    robot's own navigation function; toward a moving goal (whose navigation function changes
    every cycle) it is the path length driven.
``timeout``
    The duration ended first (a follow goal: ending too far behind).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.validation import check_booleans, validate_fields

OUTCOMES = ("success", "collision", "deadlock", "timeout")
"""Per-robot outcomes (docs/method.md section 7.3)."""


@dataclass(frozen=True)
class OutcomeConfig:
    """The numbers of the outcome rules (docs/method.md section 7.3; ours: the paper names
    deadlocks but gives no test)."""

    deadlock: bool = True
    """Apply the deadlock rule; False: a stalled robot runs on until the duration ends (a
    protocol without that rule, such as CrowdNav's, calls it a timeout)."""
    deadlock_window: float = 10.0
    """Seconds over which progress is measured for ``deadlock``."""
    deadlock_progress: float = 0.1
    """Less progress than this (m) over the window is a deadlock."""

    def __post_init__(self):
        check_booleans(self, ("deadlock",))
        validate_fields(self, {"deadlock_window": dict(low=0.0, low_open=True),
                                "deadlock_progress": dict(low=0.0)})


def window_progress(history, window: int, kind: str) -> float | None:
    """Progress (m) over the last ``window`` cycles, None while fewer have passed.

    Parameters
    ----------
    history : sequence of float
        One value per state so far: the navigation-function value at the robot (``kind ==
        "fixed"``, progress is its decrease) or the cumulative path length (``"follow"``).
    window : int
        Cycles in the deadlock window (``round(OutcomeConfig.deadlock_window / dt)``).
    kind : str
        ``"fixed"`` or ``"follow"``.
    """
    if len(history) <= window:
        return None
    if kind == "fixed":
        return history[-1 - window] - history[-1]
    return history[-1] - history[-1 - window]


def outcome(t: float, duration: float, *, kind: str, collided: bool, near: bool,
            progress: float | None, rules: OutcomeConfig = OutcomeConfig()) -> str | None:
    """The outcome decided at time ``t`` for a robot without one yet, or None (keep going).

    Parameters
    ----------
    t, duration : float
        Current time and the scenario's duration, s.
    kind : str
        ``"fixed"`` or ``"follow"`` goal.
    collided : bool
        The footprint overlaps something now.
    near : bool
        Fixed goal: within its tolerance. Follow goal: within ``distance + tolerance`` of the
        followed pedestrian.
    progress : float or None
        :func:`window_progress` (None: the window has not passed yet).
    rules : OutcomeConfig
        The deadlock rule's numbers (its switch is applied by the caller, which passes
        ``progress=None`` when it is off).
    """
    stalled = progress is not None and progress < rules.deadlock_progress
    ended = t >= duration - 1e-9
    if collided:
        return "collision"
    if kind == "fixed":
        if near:
            return "success"
        if stalled:
            return "deadlock"
        return "timeout" if ended else None
    if ended:
        return "success" if near else "timeout"
    if not near and stalled:
        return "deadlock"
    return None


def footprint_gap(points_a, radii_a, points_b, radii_b) -> float:
    """Smallest gap between two sets of circles, m (negative: overlap; inf if one is empty)."""
    if len(points_a) == 0 or len(points_b) == 0:
        return math.inf
    d = np.linalg.norm(np.asarray(points_a)[:, None, :] - np.asarray(points_b)[None, :, :],
                       axis=-1)
    return float(np.min(d - np.asarray(radii_a)[:, None] - np.asarray(radii_b)[None, :]))
