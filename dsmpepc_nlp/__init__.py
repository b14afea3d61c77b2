"""DS-MPEPC local navigation as a CasADi nonlinear program, with an exact sampling verifier."""

from .config import (
    BoundsConfig,
    ControlLawConfig,
    CostConfig,
    DockingConfig,
    HorizonConfig,
    PlannerConfig,
    RobotConfig,
    RobotState,
    SmoothingConfig,
    SolverConfig,
)
from .control_law import Trajectory, rollout, rollout_function
from .costs import CostBreakdown, evaluate
from .planner import Plan, Planner, StartRecord
from .world import DynamicObstacle, NavigationFunction, OccupancyGrid, World

__all__ = [
    "BoundsConfig", "ControlLawConfig", "CostBreakdown", "CostConfig", "DockingConfig",
    "DynamicObstacle", "HorizonConfig", "NavigationFunction", "OccupancyGrid", "Plan", "Planner",
    "PlannerConfig", "RobotConfig", "RobotState", "SmoothingConfig", "SolverConfig",
    "StartRecord", "Trajectory", "World", "evaluate", "rollout", "rollout_function",
]
