"""People who stand, drawn into the map the plan sees (perception/standing.py,
``PredictionConfig.standing_map``): one who has stood a second is drawn and the navigation
function routes round them; walkers, people just stopped, people on the goal or beside the
robot, worlds with a map and the paper's settings are planned in as seen."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dsmpepc_nlp.core.config import PlannerConfig, PredictionConfig
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.grid import OccupancyGrid
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.perception.standing import RESOLUTION, StandingPeople
from dsmpepc_nlp.solve.planner import Planner

CONFIG = PlannerConfig()
ROBOT, GOAL = (1.0, 0.0), (0.0, 4.0)
PLANS_TO_HOLD = round(CONFIG.prediction.standing_map / CONFIG.horizon.dt)


def people(*rows):
    """A world of pedestrians, each ``(x, y, vx, vy)``."""
    return World(obstacles=[DynamicObstacle.pedestrian((x, y), (vx, vy)) for x, y, vx, vy in rows])


# Two people standing 1.1 m apart, centre to centre, across the robot's line to its goal: the
# 0.5 m between their bodies is narrower than the robot (0.6 m across).
PAIR = ((0.5, 1.2, 0.0, 0.0), (1.6, 1.3, 0.0, 0.0))


def updates(tracker, world, plans, robot=ROBOT, goal=GOAL):
    """The world ``tracker`` returns at each of ``plans`` plans in ``world``."""
    return [tracker.update(world, robot, goal) for _ in range(plans)]


def test_a_pair_that_has_stood_a_second_is_drawn_and_the_route_goes_round():
    world = people(*PAIR, (3.0, 0.0, 1.0, 0.0))
    seen = updates(StandingPeople(CONFIG), world, PLANS_TO_HOLD + 1)
    assert all(w is world for w in seen[:PLANS_TO_HOLD - 1])
    drawn = seen[PLANS_TO_HOLD - 1]
    assert drawn.grid is not None and drawn.obstacles == world.obstacles
    grid = drawn.grid
    assert grid.resolution == RESOLUTION
    # Both people are drawn as discs of their radius; the walker is not.
    assert grid.distance(np.array([[0.5, 1.2], [1.6, 1.3]])).max() < -0.2
    assert grid.distance(np.array([[3.0, 0.0]]))[0] > 1.0
    assert grid.occupied.sum() == pytest.approx(2 * np.pi * 0.3 ** 2 / RESOLUTION ** 2, rel=0.15)
    nav = drawn.navigation(GOAL, CONFIG.robot.bounding_radius, near=ROBOT, reach=CONFIG.reach)
    straight = float(np.hypot(ROBOT[0] - GOAL[0], ROBOT[1] - GOAL[1]))
    assert nav.value(np.array([ROBOT]))[0] > straight + 0.3       # round the pair, not between
    # The next plan with nothing changed is the same grid, so its navigation function is kept.
    assert seen[PLANS_TO_HOLD].grid is grid


def test_walkers_people_just_stopped_and_the_option_off_pass_the_world_unchanged():
    walkers = people((0.5, 1.2, 0.0, 0.5), (1.6, 1.3, 0.3, 0.0))
    assert all(w is walkers for w in updates(StandingPeople(CONFIG), walkers, 10))
    off = dataclasses.replace(CONFIG, prediction=PredictionConfig(standing_map=0.0))
    still = people(*PAIR)
    assert all(w is still for w in updates(StandingPeople(off), still, 10))
    assert all(w is still for w in updates(StandingPeople(PlannerConfig.paper()), still, 10))
    assert PlannerConfig.paper().prediction.standing_map == 0.0


def test_one_who_walks_on_is_dropped_and_counts_from_zero_when_they_stop_again():
    tracker = StandingPeople(CONFIG)
    assert updates(tracker, people(*PAIR), PLANS_TO_HOLD)[-1].grid is not None
    walking = people((0.5, 1.25, 0.0, 0.5), (1.6, 1.35, 0.0, 0.5))
    assert tracker.update(walking, ROBOT, GOAL) is walking
    stopped = people((0.5, 1.3, 0.0, 0.0), (1.6, 1.4, 0.0, 0.0))
    seen = updates(tracker, stopped, PLANS_TO_HOLD)
    assert all(w is stopped for w in seen[:-1]) and seen[-1].grid is not None


def test_people_on_the_goal_or_beside_the_robot_are_left_out():
    # One stands 0.4 m from the goal, one 0.5 m from the robot: each disc, grown by the
    # robot's radius, covers that point.
    world = people((0.0, 4.4, 0.0, 0.0), (1.5, 0.0, 0.0, 0.0))
    assert updates(StandingPeople(CONFIG), world, 10)[-1] is world
    with_pair = people((0.0, 4.4, 0.0, 0.0), (1.5, 0.0, 0.0, 0.0), *PAIR)
    grid = updates(StandingPeople(CONFIG), with_pair, 10)[-1].grid
    assert grid.distance(np.array([[0.0, 4.4], [1.5, 0.0]])).min() > 0.2


def test_a_world_with_a_map_and_a_far_goal():
    mapped = World(OccupancyGrid.from_array(np.zeros((20, 20), bool), 0.1), people(*PAIR).obstacles)
    assert updates(StandingPeople(CONFIG), mapped, 10)[-1] is mapped
    # A goal 100 m away: the grid holds the robot and the way ahead to the horizon's reach.
    grid = updates(StandingPeople(CONFIG), people(*PAIR), 10, goal=(0.0, 100.0))[-1].grid
    low, high = grid.origin, grid.origin + np.array(grid.shape[::-1]) * grid.resolution
    assert high[1] - low[1] <= CONFIG.reach + 6.0
    assert np.all(low <= np.array(ROBOT)) and np.all(np.array(ROBOT) <= high)


def test_a_planner_draws_standing_people_after_a_second_and_forgets_them_on_reset():
    solver = SolverConfig.sampling(n_samples=256)
    off = dataclasses.replace(CONFIG, prediction=PredictionConfig(standing_map=0.0))
    world, state = people(*PAIR), (1.0, 0.0, np.pi / 2, 0.0, 0.0)
    planners = {name: Planner(config, solver, strict=True)
                for name, config in (("on", CONFIG), ("off", off))}
    plans = {name: [planner.plan(state, world, GOAL) for _ in range(PLANS_TO_HOLD + 1)]
             for name, planner in planners.items()}
    assert all(np.isfinite(p.fun) for name in plans for p in plans[name])
    # The same plans until the pair has stood a second; then progress is read round them.
    for before_on, before_off in zip(plans["on"][:PLANS_TO_HOLD - 1], plans["off"]):
        np.testing.assert_allclose(before_on.x, before_off.x)
    assert planners["on"].standing.drawn is not None and planners["off"].standing.drawn is None
    assert plans["on"][-1].cost.terms["progress"] != pytest.approx(
        plans["off"][-1].cost.terms["progress"], rel=1e-6)
    on = planners["on"]
    on.reset()
    assert on.standing.drawn is None and on.standing.last is None
    np.testing.assert_allclose(on.plan(state, world, GOAL).x, plans["off"][0].x)


@pytest.mark.parametrize("value", [-1.0, float("nan")])
def test_a_bad_standing_time_is_refused_by_name(value):
    with pytest.raises(InputError, match="standing_map"):
        PredictionConfig(standing_map=value)


@settings(max_examples=60)
@given(st.lists(st.tuples(st.floats(-6.0, 6.0), st.floats(-6.0, 8.0), st.floats(0.1, 0.6)),
                min_size=1, max_size=8))
def test_the_drawn_cells_are_every_cell_whose_centre_a_person_covers(rows):
    """Each person is drawn only in the cells round them; the grid is the one every cell's
    test against every person gives (people at its edges and beyond it included)."""
    still = [DynamicObstacle.pedestrian((x, y), (0.0, 0.0), radius) for x, y, radius in rows]
    tracker = StandingPeople(CONFIG)
    position, goal = np.array(ROBOT), np.array(GOAL)
    occupied, origin = tracker._draw(still, position, goal)
    kept = [p for p in still
            if np.hypot(*(p.centers[0] - goal)) >= p.radii[0] + CONFIG.robot.bounding_radius
            and np.hypot(*(p.centers[0] - position)) >= p.radii[0] + CONFIG.robot.bounding_radius]
    if occupied is None:
        assert origin is None
        return
    ny, nx = occupied.shape
    xs = origin[0] + (np.arange(nx) + 0.5) * RESOLUTION
    ys = origin[1] + (np.arange(ny) + 0.5) * RESOLUTION
    expected = np.zeros_like(occupied)
    for p in kept:
        expected |= np.hypot(xs[None, :] - p.centers[0][0],
                             ys[:, None] - p.centers[0][1]) <= p.radii[0]
    np.testing.assert_array_equal(occupied, expected)
    assert expected.any()


@pytest.mark.parametrize("field, value", [("standing", -1.0), ("gate", float("nan")),
                                          ("standing_map", -0.5)])
def test_bad_prediction_settings_are_refused_by_name(field, value):
    with pytest.raises(InputError, match=field):
        dataclasses.replace(PredictionConfig(), **{field: value})
