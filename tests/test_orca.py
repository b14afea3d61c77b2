"""ORCA baseline: unicycle conversion, map polygons, closed loop, missing dependency."""

import sys

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.world import OccupancyGrid, World

pytest.importorskip("pyrvo")

from dsmpepc_nlp.bench import orca  # noqa: E402
from dsmpepc_nlp.sim.types import Agent, FixedGoal, Pedestrian, Scenario  # noqa: E402


def test_unicycle_conversion():
    planner = orca.OrcaPlanner(PlannerConfig())
    robot = planner.config.robot
    state = RobotState(0.0, 0.0, 0.0, v=1.0)
    v, omega = planner.to_unicycle(state, (1.0, 0.0))
    assert (v, omega) == (1.0, 0.0)
    v, omega = planner.to_unicycle(state, (0.0, 1.0))  # sideways: brake and turn left
    assert v == pytest.approx(max(1.0 - robot.accel_limit * 0.2, 0.0))
    assert omega == pytest.approx(min(robot.alpha_limit * 0.2, robot.omega_limit))
    v, omega = planner.to_unicycle(RobotState(0, 0, 0), (-1.0, -0.01))  # behind: turn in place
    assert v == 0.0 and omega < 0


def test_grid_polygons_are_counter_clockwise_rectangles():
    occ = np.zeros((4, 5), dtype=bool)
    occ[1:3, 1:4] = True
    polygons = orca.grid_polygons(OccupancyGrid(occ, 0.5, (1.0, 2.0)))
    assert len(polygons) == 2
    (x0, y0), (x1, _), (_, y1), _ = polygons[0]
    assert (x0, y0, x1, y1) == (1.5, 2.5, 3.0, 3.0)
    area = sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(polygons[0], polygons[0][1:] +
                                                           polygons[0][:1]))
    assert area > 0


def test_velocity_avoids_head_on_pedestrian():
    from dsmpepc_nlp.core.world import DynamicObstacle

    planner = orca.OrcaPlanner(PlannerConfig())
    state = RobotState(0.0, 0.0, 0.0, v=1.0)
    world = World(None, [DynamicObstacle.pedestrian((2.0, 0.0), (-1.0, 0.0), 0.3)])
    u = planner.holonomic_velocity(state, world, (10.0, 0.0))
    assert abs(u[1]) > 0.05 or u[0] < 0.9
    free = planner.holonomic_velocity(state, World(), (10.0, 0.0))
    assert np.allclose(free, (1.0, 0.0), atol=1e-6)


def test_closed_loop_reaches_the_goal_past_a_pedestrian():
    agent = Agent("r", RobotState(0.0, 0.0, 0.0), FixedGoal((5.0, 0.0)))
    ped = Pedestrian.constant((5.0, 1.5), (-0.5, -0.3))
    scenario = Scenario("cross", (agent,), pedestrians=(ped,), duration=12.0)
    episode = orca.simulate_orca(scenario, PlannerConfig(), np.random.default_rng(0))
    assert episode.outcomes == ["success"]
    speeds = episode.states[0, :-1, 3]  # the last state is the stop at the outcome
    assert np.all(np.abs(np.diff(speeds)) <= 1.5 * 0.2 + 1e-9)
    assert episode.states[0, :, 3].max() <= 1.0 + 1e-12


def test_missing_pyrvo_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyrvo", None)
    with pytest.raises(ImportError, match=r'pip install "dsmpepc_nlp\[orca\]"'):
        orca.OrcaPlanner(PlannerConfig())
    with pytest.raises(ImportError, match=r'pip install "dsmpepc_nlp\[orca\]"'):
        orca.check_variants(["ds-mpepc", "orca"])
    orca.check_variants(["ds-mpepc"])  # no ORCA asked: no pyrvo needed
