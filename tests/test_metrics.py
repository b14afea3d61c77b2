"""Metrics on hand-built episodes whose answers are known, and on one simulated episode."""

import dataclasses
import json
import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.jsonio import json_clean
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import OccupancyGrid
from dsmpepc_nlp.sim.metrics import (
    collision_kind,
    contact_approach_speed,
    discomfort,
    episode_metrics,
    following_distance,
    min_dynamic_clearance,
    min_static_clearance,
    path_length,
    plan_times,
    run_length,
    shortest_path_length,
    smoothness,
    spl,
    swept_contact_time,
    time_to_goal,
)
from dsmpepc_nlp.sim.simulate import simulate
from dsmpepc_nlp.sim.types import Agent, FixedGoal, Pedestrian, Scenario


def straight_episode(outcome="success", n=11, dt=0.2):
    """One round robot (r = 0.3) driving along y = 0 at 1 m/s, one pedestrian at (2, 1)."""
    ep = simulate(Scenario("x", (Agent("a", RobotState(0, 0, 0), FixedGoal((9.0, 0.0))),),
                           pedestrians=(Pedestrian.constant((2.0, 1.0), (0.0, 0.0)),),
                           duration=(n - 1) * dt),
                  PlannerConfig(), SolverConfig(method="sampling", n_samples=16))
    t = np.arange(n) * dt
    states = np.zeros((1, n, 5))
    states[0, :, 0] = t
    states[0, :, 3] = 1.0
    return dataclasses.replace(
        ep, times=t, states=states, ped_positions=np.tile([[[2.0, 1.0]]], (n, 1, 1)),
        ped_velocities=np.zeros((n, 1, 2)), outcomes=[outcome], outcome_times=[t[-1]],
        plan_time=np.linspace(0.0, 1.0, n - 1)[None], active=np.ones((1, n - 1), bool))


def test_path_length_and_time_to_goal():
    ep = straight_episode()
    assert path_length(ep, 0) == pytest.approx(2.0)
    assert time_to_goal(ep, 0) == pytest.approx(2.0)
    assert math.isnan(time_to_goal(straight_episode("deadlock"), 0))


def test_metrics_stop_at_the_outcome():
    ep = straight_episode()
    ep.outcome_times[0] = 1.0
    assert run_length(ep, 0) == 6
    assert path_length(ep, 0) == pytest.approx(1.0)


def test_dynamic_clearance_and_discomfort():
    ep = straight_episode()
    # closest approach at x = 2: centre distance 1, radii 0.3 + 0.3
    assert min_dynamic_clearance(ep, 0) == pytest.approx(0.4)
    assert discomfort(ep, 0) == 0.0
    # gap < 0.2 <=> centre distance < 0.8 <=> |x - 2| < sqrt(0.64 - 0) ... with y offset 0.5
    ep.ped_positions[:, 0, 1] = 0.5
    gaps = np.hypot(ep.states[0, :, 0] - 2.0, 0.5) - 0.6
    assert discomfort(ep, 0) == pytest.approx(np.mean(gaps < 0.2))
    assert 0.0 < discomfort(ep, 0) < 1.0


def test_static_clearance_uses_the_map():
    ep = straight_episode()
    assert min_static_clearance(ep, 0) == math.inf
    occ = np.zeros((20, 40), bool)
    occ[15, :] = True          # a wall whose lower edge is y = 1.5 (cells of 0.1 m from y=0)
    ep = dataclasses.replace(ep, grid_occupied=occ, grid_resolution=0.1,
                             grid_origin=np.array([-1.0, 0.0]))
    assert ep.grid == ep.grid or isinstance(ep.grid, OccupancyGrid)
    assert min_static_clearance(ep, 0) == pytest.approx(1.5 - 0.3, abs=0.06)


def test_smoothness_of_a_constant_and_of_a_bang_command():
    ep = straight_episode()
    assert smoothness(ep, 0) == (0.0, 0.0)
    ep.states[0, 5:, 4] = 0.4      # one jump of omega by 0.4 rad/s within 0.2 s
    alpha, _ = smoothness(ep, 0)
    assert alpha == pytest.approx(2.0 / 10)


