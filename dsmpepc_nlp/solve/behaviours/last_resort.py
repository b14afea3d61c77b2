"""The back-up rung's last resort (``stall.doomed_below``): over a plan struck almost surely
within the next second, where the cost's collision term has saturated for every way near it,
the way that keeps the widest gap over that second, not the cheapest; where every way touches
someone, the one that drives least toward whoever it touches (:mod:`.passive`)."""

from __future__ import annotations

import math

import numpy as np

from ...core.config import PlannerConfig
from ...core.control_law import stacked
from ..exact.evaluator import Evaluator
from ..plan import Plan
from . import passive
from .passive import clearance
from .ways import Ways, back_up_speed, dodge_named, replaced, reverse_named


def survival_within(plan: Plan, config: PlannerConfig, within: float = math.inf) -> float:
    """The plan's survivability at the first step at or after ``within`` seconds, the
    horizon's end ``p^s_N`` when that is later."""
    survival = plan.cost.survivability
    steps = math.ceil(within / config.horizon.dt - 1e-9) if math.isfinite(within) else math.inf
    return float(survival[min(steps, len(survival) - 1)])



CLEARER = 1e-3
"""m: the clearest way replaces a doomed plan only if its gap is wider by more than this (a
millimetre, above round-off)."""



def clearest(plan: Plan, state, evaluator: Evaluator, arrival: float = math.inf,
             ways: Ways | None = None) -> Plan | None:
    """The clearest way out of a doomed ``plan``, or None (keep it; ``stall.doomed_below``);
    gaps measured and the way costed by the plan's ``evaluator``.

    Doomed: the plan's survival over the next ``stall.clearance_within`` seconds (until
    ``arrival``, s, if that is sooner: a docked plan's :func:`.backup.arrival_time`, where the
    task ends, as :class:`.chain.Recovery` reads it) is below ``doomed_below``. Then the plan
    and this cycle's :class:`Ways` (``ways`` if already made) are set by their
    :func:`clearance` over the next ``clearance_within`` seconds instead of their cost, and the
    clearest replaces the plan when its gap is wider; all below 0, the least approaching
    (``stall.passive``)."""
    cycle = evaluator.cycle
    config = cycle.config
    stall = config.stall
    if not stall.doomed_below > 0.0:
        return None
    within = min(stall.clearance_within, arrival)
    survival = survival_within(plan, config, within)
    if survival >= stall.doomed_below:
        return None
    ways = ways or Ways(state, config, cycle.world)
    dodges = ways.dodges
    reverses = [ways.reverses] if back_up_speed(config) > 0.0 and len(ways.reverses) else []
    candidates = stacked([plan.trajectory, dodges, *reverses])
    gaps = clearance(candidates, evaluator, stall.clearance_within)
    gaps = np.where(np.isnan(gaps), -np.inf, gaps)           # a gap not measured keeps nothing
    still = (stall.passive and not np.max(gaps) >= 0.0       # every way touches someone, the
             and clearance(candidates[:1], evaluator, 0.0)[0] >= 0.0)  # start not yet: be still
    if still:                               # at the contact (passive.py), a stop put second
        candidates = stacked([candidates[:1], passive.stopping(state, config), candidates[1:]])
        gaps = np.insert(gaps, 1, clearance(candidates[1:2], evaluator, stall.clearance_within))
        best = passive.least_approaching(candidates, gaps, evaluator, stall.clearance_within)
        if best == 0:
            return None             # the plan is as still as any: the rung goes on by the cost
    else:
        best = int(np.argmax(gaps))
        if not gaps[best] > gaps[0] + CLEARER:
            return None
    chosen, way = candidates[best], best - 1 if still else best     # way: without the stop
    what = ("braking to a stop" if still and best == 1 else dodge_named(chosen)
            if way <= len(dodges)
            else reverse_named(int(ways.reverse_rows[way - 1 - len(dodges)]), config))
    how = (f"every way touches someone within {stall.clearance_within:g} s: the way that "
           f"drives least toward whoever it touches, {what}" if still else
           f"the clearest way over {stall.clearance_within:g} s, {what}")
    message = (f"the plan is doomed (survival {survival:.2f} < {stall.doomed_below:g} within "
               f"{within:g} s): {how}, keeps {gaps[best]:.2f} m against the plan's "
               f"{gaps[0]:.2f} m; it replaced: {plan.message}")
    cost = evaluator.evaluate_trajectories(chosen)
    return replaced(plan, chosen, cost, message, "clearing", config)
