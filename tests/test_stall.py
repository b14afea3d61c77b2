"""The product's two extensions for robots that stall: docking that counts the risk until
arrival, and the stall monitor's ladder (docs/method.md sections 7.1 and 7.5)."""

import dataclasses
import math

import numpy as np
import pytest

from dsmpepc_nlp.bench.params import configure
from dsmpepc_nlp.core.config import (
    DockingConfig,
    PlannerConfig,
    RobotState,
    StallConfig,
)
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.solve.behaviours import docking
from dsmpepc_nlp.solve.behaviours.stall import StallMonitor
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator
from dsmpepc_nlp.solve.planner import Planner

SAMPLING = SolverConfig.sampling(n_samples=64)
FAR_GOAL = (5.0, 0.0)


def person_beside_the_goal():
    """A person standing 1 m to the side of a goal 0.5 m ahead: at the goal the bodies are
    0.4 m apart."""
    return World(obstacles=[DynamicObstacle.pedestrian((0.5, 1.0), (0.0, 0.0), 0.3)])


def test_docking_reads_the_survivability_at_arrival_not_at_the_horizons_end():
    state, goal = RobotState(0.0, 0.0, 0.0), (0.5, 0.0)
    until_end = PlannerConfig(docking=DockingConfig(arrival_radius=0.0))
    until_arrival = PlannerConfig()
    # At the horizon's end the robot has stood 4 s beside the person: 0.89, under 0.9.
    assert docking.dock(Evaluator(Cycle.prepare(state, person_beside_the_goal(), goal, until_end)),
                        until_end) is None
    evaluated, message = docking.dock(
        Evaluator(Cycle.prepare(state, person_beside_the_goal(), goal, until_arrival)),
        until_arrival)
    step, survival = docking.arrival_survival(evaluated, goal, 0.1)
    assert 0 < step < until_arrival.horizon.n_steps and survival > 0.9
    assert survival > evaluated.costs.survivability[0, -1]
    assert f"until arrival (step {step})" in message


def test_the_product_docks_from_the_horizons_reach_and_the_paper_from_2_m():
    product = PlannerConfig()
    assert docking.docking_radius(product) == product.reach == 5.0
    assert docking.docking_radius(PlannerConfig.paper()) == 2.0
    # A robot 4 m from its goal, the way clear: the product docks, the paper preset plans.
    state, goal = RobotState(0.0, 0.0, 0.0), (4.0, 0.0)
    assert docking.dock(Evaluator(Cycle.prepare(state, World(), goal, product)),
                        product) is not None
    paper = PlannerConfig.paper()
    assert docking.dock(Evaluator(Cycle.prepare(state, World(), goal, paper)), paper) is None


def test_the_paper_preset_keeps_the_horizons_end_and_no_ladder():
    paper = PlannerConfig.paper()
    assert paper.docking.arrival_radius == 0.0 and paper.stall.levels == 0
    assert PlannerConfig().docking.arrival_radius > 0 and PlannerConfig().stall.levels > 0


def stalled_plans(config, count):
    planner = Planner(config, SAMPLING)
    state = RobotState(0.0, 0.0, 0.0)
    return planner, [planner.plan(state, World(), FAR_GOAL) for _ in range(count)]


def test_a_robot_that_does_not_move_climbs_the_ladder_one_window_at_a_time():
    config = PlannerConfig()
    window = round(config.stall.window / config.horizon.dt)
    planner, plans = stalled_plans(config, 3 * window + 6)
    levels = [p.stall_level for p in plans]
    assert levels[:window] == [0] * window                  # a first window fills
    assert levels[window] == 1 and levels[2 * window] == 2 and levels[3 * window] == 3
    assert max(levels) == config.stall.levels               # never past the top
    assert "ladder level 3, progress weight x8" in plans[-1].message
    planner.reset()
    assert planner.plan(RobotState(0.0, 0.0, 0.0), World(), FAR_GOAL).stall_level == 0


