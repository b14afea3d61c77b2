"""Metrics on hand-built episodes whose answers are known, and on one simulated episode."""

import dataclasses
import json
import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState, SolverConfig
from dsmpepc_nlp.core.world import OccupancyGrid
from dsmpepc_nlp.sim.metrics import (
    discomfort,
    episode_metrics,
    following_distance,
    json_safe,
    min_dynamic_clearance,
    min_static_clearance,
    path_length,
    plan_times,
    run_length,
    smoothness,
    time_to_goal,
)
from dsmpepc_nlp.sim.simulate import Agent, FixedGoal, Pedestrian, Scenario, simulate


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


def test_plan_time_median_and_p95():
    median, p95 = plan_times(straight_episode(), 0)
    assert median == pytest.approx(0.5)
    assert p95 == pytest.approx(0.95)


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
    text = json.dumps(json_safe(rows), allow_nan=False)
    assert '"following_distance": null' in text
