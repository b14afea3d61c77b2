"""The stall ladder's back-up rung: moves the pose-following law cannot make (the ``moves``
behaviour of :mod:`.chain`).

The law turns only while it drives forward (its turn rate is the curvature times the speed),
so a robot that stands facing a person just ahead has no trajectory of its own that does not
first close the gap: every one costs more than standing, and the robot waits for as long as the
person stands (docs/experiments/2026-11-25-two-more-failure-classes.md). In the spirit of Nav2's
back-up recovery, when the chosen plan would stand and the stall ladder is at
``StallConfig.back_up_level`` or above (1 by default: stalled), or the robot expects to be
struck where the plan leaves it (``StallConfig.back_up_threat``), :func:`moves` sets a few
reverse trajectories against it, costed by the same exact cost through the plan's evaluator
(``Evaluator.evaluate_trajectories``), and takes the cheapest when it is cheaper than the plan.
``StallConfig.back_up`` (m/s; 0 = off) and ``back_up_time``; docs/method.md section 7.5. With
them come forward dodges against a plan the robot expects to be struck on
(``StallConfig.dodge``) and, once stalled, turns in place each followed by the law
(``StallConfig.turn_to_goal``). The rung's last resort is :mod:`.last_resort`.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.config import PlannerConfig
from ...core.control_law import stacked
from ..exact.evaluator import Evaluator
from ..plan import Plan
from . import docking
from .last_resort import survival_within
from .ways import (
    Ways,
    back_up_speed,
    dodge_named,
    replaced,
    reverse_named,
    turn_named,
    turn_trajectories,
)


def stands(plan: Plan, config: PlannerConfig) -> bool:
    """Whether ``plan`` gets less far than the stall window's least displacement over its
    whole horizon (it would stand, or all but)."""
    poses = plan.trajectory.poses
    path = float(np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T)))
    return path < config.stall.min_displacement


def threatened(plan: Plan, config: PlannerConfig, within: float = math.inf) -> bool:
    """Whether the robot expects to be struck on ``plan`` within ``within`` seconds (the
    horizon's end by default): the plan's survival then is below ``stall.back_up_threat``
    (never when that is 0)."""
    return survival_within(plan, config, within) < config.stall.back_up_threat


def arrival_time(plan: Plan, goal, goal_tolerance: float, config: PlannerConfig) -> float:
    """s: when a docked ``plan`` first comes within ``goal_tolerance`` of a fixed ``goal``
    with ``stall.threat_until_arrival`` (the task ends there); otherwise, or when it never
    does, infinity (the gate reads the horizon's end)."""
    if not (config.stall.threat_until_arrival and plan.status == "docked"):
        return math.inf
    step = docking.arrival_step(plan.trajectory.poses, goal, goal_tolerance)
    return math.inf if step is None else step * config.horizon.dt


def moves(plan: Plan, state, evaluator: Evaluator, level: int, arrival: float = math.inf,
          ways: Ways | None = None) -> Plan | None:
    """The rung's moves against ``plan``, or None (keep it), every way costed by the plan's
    ``evaluator`` (its cycle's world, goal and config): reverse trajectories when the plan
    stands and the ladder is at ``back_up_level`` or above or the plan is :func:`threatened`;
    forward dodges (``stall.dodge``) when it is threatened, standing or not; turns in place
    (``stall.turn_to_goal``, :func:`turn_trajectories`) when the ladder is at ``turn_level``
    or above and the plan is not docked. A docked plan's threat is read at ``arrival`` (its
    :func:`arrival_time`, s). The cheapest of them by the exact cost replaces the plan if it
    is cheaper. ``ways``: this cycle's :class:`Ways` if already made (the chain's
    :class:`~.chain.Recovery` shares them with the last resort)."""
    cycle = evaluator.cycle
    config = cycle.config
    stall = config.stall
    ways = ways or Ways(state, config, cycle.world)
    threat = threatened(plan, config, arrival)
    stalled = level >= stall.back_up_level
    reverse = (back_up_speed(config) > 0.0 and stands(plan, config) and (stalled or threat)
               and len(ways.reverses) > 0)
    dodge = stall.dodge and threatened(plan, config, min(stall.dodge_within, arrival))
    # A docked plan already heads for the goal, turning in place first where it must.
    turn = (level >= stall.turn_level and stall.turn_to_goal > 0.0
            and plan.status != "docked")
    sets = ([("reverse", ways.reverses)] if reverse else []) + (
        [("dodge", ways.dodges)] if dodge else []) + (
        [("turn", turn_trajectories(plan, state, cycle.goal, config))] if turn else [])
    if not sets:
        return None
    candidates = stacked([t for _, t in sets])
    costs = evaluator.evaluate_trajectories(candidates)
    total = np.where(np.isfinite(costs.total), costs.total, np.inf)
    best = int(np.argmin(total))
    if not total[best] < plan.fun:
        return None
    chosen = candidates[best]
    ends = np.cumsum([len(t.z) for _, t in sets])
    which = int(np.searchsorted(ends, best, side="right"))      # the set it came from
    kind, first = sets[which][0], best - (int(ends[which - 1]) if which else 0)
    if kind == "turn":
        off = abs(float(docking.off_the_line(state.pose, cycle.goal)))
        why = f"stalled, facing {off:.2f} rad away from the goal"
        name = turn_named(first, chosen, plan)
        what = (f"turning in place {name}, then heading to "
                f"{'it' if name.startswith('toward') else 'the goal'}")
    elif kind == "reverse" and stalled:
        why = "stalled and the plan stood"
    else:
        within = arrival if kind == "reverse" else min(stall.dodge_within, arrival)  # as read
        soon = f" within {within:g} s" if within < config.horizon.duration else ""
        why = (f"the plan {'stood' if stands(plan, config) else 'went'} where it expects to be "
               f"struck{soon} (survival {survival_within(plan, config, within):.2f} < "
               f"{stall.back_up_threat:g})")
    if kind == "reverse":
        what = reverse_named(int(ways.reverse_rows[first]), config)
    elif kind == "dodge":
        what = dodge_named(chosen)
    message = (f"{why} (exact cost {plan.fun:.3f}): {what} (exact cost {total[best]:.3f}); "
               f"it replaced: {plan.message}")
    status = {"reverse": "backing-up", "dodge": "dodging", "turn": "turning"}[kind]
    return replaced(plan, chosen, costs[best], message, status, config)