def test_the_paper_preset_never_escalates():
    _, plans = stalled_plans(PlannerConfig.paper(), 25)
    assert {p.stall_level for p in plans} == {0}


def test_progress_puts_the_ladder_back_to_zero_and_arrival_is_no_stall():
    config = PlannerConfig(stall=StallConfig(window=0.4))       # two plans a window
    monitor = StallMonitor(config)
    still = RobotState(0.0, 0.0, 0.0)
    assert [monitor.update(still, FAR_GOAL) for _ in range(5)] == [0, 0, 1, 1, 2]
    # The level holds until a whole window shows progress (here 0.2 m a plan).
    assert monitor.update(RobotState(0.2, 0.0, 0.0), FAR_GOAL) == 2
    assert monitor.update(RobotState(0.4, 0.0, 0.0), FAR_GOAL) == 0
    at_goal = StallMonitor(config)
    assert {at_goal.update(still, (0.05, 0.0)) for _ in range(6)} == {0}


def _circling(monitor, goal, plans):
    """Levels of a robot driving round ``goal`` on a 2 m circle at 1 m/s: it moves 0.4 m
    a 0.4 s window and comes no nearer."""
    return [monitor.update(RobotState(goal[0] + 2.0 * math.cos(0.1 * k),
                                      goal[1] + 2.0 * math.sin(0.1 * k), 0.0), goal)
            for k in range(plans)]


def test_a_robot_that_moves_but_comes_no_nearer_climbs_with_min_progress():
    """Univ's wandering robots circled people at their goals at ladder level 0: they moved
    more than min_displacement every window. With min_progress they climb."""
    moving = PlannerConfig(stall=StallConfig(window=0.4, min_progress=0.2))
    assert _circling(StallMonitor(moving), FAR_GOAL, 5) == [0, 0, 1, 1, 2]
    assert "or came < 0.2 m nearer the goal in 0.4 s" in StallMonitor(moving).describe(1)
    motion_only = PlannerConfig(stall=StallConfig(window=0.4, min_progress=0.0))
    assert set(_circling(StallMonitor(motion_only), FAR_GOAL, 5)) == {0}
    assert "nearer" not in StallMonitor(motion_only).describe(1)
    # Driving at the goal is progress; so is keeping up with a goal that moves ahead.
    straight = StallMonitor(moving)
    assert {straight.update(RobotState(0.2 * k, 0.0, 0.0), FAR_GOAL) for k in range(6)} == {0}
    follower = StallMonitor(moving)
    assert {follower.update(RobotState(0.2 * k, 0.0, 0.0), (0.2 * k + 1.0, 0.0))
            for k in range(6)} == {0}


def test_a_level_raises_only_the_progress_weight_and_its_configuration_is_kept():
    config = PlannerConfig()
    monitor = StallMonitor(config)
    raised = monitor.config_for(2)
    assert raised.cost.w_progress == config.cost.w_progress * config.stall.gain ** 2
    assert dataclasses.replace(raised, cost=config.cost) == config
    assert monitor.config_for(2) is raised and monitor.config_for(0) is config


@pytest.mark.parametrize("changes, field", [
    (dict(levels=-1), "levels"), (dict(levels=1.5), "levels"), (dict(gain=0.5), "gain"),
    (dict(window=0.0), "window"), (dict(min_displacement=float("nan")), "min_displacement"),
    (dict(min_progress=-0.1), "min_progress"),
])
def test_bad_stall_settings_are_refused_by_name(changes, field):
    with pytest.raises(InputError, match=f"StallConfig.{field}|{field}"):
        StallConfig(**changes)


