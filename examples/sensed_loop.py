"""A robot loop that plans from what it senses: a lidar scan into the local map, people
detections into the tracker, and ``Planner.plan`` on the result.

Your robot gives the scans, the detections and its pose; here a tiny stand-in world makes them
(a wall and one walker), so the script runs anywhere. Only the product's public calls are used:
``LocalMap.update`` / ``LocalMap.grid``, ``PeopleTracker.update`` / ``PeopleTracker.obstacles``
and ``Planner.plan``.
"""

import math

import numpy as np

from dsmpepc_nlp import Planner, PlannerConfig, RobotState, SolverConfig, World
from dsmpepc_nlp.perception import (
    Detections,
    LaserScan,
    LocalMap,
    LocalMapConfig,
    PeopleTracker,
)

PERIOD = 0.2                                # s, the planner's control period
BEAMS = np.linspace(-2.356, 2.356, 720)     # a 270-degree, 720-beam lidar
WALL_Y = 1.5                                # a wall along y = 1.5 m, the stand-in world's


def fake_scan(pose, walker, t):
    """What a lidar at ``pose`` would return: the wall, the walker's disc, else no return."""
    ranges = np.full(BEAMS.size, np.inf)
    for i, angle in enumerate(pose[2] + BEAMS):
        direction = np.array([math.cos(angle), math.sin(angle)])
        if direction[1] > 1e-9:
            ranges[i] = (WALL_Y - pose[1]) / direction[1]
        rel = walker - pose[:2]
        along = rel @ direction
        miss = rel @ rel - along**2
        if along > 0 and miss < 0.3**2:
            ranges[i] = min(ranges[i], along - math.sqrt(0.3**2 - miss))
    ranges[ranges > 30.0] = np.inf
    return LaserScan(ranges, angle_min=-2.356, angle_increment=BEAMS[1] - BEAMS[0],
                     range_min=0.1, range_max=30.0, pose=tuple(pose), stamp=t)


def main():
    planner = Planner(PlannerConfig(), SolverConfig.sampling())   # SolverConfig(): IPOPT
    local_map = LocalMap(LocalMapConfig(size=12.0, resolution=0.05))
    tracker = PeopleTracker()
    rng = np.random.default_rng(0)
    state, goal = np.array([0.0, 0.0, 0.0, 0.0, 0.0]), np.array([6.0, 0.0])
    for k in range(40):
        t = k * PERIOD
        walker = np.array([5.0 - 0.6 * t, -0.4])
        local_map.update(fake_scan(state[:3], walker, t))
        tracker.update(Detections(walker[None] + rng.normal(0.0, 0.05, (1, 2)), t))
        world = World(local_map.grid(), tracker.obstacles(now=t))
        plan = planner.plan(RobotState(*state), world, goal, goal_tolerance=0.3)
        v, omega = plan.control
        x, y, phi = state[:3]
        state = np.array([x + v * PERIOD * math.cos(phi), y + v * PERIOD * math.sin(phi),
                          phi + omega * PERIOD, v, omega])
        if np.hypot(*(state[:2] - goal)) < 0.3:
            break
    print(f"{t:.1f} s: at ({state[0]:.2f}, {state[1]:.2f}) m, {len(tracker.obstacles())} "
          f"person tracked, last plan {plan.status}")


if __name__ == "__main__":
    main()
