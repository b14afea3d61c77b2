"""The crowded demonstration scene: a walled 16 x 12 m map with blocks and 12 pedestrians.

One fixed, seeded scene on which the planners are timed (``dsmpepc bench``) and cross-checked
cycle by cycle: harder than an open field (walls, a pillar, a block, pedestrians in every
direction) and small enough that a cycle costs milliseconds.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.control_law import arc_step
from ..core.solver_config import SolverConfig
from ..core.world import DynamicObstacle, OccupancyGrid, World
from ..solve.planner import Planner


def demo_world(rng: np.random.Generator, n_pedestrians: int = 12) -> tuple:
    """A 16 m x 12 m map with walls and blocks, and pedestrians at constant velocity.

    Returns ``(world, start_state, goal)``.
    """
    resolution = 0.1
    occupied = np.zeros((120, 160), dtype=bool)
    occupied[:2, :] = occupied[-2:, :] = True            # outer walls, y = 0 and y = 12 m
    occupied[:, :2] = occupied[:, -2:] = True            # x = 0 and x = 16 m
    occupied[40:80, 50:54] = True                         # a pillar wall at x = 5 m
    occupied[20:45, 95:120] = True                        # a block
    occupied[85:89, 90:140] = True                        # a wall at y = 8.5 m
    grid = OccupancyGrid(occupied, resolution, (0.0, 0.0))
    pedestrians = []
    while len(pedestrians) < n_pedestrians:
        position = rng.uniform([1.0, 1.0], [15.0, 11.0])
        if grid.distance(position[None])[0] < 0.6 or np.hypot(*(position - [1.5, 6.0])) < 2.0:
            continue
        heading = rng.uniform(-math.pi, math.pi)
        speed = rng.uniform(0.3, 0.9)
        pedestrians.append(DynamicObstacle.pedestrian(
            position, speed * np.array([math.cos(heading), math.sin(heading)]), radius=0.3))
    return World(grid, pedestrians), RobotState(1.5, 6.0, 0.0), np.array([14.5, 6.0])


def _advance(world: World, dt: float, bounds) -> World:
    """Pedestrians moved by velocity * dt, bouncing off the map's outer box."""
    moved = []
    xmin, ymin, xmax, ymax = bounds
    for obstacle in world.obstacles:
        centers = obstacle.centers + dt * obstacle.velocity
        velocity = np.array(obstacle.velocity)
        for axis, (low, high) in enumerate(((xmin + 0.5, xmax - 0.5), (ymin + 0.5, ymax - 0.5))):
            if not low <= centers[0, axis] <= high:
                velocity[axis] = -velocity[axis]
                centers[:, axis] = np.clip(centers[:, axis], low, high)
        moved.append(dataclasses.replace(obstacle, centers=centers, velocity=velocity))
    return world.with_obstacles(moved)


def demo_cycles(config: PlannerConfig, n_cycles: int, seed: int = 0,
                n_samples: int = 1024) -> list:
    """Cycles ``(state, world, goal)`` of the crowded scene (map + 12 pedestrians).

    The robot executes the first control of a sampling plan (``n_samples`` samples) each cycle;
    pedestrians move at constant velocity. Deterministic for a given ``seed``.
    """
    rng = np.random.default_rng(seed)
    world, state, goal = demo_world(rng)
    # No deadline: the scene's states are the same however fast this machine plans.
    planner = Planner(config, SolverConfig.sampling(n_samples=n_samples, seed=seed,
                                                    time_budget=None))
    dt = config.horizon.dt
    cycles = []
    for _ in range(n_cycles):
        cycles.append((state, world, goal))
        plan = planner.plan(state, world, goal)
        v, omega = plan.control
        x, y, phi = arc_step(state.pose, v, omega, dt)
        state = RobotState(float(x), float(y), float(phi), v, omega)
        world = _advance(world, dt, world.grid.bounds)
    return cycles
