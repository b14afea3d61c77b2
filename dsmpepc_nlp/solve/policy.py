"""What drives a robot in the closed loop: the planner interface as a ``typing.Protocol``.

:class:`~dsmpepc_nlp.solve.planner.Planner` implements it, and so do the baselines
(:class:`~dsmpepc_nlp.bench.orca.OrcaPlanner`, the constant-velocity
:class:`~dsmpepc_nlp.bench.cv.ConstantVelocityPlanner`), which is how they run in the same
loop. ``prepare`` is optional: the loop calls it when a planner has it.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from ..core.config import PlannerConfig, RobotState
from ..core.world import World
from .plan import Plan


@runtime_checkable
class PlanningPolicy(Protocol):
    """A planner: built from ``(config, solver)``, planning one cycle at a time."""

    config: PlannerConfig

    def plan(self, state: RobotState, world: World, goal, *, dock: bool = True,
             sample: bool = False, goal_tolerance: float = 0.0) -> Plan:
        """The plan from ``state`` toward ``goal`` (a fixed goal docks when ``dock``; the
        task counts arrival within ``goal_tolerance`` m of it)."""
        ...

    def reset(self) -> None:
        """Forget what a previous episode left (warm starts, counters)."""
        ...


__all__ = ["PlanningPolicy"]
