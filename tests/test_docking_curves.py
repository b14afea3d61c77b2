"""Docking along the law's curves (``docking.curves``, docs/method.md section 7.1): tried only
when the straight way to the goal and every point of its region fail docking's test."""

import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import DockingConfig, PlannerConfig, RobotState
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.solve.behaviours import docking
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator

FACING_LEFT = RobotState(0.0, 0.0, math.pi / 2)
"""A robot facing +y with its goal 1.5 m to its right: every straight docking way begins with
a turn in place."""
GOAL = (1.5, 0.0)


def person(x, y):
    return World(obstacles=[DynamicObstacle.pedestrian((x, y), (0.0, 0.0), 0.3)])


def docked(config, world, state=FACING_LEFT, goal=GOAL, tolerance=0.3):
    return docking.dock(Evaluator(Cycle.prepare(state, world, goal, config)), config, tolerance)


def test_a_person_beside_the_straight_way_leaves_a_curve_round_them():
    """A person standing 0.65 m below the middle of the line to the goal: the straight way
    (after its turn in place) survives 0.30 and no point of the region passes; the law's curve
    that sets out along the robot's heading passes above them and arrives."""
    world = person(0.75, -0.65)
    assert docked(PlannerConfig(docking=DockingConfig(curves=0)), world) is None
    evaluated, message = docked(PlannerConfig(docking=DockingConfig(curves=8)), world)
    assert message.startswith("docked along a curve") and "no point of the goal" in message
    poses = evaluated.trajectories.poses[0]
    reach = np.hypot(poses[:, 0] - GOAL[0], poses[:, 1] - GOAL[1])
    arrived = int(np.argmax(reach <= 0.3))
    assert reach[arrived] <= 0.3                     # it arrives by the task's rule
    assert evaluated.costs.survivability[0, arrived] > 0.9
    assert poses[1:arrived, 1].min() > -0.05         # never below the line: round the person
    # the z is one of the curves, its heading at the goal off the line of sight
    assert any(np.array_equal(evaluated.z[0], z)
               for z in docking.curve_z(FACING_LEFT.pose, GOAL, PlannerConfig(
                   docking=DockingConfig(curves=8))))
    assert evaluated.z[0, 1] != 0.0


@pytest.mark.parametrize("world", [World(), person(0.75, -0.75)])
def test_curves_change_nothing_where_the_straight_way_or_the_region_passes(world):
    """No one near (the goal point passes) or a person 0.75 m below the line (a region point
    passes): the same plan and message with the curves and without."""
    on = docked(PlannerConfig(docking=DockingConfig(curves=8)), world)
    off = docked(PlannerConfig(docking=DockingConfig(curves=0)), world)
    np.testing.assert_array_equal(on[0].z, off[0].z)
    assert on[1] == off[1] and "curve" not in on[1]


def test_curves_are_tried_only_within_the_docking_radius_and_not_in_the_paper_preset():
    config = PlannerConfig(docking=DockingConfig(curves=8))
    far = RobotState(-1.0, 0.0, math.pi / 2)             # 2.5 m from the goal: beyond 2 m
    assert docked(config, person(0.25, -0.65), state=far) is None
    assert PlannerConfig.paper().docking.curves == 0
    assert docking.curve_z(FACING_LEFT.pose, GOAL, PlannerConfig.paper()).shape == (0, 4)


def test_the_curves_span_the_boxs_theta_evenly_without_the_straight_way():
    config = PlannerConfig(docking=DockingConfig(curves=8))
    zs = docking.curve_z(FACING_LEFT.pose, GOAL, config)
    straight = docking.docking_z(FACING_LEFT.pose, GOAL, config)
    np.testing.assert_allclose(zs[:, 1], [-1.0, -0.75, -0.5, -0.25, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_array_equal(zs[:, [0, 2, 3]], np.tile(straight[[0, 2, 3]], (8, 1)))
    odd = PlannerConfig(docking=DockingConfig(curves=3))
    np.testing.assert_allclose(docking.curve_z(FACING_LEFT.pose, GOAL, odd)[:, 1],
                               [-1.0, 0.5, 1.0])            # the extra angle on the left


@pytest.mark.parametrize("value", [-1, 1.5, True])
def test_a_bad_count_of_curves_is_refused_by_name(value):
    with pytest.raises(InputError, match="curves"):
        DockingConfig(curves=value)