def test_plan_time_median_p95_p99_and_max():
    median, p95, p99, longest = plan_times(straight_episode(), 0)
    assert median == pytest.approx(0.5)
    assert p95 == pytest.approx(0.95)
    assert p99 == pytest.approx(0.99) and longest == pytest.approx(1.0)


def test_following_distance_only_for_follow_goals():
    ep = straight_episode()
    assert math.isnan(following_distance(ep, 0))
    ep.meta["follow"] = [[0, 1.0]]
    expected = np.mean(np.hypot(ep.states[0, :, 0] - 2.0, 1.0))
    assert following_distance(ep, 0) == pytest.approx(expected)


def test_episode_metrics_are_json_safe_and_one_per_robot():
    ep = straight_episode()
    rows = episode_metrics(ep)
    assert len(rows) == 1 and rows[0]["outcome"] == "success"
    text = json.dumps(json_clean(rows), allow_nan=False)
    assert '"following_distance": null' in text


# -- the crowd-navigation field's metrics: collision attribution and SPL ---------------------


def contact_episode(robot_x, ped_x, n, dt=0.2, outcome="collision"):
    """One round robot on y = 0 at ``robot_x(t)``, one pedestrian on y = 0 at ``ped_x(t)``."""
    ep = straight_episode(n=n, dt=dt)
    t = np.arange(n) * dt
    ep.states[0, :, 0] = robot_x(t)
    ep.states[0, :, 3] = np.gradient(robot_x(t), t)
    ep.states[0, -1, 3:] = 0.0  # the loop stops a robot at its outcome
    ped = np.zeros((n, 1, 2))
    ped[:, 0, 0] = ped_x(t)
    ep.ped_positions = ped
    ep.outcomes, ep.outcome_times = [outcome], [float(t[-1])]
    return ep


def test_robot_driving_into_a_standing_human_is_at_fault():
    # at 1 m/s toward a human standing at x = 2.5: contact (centres < 0.6 apart) at x = 2.0
    ep = contact_episode(lambda t: t, lambda t: np.full_like(t, 2.5), n=11)
    assert min_dynamic_clearance(ep, 0) < 0
    assert contact_approach_speed(ep, 0) == pytest.approx(1.0)
    assert collision_kind(ep, 0) == "at-fault"
    assert episode_metrics(ep)[0]["collision_kind"] == "at-fault"


def test_human_walking_into_a_stopped_robot_is_struck():
    # the robot stands at the origin; the human walks at 1 m/s from x = 2 and touches at t = 1.6
    ep = contact_episode(lambda t: np.zeros_like(t), lambda t: 2.0 - t, n=9)
    assert min_dynamic_clearance(ep, 0) < 0
    assert contact_approach_speed(ep, 0) == pytest.approx(0.0)
    assert collision_kind(ep, 0) == "struck"


def test_robot_moving_away_but_caught_up_is_struck_and_no_collision_has_no_kind():
    # the robot drives away at 0.5 m/s, a faster human catches it from behind
    ep = contact_episode(lambda t: 0.5 * t, lambda t: -1.5 + 1.5 * t, n=6)  # touch at t = 1
    assert min_dynamic_clearance(ep, 0) < 0
    assert contact_approach_speed(ep, 0) == pytest.approx(-0.5)
    assert collision_kind(ep, 0) == "struck"
    assert collision_kind(straight_episode(), 0) is None
    assert math.isnan(contact_approach_speed(straight_episode(), 0))


def crossing_episode(ped_x):
    """The robot drives along y = 0 at 1 m/s; a human at x = ``ped_x`` crosses its line at
    7 m/s, 0.707 m from the robot's centre at t = 1.0 and 1.2 (clear at every state) but
    passing through it in between (a contact only a check over the step sees)."""
    ep = straight_episode()
    ep.ped_positions = np.zeros((ep.times.size, 1, 2))
    ep.ped_positions[:, 0, 0] = ped_x
    ep.ped_positions[:, 0, 1] = 0.7 - 7.0 * (ep.times - 1.0)
    return ep


