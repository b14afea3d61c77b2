"""What a scenario is made of: robots (agents) with goals, pedestrians, parked robots.

Plain frozen data, validated on construction where a wrong value would only fail later in the
loop. They live apart from the loop (``simulate.py``) and the YAML reader (``scenario.py``) so
both, and the benchmarks that build scenarios in code (BARN, ETH/UCY), import them without
importing each other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.config import RobotConfig, RobotState
from ..core.errors import InputError, shown
from ..core.world import OccupancyGrid


@dataclass(frozen=True)
class Pedestrian:
    """A scripted pedestrian: timestamped waypoints or a constant velocity.

    Attributes
    ----------
    times : ndarray, (K,)
        Strictly increasing waypoint times, s. With one waypoint the pedestrian moves at
        ``velocity`` from it forever.
    positions : ndarray, (K, 2)
        Waypoint positions, m. Before the first time the pedestrian waits at the first one,
        after the last at the last one.
    velocity : ndarray, (2,)
        Constant velocity (m/s), used only when K == 1.
    radius : float
        Body radius, m.
    """

    times: np.ndarray
    positions: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(2))
    radius: float = 0.3

    def __post_init__(self):
        times = np.atleast_1d(np.asarray(self.times, dtype=float))
        positions = np.atleast_2d(np.asarray(self.positions, dtype=float))
        velocity = np.asarray(self.velocity, dtype=float)
        if times.ndim != 1 or positions.shape != (times.size, 2) or times.size < 1:
            raise InputError(f"Pedestrian: times {times.shape} and positions {positions.shape}: "
                             "must be (K,) and (K, 2) with K >= 1")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(positions))
                and velocity.shape == (2,) and np.all(np.isfinite(velocity))):
            raise InputError("Pedestrian: times, positions and velocity must be finite")
        if np.any(np.diff(times) <= 0):
            raise InputError(f"Pedestrian.times = {times.tolist()}: must be strictly increasing")
        if not (math.isfinite(self.radius) and self.radius > 0):
            raise InputError(f"Pedestrian.radius = {shown(self.radius)}: must be finite and > 0")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "velocity", velocity)

    @classmethod
    def constant(cls, position, velocity, radius=0.3) -> Pedestrian:
        """Starts at ``position`` (m) at t = 0 and keeps ``velocity`` (m/s)."""
        return cls(np.zeros(1), np.reshape(position, (1, 2)), np.asarray(velocity), radius)

    def position(self, t: float) -> np.ndarray:
        """Position at time ``t`` (s), m, shape (2,)."""
        if self.times.size == 1:
            return self.positions[0] + (t - self.times[0]) * self.velocity
        return np.array([np.interp(t, self.times, self.positions[:, i]) for i in range(2)])

    def velocity_at(self, t: float) -> np.ndarray:
        """Current velocity (m/s): the slope of the waypoint segment holding ``t``."""
        if self.times.size == 1:
            return self.velocity.copy()
        if t < self.times[0] or t >= self.times[-1]:
            return np.zeros(2)
        k = int(np.searchsorted(self.times, t, side="right")) - 1
        span = self.times[k + 1] - self.times[k]
        return (self.positions[k + 1] - self.positions[k]) / span


@dataclass(frozen=True)
class FixedGoal:
    """A goal position (m); reached within ``tolerance`` (m). Docked near it."""

    position: tuple
    tolerance: float = 0.25

    @property
    def kind(self) -> str:
        return "fixed"


@dataclass(frozen=True)
class FollowGoal:
    """Follow pedestrian ``pedestrian`` (index) at ``distance`` (m); docked at only with
    ``DockingConfig.follow`` (the product's default, off in the paper preset).

    The goal each cycle is the pedestrian's position pulled back toward the robot by
    ``distance``. ``tolerance`` (m) is how much farther than ``distance`` the robot may end up.
    """

    pedestrian: int
    distance: float = 1.0
    tolerance: float = 1.0

    @property
    def kind(self) -> str:
        return "follow"


@dataclass(frozen=True)
class Agent:
    """A planning robot: its name, start state, goal and body (None: the config's robot)."""

    name: str
    start: RobotState
    goal: FixedGoal | FollowGoal
    robot: RobotConfig | None = None


@dataclass(frozen=True)
class ParkedRobot:
    """A robot that never moves (a dynamic obstacle of kind ``robot`` with zero velocity)."""

    pose: tuple
    footprint: tuple


@dataclass(frozen=True)
class Scenario:
    """Everything the simulator needs, already validated (see ``scenario.py`` for the YAML).

    ``start_noise`` (m) is the standard deviation of a seeded Gaussian perturbation of every
    agent's start position; ``map_path`` only records where ``grid`` came from.
    """

    name: str
    agents: tuple
    grid: OccupancyGrid | None = None
    pedestrians: tuple = ()
    parked: tuple = ()
    duration: float = 30.0
    start_noise: float = 0.0
    map_path: str | None = None
    description: str = ""
