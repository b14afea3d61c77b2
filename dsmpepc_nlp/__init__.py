"""DS-MPEPC local navigation as a CasADi nonlinear program, with an exact sampling verifier."""

from ._version import __version__
from .core.config import (
    BoundsConfig,
    ControlLawConfig,
    DockingConfig,
    HorizonConfig,
    PlannerConfig,
    RobotConfig,
    RobotState,
    StallConfig,
)
from .core.control_law import Trajectory, rollout, rollout_function
from .core.cost_config import CostConfig, SmoothingConfig
from .core.errors import InputError
from .core.exact_cost import CostBreakdown, evaluate
from .core.solver_config import (
    LocalSolverSettings,
    MultistartSettings,
    ParallelSettings,
    PolishSettings,
    SolverConfig,
)
from .core.world import DynamicObstacle, NavigationFunction, OccupancyGrid, World
from .solve.plan import StartRecord
from .solve.planner import Plan, Planner

__all__ = [
    "BoundsConfig", "ControlLawConfig", "CostBreakdown", "CostConfig", "DockingConfig",
    "DynamicObstacle", "HorizonConfig", "InputError", "LocalSolverSettings", "MultistartSettings",
    "NavigationFunction", "OccupancyGrid", "ParallelSettings", "Plan", "Planner", "PlannerConfig",
    "PolishSettings", "RobotConfig", "RobotState", "SmoothingConfig",
    "SolverConfig", "StallConfig", "StartRecord", "Trajectory", "World", "__version__",
    "evaluate", "rollout", "rollout_function",
]
