"""Far goals by design (issue 14): the navigation window stays bounded and the robot progresses."""

import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import OccupancyGrid, World
from dsmpepc_nlp.sim.simulate import simulate
from dsmpepc_nlp.sim.types import Agent, FixedGoal, Scenario
from dsmpepc_nlp.solve.planner import Planner


def small_map():
    """2 x 2 m at 0.05 m with a short wall."""
    occupied = np.zeros((40, 40), dtype=bool)
    occupied[30:32, 10:30] = True     # y in [1.5, 1.6], x in [0.5, 1.5]
    return OccupancyGrid(occupied, 0.05)


def test_far_goal_window_is_as_small_as_a_near_one():
    world = World(small_map())
    config = PlannerConfig()
    near = (0.5, 0.5)
    sizes = [world.navigation(goal, 0.3, near=near, reach=config.reach).values.size
             for goal in ((10.0, 1.0), (1.0e4, 1.0), (-3.0e5, 1.0e6))]
    assert len(set(sizes)) == 1          # one robot box whatever the distance
    side = 2 * (math.ceil(config.reach / 0.05) + 1) + 26
    assert sizes[0] <= side * side


def test_robot_drives_toward_a_goal_1_km_away_and_leaves_the_map_behind():
    world = World(small_map())
    config = PlannerConfig()
    planner = Planner(config, SolverConfig.sampling(n_samples=128))
    goal = np.array([1000.0, 0.5])
    state = RobotState(0.3, 0.5, 0.0)
    start_distance = math.dist(state.pose[:2], goal)
    dt = config.horizon.dt
    for _ in range(50):
        plan = planner.plan(state, world, goal)
        assert plan.status == "sampling"
        x, y, phi = plan.trajectory.poses[1]
        state = RobotState(x, y, phi, *plan.control)
    assert state.x > 2.0 + 2.0 + 1.0                       # past the map and its margin
    assert math.dist(state.pose[:2], goal) < start_distance - 0.5 * 50 * dt * config.robot.v_limit


def test_a_simulated_robot_driving_to_a_far_goal_is_not_called_deadlocked():
    # The deadlock rule measures progress on the navigation function; on the map's window
    # alone a robot that left the map toward a far goal seemed to lose ground and was stopped
    # as "deadlock" after 10 s, about 10 m out.
    from dsmpepc_nlp.sim.simulate import simulate
    from dsmpepc_nlp.sim.types import Agent, FixedGoal, Scenario

    scenario = Scenario("far", (Agent("r", RobotState(0.3, 0.5, 0.0), FixedGoal((1000.0, 0.5))),),
                        small_map(), duration=16.0)
    episode = simulate(scenario, PlannerConfig(), SolverConfig.sampling(n_samples=128),
                       np.random.default_rng(0), record_trajectories=False)
    assert episode.outcomes == ["timeout"]
    assert episode.states[0, -1, 0] > 10.0


def test_a_robot_at_the_coordinate_bound_gets_a_window_past_it():
    # A robot may stand at the plausible bound (|x|, |y| <= 1e6 m); its navigation window then
    # reaches past the bound. The fuzz suite found the episode's progress check raising there.
    grid = OccupancyGrid.from_array(np.zeros((5, 5), bool), 0.1, (-6.0, -6.0))
    robot, goal = (3.0, -1.0e6), (0.0, -1.0e6)
    nav = World(grid).navigation(goal, 0.3, near=robot, reach=5.0)
    assert nav.value(np.array(robot)) == pytest.approx(3.0, abs=0.2)
    state = RobotState(*robot, 0.0)
    scenario = Scenario("bound", (Agent("robot", state, FixedGoal(goal)),), grid, (),
                        duration=0.4)
    episode = simulate(scenario, PlannerConfig(), SolverConfig.sampling(n_samples=16),
                       np.random.default_rng(0), record_trajectories=False)
    assert np.all(np.isfinite(episode.states))
