"""The per-cycle object: everything a plan's evaluators read that does not depend on z.

Built once per :meth:`~dsmpepc_nlp.solve.planner.Planner.plan` (like Nav2 MPPI's
``CriticData``): the robot state, the goal, the dynamic obstacles and their predicted positions
at every pose time, the static map's distance table and the navigation function. The exact
evaluators (numpy and compiled), the screening of the NLP's starts, the sampler, the verdict,
docking and the NLP's parameters all read this one object; nothing is re-derived inside a plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.config import PlannerConfig, RobotState


@dataclass(frozen=True, eq=False)
class Cycle:
    """What one planning cycle knows, prepared once.

    Attributes
    ----------
    config : PlannerConfig
    state : RobotState
    goal : ndarray, (2,)
        Goal position, m.
    world : World
        The world the cycle was prepared from (static grid and obstacles now).
    times : ndarray, (N+1,)
        Time of each pose from the plan's start, s.
    centers, radii, velocities, owner : ndarray
        Every dynamic-obstacle circle, flattened: ``(K, 2)`` m, ``(K,)`` m, ``(K, 2)`` m/s,
        ``(K,)`` index of the circle's object (see ``World.stacked_obstacles``).
    predicted : ndarray, (N+1, K, 2)
        Each circle's centre at each pose time (constant velocity), m.
    navigation : NavigationFunction
        Path length to the goal on the inflated map (Euclidean without a map).
    """

    config: PlannerConfig
    state: RobotState
    goal: np.ndarray
    world: object
    times: np.ndarray
    centers: np.ndarray
    radii: np.ndarray
    velocities: np.ndarray
    owner: np.ndarray
    predicted: np.ndarray
    navigation: object

    @classmethod
    def prepare(cls, state: RobotState, world, goal, config: PlannerConfig) -> Cycle:
        """Derive the cycle's data from ``world`` once (predictions, navigation function)."""
        goal = np.asarray(goal, dtype=float)
        times = np.arange(config.horizon.n_steps + 1) * config.horizon.dt
        centers, radii, velocities, owner = world.stacked_obstacles()
        predicted = centers[None, :, :] + velocities[None, :, :] * times[:, None, None]
        navigation = world.navigation(goal, config.robot.inflation_radius,
                                      near=(state.x, state.y), reach=config.reach)
        return cls(config, state, goal, world, times, centers, radii, velocities, owner,
                   predicted, navigation)

    @property
    def grid(self):
        """The static OccupancyGrid, or None."""
        return self.world.grid