def test_the_command_line_sets_the_ladder_and_the_paper_preset():
    config = configure({"stall.levels": 1.0, "stall.gain": 3.0}, "ds-mpepc")
    assert config.stall.levels == 1 and isinstance(config.stall.levels, int)
    assert config.stall.gain == 3.0
    assert configure({}, "ds-mpepc", "paper") == PlannerConfig.paper("ds-mpepc")
    with pytest.raises(InputError, match="whole number"):
        configure({"stall.levels": 1.5}, "ds-mpepc")


def test_every_benchmark_table_runs_and_records_its_preset_and_overrides():
    from dsmpepc_nlp.bench import crowdnav, crowds
    from dsmpepc_nlp.bench.params import planner_config

    for settings in (crowdnav.CrowdNavSettings(preset="paper"),
                     crowds.CrowdSettings(data=".", scene="eth", preset="paper",
                                          overrides=(("stall.levels", 2.0),))):
        meta = settings.meta()
        assert meta["preset"] == "paper"
        config = planner_config(settings, "mpepc")
        assert config.docking == PlannerConfig.paper("mpepc").docking
        assert config.stall.levels == (2 if settings.overrides else 0)
    assert "preset" not in crowdnav.CrowdNavSettings().meta()      # older tables still match


def person_near_the_goal(y):
    """A person standing ``y`` m beside a goal 3 m ahead of the robot (0.3 m radii both)."""
    from dsmpepc_nlp.sim.types import Pedestrian

    return Pedestrian(np.array([0.0]), np.array([[3.0, y]]), radius=0.3)


def test_docking_tries_the_goals_region_only_when_the_goal_point_fails():
    """A person 0.8 m beside the goal: at the goal point the bodies are 0.2 m apart and the
    straight way there survives 0.61 (under 0.9); a point of the 0.3 m tolerance farther from
    the person passes. Without a tolerance, without region points, or where the goal point
    passes, docking is what it was."""
    state, goal = RobotState(2.0, 0.0, 0.0), (3.0, 0.0)
    world = World(obstacles=[DynamicObstacle.pedestrian((3.0, 0.8), (0.0, 0.0), 0.3)])
    on = PlannerConfig(docking=DockingConfig(region_points=8))
    off = PlannerConfig(docking=DockingConfig(region_points=0))

    def docked(config, tolerance, where=world):
        return docking.dock(Evaluator(Cycle.prepare(state, where, goal, config)), config,
                            tolerance)

    assert docked(off, 0.3) is None and docked(on, 0.0) is None and docked(on, 0.1) is None
    evaluated, message = docked(on, 0.3)
    assert "within the goal's tolerance 0.3 m" in message
    poses = evaluated.trajectories.poses[0]
    reach = np.hypot(poses[:, 0] - goal[0], poses[:, 1] - goal[1])
    assert reach.min() <= 0.3                      # it arrives by the task's rule
    arrived = int(np.argmax(reach <= 0.3))
    assert evaluated.costs.survivability[0, arrived] > 0.9
    assert poses[arrived, 1] < 0.0                 # on the side away from the person
    # The goal point passes with the person 2 m away: the same trajectory either way.
    clear = World(obstacles=[DynamicObstacle.pedestrian((3.0, 2.0), (0.0, 0.0), 0.3)])
    with_region, without = docked(on, 0.3, clear), docked(off, 0.3, clear)
    np.testing.assert_array_equal(with_region[0].z, without[0].z)
    assert with_region[1] == without[1] and "within the goal's tolerance" not in without[1]


def test_the_goals_region_is_tried_only_within_the_docking_radius():
    config = PlannerConfig(docking=DockingConfig(region_points=8))
    goal = (3.0, 0.0)
    near = docking.region_targets(RobotState(1.5, 0.0, 0.0), goal, 0.3, config)
    assert len(near) == 8
    np.testing.assert_allclose(np.hypot(*(np.array(near) - goal).T), 0.2)
    # the first point lies on the line to the robot
    np.testing.assert_allclose(near[0], (2.8, 0.0), atol=1e-12)
    assert docking.region_targets(RobotState(0.5, 0.0, 0.0), goal, 0.3, config) == []
    assert docking.region_targets(RobotState(1.5, 0.0, 0.0), goal, 0.3,
                                  PlannerConfig.paper()) == []


