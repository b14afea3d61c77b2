"""Fuzzing: for any finite state and world the planner's control is finite and within limits.

1,000 examples per property in the default suite; ``HYPOTHESIS_PROFILE=slow`` runs 10,000.
About one coordinate in four of the robot and the goal is far from the map (up to 1e6 m, the
plausible limit): far goals, and robots that left the map (issue 14).
"""

import math
import os

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from dsmpepc_nlp.core.config import PlannerConfig, RobotConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World
from dsmpepc_nlp.sim.outcomes import OUTCOMES
from dsmpepc_nlp.sim.simulate import simulate
from dsmpepc_nlp.sim.types import Agent, FixedGoal, Pedestrian, Scenario
from dsmpepc_nlp.solve.behaviours import ways
from dsmpepc_nlp.solve.planner import Planner

SLOW = os.environ.get("HYPOTHESIS_PROFILE") == "slow"
EXAMPLES = 10_000 if SLOW else 1_000

coordinate = st.floats(-6.0, 6.0, allow_nan=False)
far = st.floats(-1.0e6, 1.0e6, allow_nan=False)
position = st.one_of(coordinate, coordinate, coordinate, far)   # robot and goal coordinates
speed = st.floats(-2.0, 3.0, allow_nan=False)          # measured values may exceed the limits
circle = st.tuples(st.floats(-0.4, 0.4), st.floats(-0.3, 0.3), st.floats(0.05, 0.5))
footprints = st.lists(circle, min_size=1, max_size=3).map(tuple)
pedestrian = st.builds(
    DynamicObstacle.pedestrian,
    st.tuples(coordinate, coordinate), st.tuples(speed, speed), st.floats(0.05, 1.0))


@st.composite
def grids(draw):
    if draw(st.booleans()):
        return None
    shape = (draw(st.integers(1, 24)), draw(st.integers(1, 24)))
    seed = draw(st.integers(0, 2**32 - 1))
    fill = draw(st.floats(0.0, 1.0))
    occupied = np.random.default_rng(seed).random(shape) < fill
    resolution = draw(st.floats(0.05, 0.5))
    origin = (draw(coordinate), draw(coordinate))
    return OccupancyGrid.from_array(occupied, resolution, origin)


@st.composite
def situations(draw):
    state = RobotState(draw(position), draw(position), draw(st.floats(-10.0, 10.0)),
                       draw(speed), draw(speed))
    world = World(draw(grids()), draw(st.lists(pedestrian, max_size=6)))
    goal = (draw(position), draw(position))
    return state, world, goal


PLANNERS = {}


def planner_for(footprint):
    """Planners are built once per footprint (the sample set is part of the planner)."""
    if footprint not in PLANNERS:
        config = PlannerConfig(robot=RobotConfig(footprint=footprint))
        PLANNERS[footprint] = Planner(config, SolverConfig.sampling(n_samples=16))
    return PLANNERS[footprint]


def assert_control_in_limits(plan, config):
    """Within the robot's declared limits, ``[-reverse_limit, v_limit]``; reverse only for the
    back-up rung, its last resort, at most the rung's speed, and a robot in collision braking
    a measured reverse (Lemma 3)."""
    v, omega = plan.control
    robot = config.robot
    assert math.isfinite(v) and math.isfinite(omega)
    assert -robot.reverse_limit <= v <= robot.v_limit and abs(omega) <= robot.omega_limit
    if plan.status in ("backing-up", "clearing"):
        assert v >= -ways.back_up_speed(config)
    elif plan.status != "start-in-collision":
        assert v >= 0.0, plan.message


@settings(max_examples=EXAMPLES)
@given(situation=situations(), footprint=footprints, dock=st.booleans())
def test_any_situation_gives_a_finite_control_within_limits(situation, footprint, dock):
    state, world, goal = situation
    planner = planner_for(footprint)
    plan = planner.plan(state, world, goal, dock=dock)
    assert_control_in_limits(plan, planner.config)
    assert np.all(np.isfinite(plan.trajectory.poses)) and np.all(np.isfinite(plan.x))
    assert not math.isnan(plan.fun)
    assert plan.status in ("sampling", "docked", "stopped", "start-in-collision", "backing-up",
                           "dodging", "turning", "clearing")


@settings(max_examples=EXAMPLES // 20)
@given(situation=situations(), seed=st.integers(0, 1000))
def test_any_short_episode_ends_with_an_outcome(situation, seed):
    state, world, goal = situation
    pedestrians = tuple(Pedestrian.constant(o.centers[0], o.velocity, float(o.radii[0]))
                        for o in world.obstacles)
    scenario = Scenario("fuzz", (Agent("robot", state, FixedGoal(goal)),), world.grid,
                        pedestrians, duration=0.6)
    episode = simulate(scenario, PlannerConfig(), SolverConfig.sampling(n_samples=16),
                       np.random.default_rng(seed), record_trajectories=False)
    assert len(episode.outcomes) == 1 and episode.outcomes[0] in OUTCOMES
    assert np.all(np.isfinite(episode.states))


NLP_PLANNERS = {}


@settings(max_examples=EXAMPLES // 10)
@given(situation=situations(), method=st.sampled_from(["fast", "nlp"]))
def test_the_nlp_path_also_gives_finite_controls_within_limits(situation, method):
    """The product path: local models, the CasADi graph, the solver, fallbacks."""
    state, world, goal = situation
    if method not in NLP_PLANNERS:
        NLP_PLANNERS[method] = Planner(PlannerConfig(), SolverConfig.named(method))
    planner = NLP_PLANNERS[method]
    plan = planner.plan(state, world, goal, dock=False)
    assert_control_in_limits(plan, planner.config)
    assert np.all(np.isfinite(plan.trajectory.poses)) and not math.isnan(plan.fun)
    assert plan.status in ("nlp", "sampling-fallback", "stopped", "start-in-collision",
                           "backing-up", "dodging", "turning", "clearing")
