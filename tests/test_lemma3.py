"""The paper's Lemma 3 at every preset and solver: a robot whose footprint already overlaps the
map or a moving object brakes as hard as its limits allow and moves no other way; and every
plan's control lies within the robot's declared limits, the reverse limit included."""

import dataclasses
import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World
from dsmpepc_nlp.solve.behaviours import ways
from dsmpepc_nlp.solve.planner import Planner

FOOTPRINTS = (((0.0, 0.0, 0.3),),
              ((-0.2, 0.0, 0.2), (0.0, 0.0, 0.2), (0.2, 0.0, 0.2), (0.4, 0.0, 0.2)))


def _starts_in_collision(rng, count):
    """``count`` random (state, world, footprint) whose footprint overlaps a wall or a person,
    with measured speeds and turn rates inside and beyond the limits, either sign."""
    for i in range(count):
        footprint = FOOTPRINTS[i % 2]
        robot = RobotConfig(footprint=footprint, reverse_limit=float(rng.choice([0.0, 0.3])))
        x, y, phi = rng.uniform(1.0, 3.0), rng.uniform(1.0, 3.0), rng.uniform(-np.pi, np.pi)
        v, omega = rng.uniform(-1.0, 2.0), rng.uniform(-3.0, 3.0)
        occupied = np.zeros((40, 40), bool)
        obstacles = []
        if i % 3 == 0:                                   # a wall through the robot's centre
            ix = int(x / 0.1)
            occupied[:, ix:] = True
        else:                                            # a person on the robot, walking
            offset = rng.uniform(-0.3, 0.3, 2)
            obstacles.append(DynamicObstacle.pedestrian((x + offset[0], y + offset[1]),
                                                        rng.uniform(-1.0, 1.0, 2), 0.3))
        if i % 4 == 1:                                   # and a crowd around
            obstacles += [DynamicObstacle.pedestrian(rng.uniform(0.0, 4.0, 2),
                                                     rng.uniform(-1.0, 1.0, 2), 0.3)
                          for _ in range(5)]
        world = World(OccupancyGrid.from_array(occupied, 0.1), obstacles)
        yield RobotState(x, y, phi, v, omega), world, robot


def _braked(value, limit, dt):
    return math.copysign(max(abs(value) - limit * dt, 0.0), value)


PRESETS = {"product": PlannerConfig, "paper": PlannerConfig.paper}


@pytest.mark.parametrize("preset", sorted(PRESETS))
@pytest.mark.parametrize("method", ["sampling", "fast", "nlp"])
def test_a_robot_in_collision_brakes_and_moves_no_other_way(preset, method):
    rng = np.random.default_rng(3)
    for state, world, robot in _starts_in_collision(rng, 24):
        config = dataclasses.replace(PRESETS[preset](), robot=robot)
        solver = (SolverConfig.sampling(n_samples=64) if method == "sampling"
                  else SolverConfig.named(method))
        planner = Planner(config, solver)
        plan = planner.plan(state, world, (0.2, 0.2), goal_tolerance=0.3)
        assert plan.status == "start-in-collision" and not plan.success, plan.message
        assert "Lemma 3" in plan.message
        dt = config.horizon.dt
        v = min(max(_braked(state.v, robot.accel_limit, dt), -robot.reverse_limit),
                robot.v_limit)
        omega = min(max(_braked(state.omega, robot.alpha_limit, dt), -robot.omega_limit),
                    robot.omega_limit)
        assert plan.control == pytest.approx((v, omega), abs=1e-12), (state, plan.message)
        speeds = np.abs(plan.trajectory.v)
        assert np.all(np.diff(speeds) <= 1e-12)          # never speeds up
        assert np.all(plan.trajectory.v * np.sign(state.v) >= -1e-12)    # never turns round
        assert not math.isnan(plan.fun)


def test_the_braking_of_a_robot_at_rest_is_rest():
    state = RobotState(2.0, 2.0, 0.5)
    world = World(obstacles=[DynamicObstacle.pedestrian((2.1, 2.0), (-1.0, 0.0), 0.3)])
    plan = Planner(solver=SolverConfig.sampling(n_samples=64)).plan(state, world, (5.0, 2.0))
    assert plan.control == (0.0, 0.0)
    assert np.all(plan.trajectory.poses == plan.trajectory.poses[0])


def _walked_into(reverse_limit, person_x=3.1):
    """A robot before a person walking at it, so the back-up rung (``person_x`` 3.3) or the
    last resort (3.1) reverses; the robot's ``reverse_limit`` as given."""
    config = PlannerConfig()
    config = dataclasses.replace(config, robot=dataclasses.replace(
        config.robot, reverse_limit=reverse_limit))
    planner = Planner(config, SolverConfig.sampling(n_samples=256))
    world = World(obstacles=[DynamicObstacle.pedestrian((person_x, 2.0), (-0.5, 0.0), 0.3)])
    return planner, planner.plan(RobotState(2.0, 2.0, 0.0), world, (6.0, 2.0), dock=False)


def test_reversing_is_bounded_by_the_declared_reverse_limit():
    for person_x, status in ((3.1, "clearing"), (3.3, "backing-up")):
        _, plan = _walked_into(0.3, person_x)
        assert plan.status == status and plan.control[0] < 0.0, plan.message
        assert plan.control[0] >= -0.3 - 1e-12 and "at 0.3 m/s" in plan.message
        _, slow = _walked_into(0.1, person_x)
        assert -0.1 - 1e-12 <= slow.control[0], slow.message
        assert np.all(slow.trajectory.v >= -0.1 - 1e-12)
        _, never = _walked_into(0.0, person_x)
        assert never.control[0] >= 0.0, never.message
        assert np.all(never.trajectory.v >= 0.0) and "backing up" not in never.message


def test_the_back_up_speed_is_the_reverse_limit_at_most():
    config = PlannerConfig()
    for limit in (0.0, 0.1, 0.3, 2.0):
        robot = dataclasses.replace(config.robot, reverse_limit=limit)
        speed = ways.back_up_speed(dataclasses.replace(config, robot=robot))
        assert 0.0 <= speed <= limit


def test_reverse_limit_is_validated():
    with pytest.raises(ValueError, match="reverse_limit"):
        RobotConfig(reverse_limit=-0.1)
    with pytest.raises(ValueError, match="reverse_limit"):
        RobotConfig(reverse_limit=math.nan)