@pytest.mark.parametrize("heading", [0.0, 3.1])
def test_region_turns_off_docks_only_at_points_ahead(heading):
    """``docking.region_turns`` = False: facing the goal, the region's plan is the one docking
    makes with turns allowed (it needs none); facing away, every region point lies behind a
    turn in place, none is tried and docking gives way (None) where it turned before."""
    state, goal = RobotState(2.0, 0.0, heading), (3.0, 0.0)
    world = World(obstacles=[DynamicObstacle.pedestrian((3.0, 0.8), (0.0, 0.0), 0.3)])
    turns, straight = (PlannerConfig(docking=DockingConfig(region_turns=allowed))
                       for allowed in (True, False))

    def docked(config):
        return docking.dock(Evaluator(Cycle.prepare(state, world, goal, config)), config, 0.3)

    with_turns, without = docked(turns), docked(straight)
    if heading == 0.0:
        np.testing.assert_array_equal(with_turns[0].z, without[0].z)
        assert with_turns[1] == without[1] and "turning" not in without[1]
    else:
        assert "turning in place first" in with_turns[1] and without is None
    with pytest.raises(InputError, match="region_turns"):
        DockingConfig(region_turns="no")


def test_arrival_at_tolerance_reads_survival_where_the_task_ends():
    """``docking.arrival_at_tolerance``: the survivability is read where the way first comes
    within the task's tolerance of the goal. A person 0.8 m beside the goal: the goal point's
    way survives 0.61 to 0.1 m from it and more to 0.3 m (still under 0.9). A person 0.7 m
    beside: no region point passes read at 0.1 m from it, one does read at the tolerance.
    Without a tolerance above ``arrival_radius`` nothing changes; the paper preset keeps it
    off."""
    state, goal = RobotState(2.0, 0.0, 0.0), (3.0, 0.0)

    def docked(y, flag, tolerance=0.3):
        world = World(obstacles=[DynamicObstacle.pedestrian((3.0, y), (0.0, 0.0), 0.3)])
        config = PlannerConfig(docking=DockingConfig(arrival_at_tolerance=flag))
        return docking.dock(Evaluator(Cycle.prepare(state, world, goal, config)), config,
                            tolerance)

    def goal_point_survival(message):
        return float(message.split("survivability until arrival is ")[1].split(",")[0])

    assert goal_point_survival(docked(0.8, True)[1]) > goal_point_survival(
        docked(0.8, False)[1]) + 0.1
    assert docked(0.7, False) is None
    evaluated, message = docked(0.7, True)
    assert "within the goal's tolerance 0.3 m" in message
    poses = evaluated.trajectories.poses[0]
    near = np.hypot(poses[:, 0] - goal[0], poses[:, 1] - goal[1]) <= 0.3
    assert evaluated.costs.survivability[0, int(np.argmax(near))] > 0.9
    assert docked(0.7, True, tolerance=0.1) is None and docked(0.7, True, 0.0) is None
    assert PlannerConfig.paper().docking.arrival_at_tolerance is False


