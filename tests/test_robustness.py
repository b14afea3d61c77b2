"""Strange worlds: the planner works or fails with a clear error, never with NaN."""

import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World
from dsmpepc_nlp.solve.behaviours import ways
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import evaluate_batch
from dsmpepc_nlp.solve.planner import Planner

SAMPLING = SolverConfig.sampling(n_samples=256)


LIMITS = PlannerConfig().robot


def finite_in_limits(plan, robot=LIMITS):
    """A finite command inside the robot's limits; a reverse only from the back-up rung or
    its last resort, at most its speed (within ``reverse_limit``)."""
    v, omega = plan.control
    reversing = plan.status in ("backing-up", "clearing")
    low = -ways.back_up_speed(PlannerConfig()) if reversing else 0.0
    return (math.isfinite(v) and math.isfinite(omega) and low <= v <= robot.v_limit
            and abs(omega) <= robot.omega_limit and not math.isnan(plan.fun))


def test_goal_at_the_robot():
    plan = Planner(solver=SAMPLING).plan(RobotState(1.0, 1.0, 0.0), World(), (1.0, 1.0))
    assert finite_in_limits(plan)


def test_goal_behind_a_wall_and_enclosed():
    occupied = np.zeros((40, 40), bool)
    occupied[15:25, 15:25] = True
    occupied[18:22, 18:22] = False          # a free pocket inside a solid block
    world = World(OccupancyGrid.from_array(occupied, 0.1))
    plan = Planner(solver=SAMPLING).plan(RobotState(0.5, 0.5, 0.0), world, (2.0, 2.0))
    assert finite_in_limits(plan) and plan.status in ("sampling", "docked")


def test_pedestrian_on_top_of_the_robot_keeps_it_still():
    world = World(obstacles=[DynamicObstacle.pedestrian((0.0, 0.0), (0.5, 0.0), 0.3)])
    plan = Planner(solver=SAMPLING).plan(RobotState(0.0, 0.0, 0.0), world, (5.0, 0.0))
    assert plan.control == (0.0, 0.0)


def test_hundreds_of_pedestrians_are_costed_in_bounded_chunks():
    rng = np.random.default_rng(0)
    crowd = [DynamicObstacle.pedestrian(rng.uniform(-10, 10, 2), rng.uniform(-1, 1, 2), 0.3)
             for _ in range(300)]
    world = World(obstacles=crowd)
    config = PlannerConfig()
    z = np.tile([3.0, 0.0, 0.0, 1.0], (40, 1))
    cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.0), world, (8.0, 0.0), config)
    chunked = evaluate_batch(z, cycle)
    single = evaluate_batch(z[:1], cycle)
    np.testing.assert_allclose(chunked.costs.total, single.costs.total[0])
    plan = Planner(config, SolverConfig.sampling(n_samples=64)).plan(
        RobotState(0.0, 0.0, 0.0), world, (8.0, 0.0))
    assert finite_in_limits(plan)


def test_map_of_one_cell():
    world = World(OccupancyGrid.from_array([[True]], 0.5, (2.0, -0.25)))
    plan = Planner(solver=SAMPLING).plan(RobotState(0.0, 0.0, 0.0), world, (5.0, 0.0))
    assert finite_in_limits(plan)


@pytest.mark.parametrize("goal", [(np.nan, 0.0), (1.0,), "far"])
def test_bad_goal_is_a_clear_error(goal):
    with pytest.raises((InputError, ValueError), match="goal"):
        Planner(solver=SAMPLING).plan(RobotState(0.0, 0.0, 0.0), World(), goal)


def test_a_crashing_solver_falls_back_to_sampling():
    planner = Planner(solver=SAMPLING, strict=False)

    class Broken:
        def solve(self, *args):
            raise RuntimeError("boom")

    planner.nlp = Broken()
    plan = planner.plan(RobotState(0.0, 0.0, 0.0), World(), (5.0, 0.0), dock=False)
    assert plan.status == "sampling-fallback" and not plan.success
    assert "boom" in plan.message and finite_in_limits(plan)


@pytest.mark.slow
def test_map_of_2000_by_2000_cells():
    occupied = np.zeros((2000, 2000), bool)
    occupied[900:1100, 1100:1110] = True
    world = World(OccupancyGrid.from_array(occupied, 0.05, (-50.0, -50.0)))
    plan = Planner(solver=SAMPLING).plan(RobotState(0.0, 0.0, 0.0), world, (10.0, 0.0))
    assert finite_in_limits(plan) and plan.control[0] > 0.0