def test_a_contact_between_two_states_is_found_and_judged_where_it_happened():
    ahead = crossing_episode(1.1)
    assert min_dynamic_clearance(ahead, 0) > 0.1  # every logged state is clear
    assert swept_contact_time(ahead, 0) == pytest.approx(1.2)
    assert math.isnan(swept_contact_time(straight_episode(), 0))
    # outcome decided at the contact: the human passed just ahead of the robot, which moved
    # toward where it touched: at fault; just behind the robot: struck
    speeds = {}
    for ped_x, kind in ((1.1, "at-fault"), (0.9, "struck")):
        ep = crossing_episode(ped_x)
        ep.outcomes, ep.outcome_times = ["collision"], [1.2]
        speeds[ped_x] = contact_approach_speed(ep, 0)
        assert collision_kind(ep, 0) == kind
    # x = 1.1: the relative motion runs straight through the centre, from offset (0.1, 0.7):
    # the first touch is along that offset, and the robot's 1 m/s along x projects onto it
    assert speeds[1.1] == pytest.approx(0.1 / math.hypot(0.1, 0.7), abs=1e-9)
    assert speeds[0.9] < -0.1


def test_driving_into_a_wall_is_at_fault():
    ep = contact_episode(lambda t: t, lambda t: np.full_like(t, 50.0), n=11)
    occ = np.zeros((20, 40), bool)
    occ[:, 22:] = True  # a wall from x = 2.2 (cells of 0.1 m from x = 0)
    ep = dataclasses.replace(ep, grid_occupied=occ, grid_resolution=0.1,
                             grid_origin=np.array([0.0, -1.0]))
    assert min_static_clearance(ep, 0) < 0
    assert contact_approach_speed(ep, 0) == pytest.approx(1.0, abs=0.05)
    assert collision_kind(ep, 0) == "at-fault"


def l_shaped_episode(outcome):
    """Start (0, 0), goal (3, 4): driven along x to (3, 0), then up to (3, 4) (7 m)."""
    ep = straight_episode(n=15)
    xy = np.concatenate([np.c_[np.linspace(0, 3, 7), np.zeros(7)],
                         np.c_[np.full(8, 3.0), np.linspace(4 / 8, 4, 8)]])
    ep.states[0, :, :2] = xy
    ep.goals = np.tile([[[3.0, 4.0]]], (1, 15, 1))
    ep.outcomes, ep.outcome_times = [outcome], [float(ep.times[-1])]
    return ep


def test_spl_on_a_hand_computed_path():
    ep = l_shaped_episode("success")
    assert path_length(ep, 0) == pytest.approx(7.0)
    assert shortest_path_length(ep, 0) == pytest.approx(5.0)
    assert spl(ep, 0) == pytest.approx(5.0 / 7.0)
    assert spl(l_shaped_episode("timeout"), 0) == 0.0
    assert spl(l_shaped_episode("collision"), 0) == 0.0
    # ending inside the goal tolerance short of the goal: the path is shorter, SPL is 1
    short = l_shaped_episode("success")
    short.states[0, :, :2] = np.c_[np.zeros(15), np.linspace(0, 4.8, 15)]
    short.goals[:] = (0.0, 5.0)
    assert spl(short, 0) == 1.0


def test_spl_with_a_map_uses_the_navigation_function():
    ep = l_shaped_episode("success")
    occ = np.zeros((60, 60), bool)
    occ[15:25, 0:45] = True  # a wall between start and goal from x = -1 to 3.5 (y 0.5 to 1.5)
    ep = dataclasses.replace(ep, grid_occupied=occ, grid_resolution=0.1,
                             grid_origin=np.array([-1.0, -1.0]))
    around = shortest_path_length(ep, 0)
    assert around > 5.0 + 0.5  # the wall forces a detour beyond its end at x = 3.5
    assert spl(ep, 0) == pytest.approx(around / max(7.0, around))