@pytest.mark.parametrize("y", [0.7, 0.8])
def test_a_person_beside_the_goal_keeps_the_robot_off_it_only_without_the_region(y):
    """Closed loop: a person stands 0.7-0.8 m beside the goal, which is free (the bodies
    would be 0.1-0.2 m apart at it). Docking only at the goal point with its survivability
    read at 0.1 m from it, the robot never arrives; docking within the task's 0.3 m
    tolerance, it does. The docking alone: the ladder climbs only for a robot that stands
    (``stall.min_progress`` 0); the product's ladder also frees the robot that hovers. The
    product's defaults arrive."""
    from dsmpepc_nlp.sim.simulate import simulate
    from dsmpepc_nlp.sim.types import Agent, FixedGoal, Scenario

    scenario = Scenario("beside", (Agent("a", RobotState(0.0, 0.0, 0.0),
                                         FixedGoal((3.0, 0.0), 0.3)),),
                        pedestrians=(person_near_the_goal(y),), duration=15.0)
    runs = {(points, at_tolerance): (points, at_tolerance, 0.0)
            for points in (0, 8) for at_tolerance in (False, True)}
    runs["product"] = (0, True, StallConfig.min_progress)
    configs = {key: PlannerConfig(docking=DockingConfig(region_points=points,
                                                        arrival_at_tolerance=at_tolerance),
                                  stall=StallConfig(min_progress=progress))
               for key, (points, at_tolerance, progress) in runs.items()}
    configs["defaults"] = PlannerConfig()
    outcomes = {}
    for key, config in configs.items():
        episode = simulate(scenario, config, SolverConfig(method="sampling", n_samples=256),
                           np.random.default_rng(0))
        outcomes[key] = episode.outcomes[0]
    # Read at 0.1 m from its point, only the region frees the robot; read where the task ends
    # (the product's default), the goal point's own way passes beside a person 0.8 m off.
    assert outcomes[0, False] == "timeout" and outcomes[8, False] == "success"
    assert outcomes[8, True] == "success"
    assert outcomes[0, True] == ("success" if y == 0.8 else "timeout")
    assert StallConfig.min_progress > 0.0 and outcomes["product"] == "success"
    assert outcomes["defaults"] == "success"


@pytest.mark.parametrize("tolerance", [-0.1, math.nan, math.inf, "near", True])
def test_plan_refuses_a_goal_tolerance_that_is_not_a_distance(tolerance):
    planner = Planner(PlannerConfig(), SAMPLING)
    with pytest.raises(InputError, match="goal_tolerance"):
        planner.plan(RobotState(0.0, 0.0, 0.0), World(), (1.0, 0.0), goal_tolerance=tolerance)


@pytest.mark.parametrize("heading, v", [(0.0, 0.0), (3.1, 0.0), (3.1, 0.6)])
def test_the_regions_batch_holds_each_approach_as_it_would_be_alone(heading, v):
    """Facing the goal; facing away (each point behind a turn in place, the turns of
    different lengths in one batch), standing and moving away (the turn brakes first, so the
    law starts elsewhere than the robot stands): every row is the row of its point costed
    alone, and a turned row heads for its point from where its turn ends."""
    state, goal = RobotState(2.0, 0.0, heading, v, 0.0), (3.0, 0.0)
    world = World(obstacles=[DynamicObstacle.pedestrian((3.0, 0.8), (0.0, 0.0), 0.3)])
    config = PlannerConfig()
    targets = docking.region_targets(state, goal, 0.3, config)

    def approaches(points):
        return docking.approaches(Evaluator(Cycle.prepare(state, world, goal, config)),
                                  points, config)

    batched = approaches(targets)
    for target, (evaluation, how) in zip(targets, batched):
        [(alone, alone_how)] = approaches([target])
        assert how == alone_how
        for name in ("z", "trajectories.poses", "costs.total", "costs.survivability"):
            first, attribute = name.partition(".")[::2] if "." in name else (name, "")
            a, b = getattr(evaluation, first), getattr(alone, first)
            if attribute:
                a, b = getattr(a, attribute), getattr(b, attribute)
            np.testing.assert_array_equal(a, b)
        if how.startswith("turning"):
            _, steps = docking.turn_toward(state, target, config, config.docking.turn_in_place)
            np.testing.assert_array_equal(
                evaluation.z[0], docking.docking_z(evaluation.trajectories.poses[0, steps],
                                                   target, config))
    turned = [how.startswith("turning") for _, how in batched]
    assert any(turned) if heading else not any(turned)
