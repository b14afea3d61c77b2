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
)
from .control_law import Trajectory, rollout, rollout_function

__all__ = [
    "BoundsConfig", "ControlLawConfig", "CostConfig", "DockingConfig", "HorizonConfig",
    "PlannerConfig", "RobotConfig", "RobotState", "SmoothingConfig", "Trajectory", "rollout",
    "rollout_function",
]
