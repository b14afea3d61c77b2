"""Passive safety (``stall.passive``, ``solve/behaviours/passive.py``): where every way of a doomed
plan touches someone within ``clearance_within``, the robot takes a way that drives toward no one
it touches (at rest or moving away should the contact come), not the shallowest overlap
driven on into."""

import dataclasses
import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState, StallConfig
from dsmpepc_nlp.core.control_law import Trajectory, stacked
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.grid import OccupancyGrid
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.solve.behaviours import passive
from dsmpepc_nlp.solve.behaviours import ways as moves
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator
from dsmpepc_nlp.solve.planner import Planner

SOLVER = SolverConfig.sampling(n_samples=256)
GOAL = (0.0, 6.0)
DRIVING = RobotState(0.0, 0.0, math.pi / 2, 0.9, 0.0)
"""A robot driving at 0.9 m/s toward the goal straight ahead (+y)."""


def converging(reach: float) -> World:
    """Four people walking at the robot at 1.4 m/s from ahead, behind and either side, about
    ``reach`` m off: every way it has meets one of them within the second."""
    return World(obstacles=[
        DynamicObstacle.pedestrian((0.0, reach), (0.0, -1.4), 0.3),
        DynamicObstacle.pedestrian((0.3 - reach, 0.4), (1.4, 0.0), 0.3),
        DynamicObstacle.pedestrian((reach - 0.3, 0.4), (-1.4, 0.0), 0.3),
        DynamicObstacle.pedestrian((0.0, 0.2 - reach), (0.0, 1.4), 0.3)])


def with_passive(on: bool) -> PlannerConfig:
    config = PlannerConfig()
    return dataclasses.replace(config, stall=dataclasses.replace(config.stall, passive=on))


def ways(state, config) -> Trajectory:
    """The last resort's ways from ``state``: the dodges, the reverses and the stop."""
    return stacked([moves.dodge_trajectories(state, config),
                           moves.back_up_trajectories(state, config),
                           passive.stopping(state, config)])


def test_where_every_way_touches_someone_the_robot_drives_at_no_one():
    world, config = converging(1.6), with_passive(True)
    cycle = Cycle.prepare(DRIVING, world, GOAL, config)
    every = ways(DRIVING, config)
    assert passive.clearance(every, Evaluator(cycle), 1.0).max() < 0.0    # no way keeps a gap
    still = Planner(config, SOLVER).plan(DRIVING, world, GOAL)
    moving = Planner(with_passive(False), SOLVER).plan(DRIVING, world, GOAL)
    assert still.status == moving.status == "clearing", (still.message, moving.message)
    assert "every way touches someone within 1 s: the way that drives least toward whoever " \
        "it touches" in still.message
    assert "the clearest way over 1 s" in moving.message
    approach = passive.approach_at_contact(
        stacked([still.trajectory, moving.trajectory]), Evaluator(cycle), 1.0)
    assert approach[0] == pytest.approx(0.0, abs=passive.STILL)
    assert approach[1] > 0.2                    # the shallowest overlap drives on into them
    assert np.all(np.isfinite(still.trajectory.poses)) and np.isfinite(still.fun)
    assert still.control == pytest.approx((still.trajectory.v[0], still.trajectory.omega[0]))


def test_a_robot_that_stands_amid_them_brakes_to_a_stop_and_stays():
    """From a standstill every way is as still as standing; the stop is put before the
    dodges, so it is the one taken (a dodge would drive on after the second)."""
    standing = RobotState(0.0, 0.0, math.pi / 2, 0.0, 0.0)
    plan = Planner(with_passive(True), SOLVER).plan(standing, converging(1.3), GOAL)
    assert "braking to a stop" in plan.message, plan.message
    assert np.all(plan.trajectory.v == 0.0) and plan.control == (0.0, 0.0)


def test_a_way_that_keeps_a_gap_is_still_the_clearest():
    """Where some way keeps clear of everyone over the second, the rung does as before."""
    world = converging(2.4)
    on = Planner(with_passive(True), SOLVER).plan(DRIVING, world, GOAL)
    off = Planner(with_passive(False), SOLVER).plan(DRIVING, world, GOAL)
    assert "the clearest way over 1 s" in on.message
    np.testing.assert_array_equal(on.trajectory.poses, off.trajectory.poses)


