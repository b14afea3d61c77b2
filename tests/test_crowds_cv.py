"""The constant-velocity baseline: full speed when the way is clear, brakes for a predicted
contact, never drives into a person standing in its way; runs in both crowd benchmarks."""

import json

import numpy as np
import pytest

from dsmpepc_nlp import cli
from dsmpepc_nlp.bench import cv
from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.sim.metrics import min_dynamic_clearance
from dsmpepc_nlp.sim.outcomes import OutcomeConfig
from dsmpepc_nlp.sim.simulate import simulate
from dsmpepc_nlp.sim.types import Agent, FixedGoal, Pedestrian, Scenario

CONFIG = PlannerConfig()


def first_command(state, people=()):
    world = World(None).with_obstacles(
        [DynamicObstacle.pedestrian(p, v, 0.3) for p, v in people])
    return cv.ConstantVelocityPlanner(CONFIG).plan(state, world, (10.0, 0.0)).control


def test_clear_way_full_speed_within_the_acceleration_limit():
    robot, dt = CONFIG.robot, CONFIG.horizon.dt
    v, omega = first_command(RobotState(0.0, 0.0, 0.0, 0.5, 0.0))
    assert v == pytest.approx(min(robot.v_limit, 0.5 + robot.accel_limit * dt))
    assert omega == pytest.approx(0.0)
    # a goal to the left: it turns toward it, at most alpha_limit * dt from rest
    plan = cv.ConstantVelocityPlanner(CONFIG).plan(RobotState(0.0, 0.0, 0.0), World(None),
                                                   (0.0, 10.0))
    assert plan.control[1] == pytest.approx(robot.alpha_limit * dt)
    assert np.all(np.isfinite(plan.trajectory.poses))
    assert plan.trajectory.poses.shape == (CONFIG.horizon.n_steps + 1, 3)


def test_brakes_for_a_predicted_contact_and_keeps_speed_for_one_that_passes():
    state = RobotState(0.0, 0.0, 0.0, 1.0, 0.0)
    # a person standing 2.5 m ahead: full speed reaches them within the horizon, so it slows
    v_block, _ = first_command(state, [((2.5, 0.0), (0.0, 0.0))])
    assert v_block < 1.0
    # the same person walking away at 1.2 m/s: nothing to predict, full speed
    v_away, _ = first_command(state, [((2.5, 0.0), (1.2, 0.0))])
    assert v_away == pytest.approx(1.0)
    # a person crossing the robot's line 2 m ahead at t = 2 s, when the robot at full speed
    # would be there too: it slows
    v_cross, _ = first_command(state, [((2.0, -2.0), (0.0, 1.0))])
    assert v_cross < 1.0
    # one crossing 3 m ahead at t = 1 s, gone before the robot arrives: full speed
    v_gone, _ = first_command(state, [((3.0, -1.5), (0.0, 1.5))])
    assert v_gone == pytest.approx(1.0)


def test_never_drives_into_a_person_standing_in_its_way():
    scenario = Scenario("block", (Agent("r", RobotState(0.0, 0.0, 0.0), FixedGoal((6.0, 0.0))),),
                        pedestrians=(Pedestrian.constant((3.0, 0.0), (0.0, 0.0)),),
                        duration=12.0)
    log = simulate(scenario, CONFIG, SolverConfig.sampling(n_samples=1),
                   planner_factory=cv.ConstantVelocityPlanner,
                   outcomes=OutcomeConfig(deadlock=False))
    assert log.outcomes == ["timeout"]
    assert cv.MARGIN / 2 < min_dynamic_clearance(log, 0) < 1.0  # stopped short, close


def test_cv_variant_in_the_crowd_commands(tmp_path, capsys):
    pytest.importorskip("pyrvo")
    argv = ["benchmark", "crowdnav", "--episodes", "2", "--variants", "cv", "--duration", "3",
            "--workers", "1", "--out", str(tmp_path / "cn"), "--json"]
    assert cli.main(argv) == 0
    figures = json.loads(capsys.readouterr().out)["variants"]["cv"]
    assert figures["episodes"] == 2 and figures["error_rate"] == 0
    assert cli.main(argv[:4] + ["bogus"] + argv[5:]) == 2
    assert "cv" in capsys.readouterr().err  # the message lists the baselines
