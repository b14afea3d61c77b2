"""The behaviours beyond the optimiser, as a chain the configuration orders and switches.

``PlannerConfig.behaviours`` names them in order (in the spirit of Nav2's behaviour tree,
without a tree library); each also has the switch and parameters of its own fields:

- ``docking`` runs *instead of* the optimiser: within reach of a fixed goal, the docking
  trajectory when it is safe enough (:func:`.docking.dock`; the ``dock`` argument of
  ``Planner.plan`` and ``PlannerConfig.docking``). The optimiser runs when it finds none.
- ``last-resort`` runs *on* the optimiser's plan: over a plan struck almost surely within the
  second, the way that keeps the widest gap, or where every way touches someone the one that
  drives least toward them (:func:`.last_resort.clearest`; ``stall.doomed_below``,
  ``stall.passive``).
- ``moves`` runs on it too: reverses, dodges and turns in place set against a plan that
  stands, expects to be struck or is stalled, the cheapest by the exact cost when cheaper
  (:func:`.backup.moves`; ``stall.back_up``, ``stall.dodge``, ``stall.turn_to_goal``).

The behaviours that run on the plan take their turn in the configured order and the first that
replaces the plan ends the chain, as a behaviour tree's fallback node. Both act only with the
stall ladder on and the back-up rung's speed above 0 (:func:`enabled`), as they always did.
DS-MPEPC as published (``PlannerConfig.paper``) names docking alone: the method's docking at a
fixed goal (IROS 2012), then the optimiser, and nothing else.
"""

from __future__ import annotations

from functools import cached_property

from ...core.config import PlannerConfig
from ..exact.evaluator import Evaluator
from ..plan import Plan
from . import backup
from .last_resort import clearest
from .ways import Ways

INSTEAD = ("docking",)
"""The behaviours that run instead of the optimiser; every other runs on its plan."""


def enabled(name: str, config: PlannerConfig) -> bool:
    """Whether behaviour ``name`` (one of :data:`~dsmpepc_nlp.core.config.BEHAVIOURS`) can act
    under ``config`` at all: named in ``config.behaviours``, and for those that run on the
    plan, the stall ladder on (``stall.levels``) and the rung's speed above 0
    (``stall.back_up``); the last resort also needs ``stall.doomed_below`` above 0."""
    stall = config.stall
    if name not in config.behaviours:
        return False
    if name in INSTEAD:
        return True
    rung = stall.levels > 0 and stall.back_up > 0.0
    return rung and (name != "last-resort" or stall.doomed_below > 0.0)


def configured(config: PlannerConfig) -> tuple:
    """``(instead, on_plan)``: the names that can act under ``config`` (:func:`enabled`), in
    the configured order, split by where they run."""
    names = [name for name in config.behaviours if enabled(name, config)]
    return (tuple(n for n in names if n in INSTEAD),
            tuple(n for n in names if n not in INSTEAD))


class Recovery:
    """What the behaviours that run on one plan share: the plan, the state, the plan's
    ``evaluator`` (its cycle's world, goal and config), the stall ``level``, the fixed goal's
    ``goal_tolerance`` (m), a docked plan's :func:`.backup.arrival_time` and this cycle's
    :class:`.ways.Ways`, each made once, when first read."""

    def __init__(self, plan: Plan, state, evaluator: Evaluator, level: int,
                 goal_tolerance: float = 0.0):
        self.plan, self.state, self.evaluator = plan, state, evaluator
        self.level, self.goal_tolerance = level, goal_tolerance

    @cached_property
    def arrival(self) -> float:
        cycle = self.evaluator.cycle
        return backup.arrival_time(self.plan, cycle.goal, self.goal_tolerance, cycle.config)

    @cached_property
    def ways(self) -> Ways:
        cycle = self.evaluator.cycle
        return Ways(self.state, cycle.config, cycle.world)


def last_resort(recovery: Recovery) -> Plan | None:
    """The ``last-resort`` behaviour: :func:`.last_resort.clearest` of the recovery's plan."""
    return clearest(recovery.plan, recovery.state, recovery.evaluator, recovery.arrival,
                    recovery.ways)


def moves(recovery: Recovery) -> Plan | None:
    """The ``moves`` behaviour: :func:`.backup.moves` of the recovery's plan."""
    return backup.moves(recovery.plan, recovery.state, recovery.evaluator, recovery.level,
                        recovery.arrival, recovery.ways)


ON_PLAN = {"last-resort": last_resort, "moves": moves}
"""Each behaviour that runs on the plan, by name: ``Recovery -> Plan or None``."""

STAGES = {"last-resort": "the last resort", "moves": "the moves"}
"""Each behaviour's stage name in a plan's message and ``Plan.cut``."""


def recover(plan: Plan, state, evaluator: Evaluator, level: int, goal_tolerance: float = 0.0,
            names=None, run=None) -> Plan | None:
    """The behaviours that run on ``plan``, in order (``names``; default: those its
    evaluator's config enables): the first plan one of them returns, or None (keep ``plan``).
    ``run(stage, behaviour, recovery)``, when given, runs each (``Planner.plan`` runs each as
    a stage under the time budget, named by :data:`STAGES`); by default it is called."""
    names = configured(evaluator.cycle.config)[1] if names is None else names
    recovery = Recovery(plan, state, evaluator, level, goal_tolerance)
    for name in names:
        replaced = (ON_PLAN[name](recovery) if run is None
                    else run(STAGES[name], ON_PLAN[name], recovery))
        if replaced is not None:
            return replaced
    return None