def test_approach_counts_the_speed_toward_whoever_is_touched_and_not_away():
    """A person standing 0.9 m ahead: driving straight on touches them at speed, braking to
    a stop touches no one, and backing away from a person walking up from behind, though it
    touches them, moves away; a wall in the way counts the whole speed."""
    config = with_passive(True)
    ahead = World(obstacles=[DynamicObstacle.pedestrian((0.0, 0.9), (0.0, 0.0), 0.3)])
    drive = moves.dodge_trajectories(DRIVING, config)
    straight = drive[[i for i in range(len(drive)) if np.all(drive.omega[i] == 0.0)
                      and drive.v[i, -1] == config.robot.v_limit][0]]
    both = stacked([passive.stopping(DRIVING, config), straight])
    approach = passive.approach_at_contact(
        both, Evaluator(Cycle.prepare(DRIVING, ahead, GOAL, config)), 1.0)
    assert approach[0] == 0.0                                     # stops short of them
    assert 0.8 < approach[1] <= config.robot.v_limit + 1e-9
    standing = RobotState(0.0, 0.0, math.pi / 2, 0.0, 0.0)
    behind = World(obstacles=[DynamicObstacle.pedestrian((0.0, -0.9), (0.0, 1.5), 0.3)])
    back = moves.back_up_trajectories(standing, config)[:1]      # straight back, at them
    ahead_of_them = moves.dodge_trajectories(standing, config)
    away = ahead_of_them[[i for i in range(len(ahead_of_them))
                          if np.all(ahead_of_them.omega[i] == 0.0)][0]]
    cycle = Cycle.prepare(standing, behind, GOAL, config)
    toward, fleeing = passive.approach_at_contact(stacked([back, away]), Evaluator(cycle), 1.0)
    assert toward > 0.2 and fleeing == 0.0
    assert passive.clearance(stacked([away]), Evaluator(cycle), 1.0)[0] < 0.0   # touched
    occupied = np.zeros((40, 40), bool)
    occupied[27:, :] = True                                       # a wall from y = 0.7 m
    wall = World(OccupancyGrid.from_array(occupied, 0.1, (-2.0, -2.0)))
    hit = passive.approach_at_contact(stacked([straight]),
                                      Evaluator(Cycle.prepare(DRIVING, wall, GOAL, config)), 1.0)
    assert hit[0] == pytest.approx(np.abs(straight.v[:5]).max())
    nobody = passive.approach_at_contact(
        both, Evaluator(Cycle.prepare(DRIVING, World(), GOAL, config)), 1.0)
    np.testing.assert_array_equal(nobody, [0.0, 0.0])


def test_on_by_default_off_in_the_paper_preset():
    assert PlannerConfig().stall.passive is True
    assert PlannerConfig.paper().stall.passive is False
    with pytest.raises(InputError, match="passive"):
        StallConfig(passive="yes")


def test_a_turn_in_place_swings_a_circle_off_the_centre_into_whoever_it_touches():
    """A robot of three circles in a row (BARN's Jackal) turning in place: its end circles
    move at the turn rate times their offset, as the simulator's at-fault test reads a
    contact, so a turn that swings the front circle into a person beside it approaches them
    (read by the speed along the heading alone, it was still), and a wall it swings into counts
    that circle's speed; a one-circle robot turning in place approaches no one."""
    from dsmpepc_nlp.bench.barn import jackal_robot
    from dsmpepc_nlp.solve.behaviours.docking import turn_in_place

    config = dataclasses.replace(with_passive(True), robot=jackal_robot())
    offset = config.robot.footprint[-1][0]
    standing = RobotState(0.0, 0.0, 0.0, 0.0, 0.0)
    left, right = turn_in_place(standing, config, 1.0), turn_in_place(standing, config, -1.0)
    turns = stacked([left, right])
    points = passive.footprint_points(turns.poses, config.robot.footprint)
    arriving, leaving = passive.circle_velocities(turns, points)
    omega = turns.omega[0, 1]
    np.testing.assert_allclose(np.linalg.norm(leaving[0, 1], axis=-1),
                               [abs(omega) * offset, 0.0, abs(omega) * offset], atol=1e-12)
    np.testing.assert_allclose(leaving[0, 1, 2] @ [math.cos(turns.poses[0, 1, 2]),
                                                    math.sin(turns.poses[0, 1, 2])], 0.0,
                               atol=1e-12)                   # across the robot, not along it
    beside = World(obstacles=[DynamicObstacle.pedestrian((offset, 0.55), (0.0, 0.0), 0.3)])
    cycle = Cycle.prepare(standing, beside, GOAL, config)
    toward = passive.approach_at_contact(turns[:1], Evaluator(cycle), 1.0)[0]
    assert toward > 0.1                                  # left swings the front circle at them
    occupied = np.zeros((40, 40), bool)
    occupied[:, 21:] = True                                      # a wall from x = 0.1 m
    wall = World(OccupancyGrid.from_array(occupied, 0.1, (-2.0, -2.0)))
    hit = passive.approach_at_contact(
        turns[:1], Evaluator(Cycle.prepare(standing, wall, GOAL, config)), 1.0)
    assert hit[0] > 0.1
    one = with_passive(True)
    spin = stacked([turn_in_place(standing, one, 1.0)])
    near = World(obstacles=[DynamicObstacle.pedestrian((0.0, 0.55), (0.0, 0.0), 0.3)])
    assert passive.approach_at_contact(
        spin, Evaluator(Cycle.prepare(standing, near, GOAL, one)), 1.0)[0] == 0.0
