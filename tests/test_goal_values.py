"""Defined values at the goal (issue 15): no jump between ending on the goal and beside it.

The paper's limits: as the distance to the goal goes to 0 with the robot moving toward it, TTG
goes to 0, so ``C_TTG -> 0`` and the terminal term goes to 0; the heading term compares the
heading with the navigation function's descent direction, which near the goal is the direction
to the goal.
"""

import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.costs import GOAL_TOLERANCE, heading_error, inverse_ttg
from dsmpepc_nlp.core.exact_cost import evaluate
from dsmpepc_nlp.core.world import OccupancyGrid, World

CONFIG = PlannerConfig()


def grid_world():
    occupied = np.zeros((80, 80), dtype=bool)
    occupied[60:62, 10:30] = True
    return World(OccupancyGrid(occupied, 0.05, (-1.0, -1.0)))


def straight():
    """A trajectory driving along +x; it ends at about (2.92, 0) still moving."""
    return rollout(np.array([3.0, 0.0, 0.0, 1.0]), RobotState(0.0, 0.0, 0.0), CONFIG)


def test_inverse_ttg_follows_the_limit_ttg_to_zero():
    pose = (0.0, 0.0, 0.0)
    assert inverse_ttg(pose, 0.5, (0.0, 0.0)) == math.inf                      # on the goal
    assert inverse_ttg(pose, 0.0, (1e-9, 0.0)) == math.inf                     # within tolerance
    ahead = [inverse_ttg(pose, 0.5, (d, 0.0)) for d in (1e-1, 1e-2, 1e-3)]
    assert ahead == pytest.approx([5.0, 50.0, 500.0], rel=1e-5)                # v / d grows
    assert GOAL_TOLERANCE == 1e-6


def test_heading_error_is_zero_where_the_descent_direction_has_no_length():
    assert heading_error(math.pi, 0.0, 0.0) == 0.0
    assert heading_error(0.0, -1.0, 0.0) == pytest.approx(math.pi)


@pytest.mark.parametrize("world", [World(), grid_world()], ids=["no map", "map"])
def test_no_jump_between_ending_on_the_goal_and_beside_it(world):
    trajectory = straight()
    end = trajectory.poses[-1, :2]
    on_goal = evaluate(trajectory, world, end, CONFIG)
    for d in (1e-12, 1e-9, 1e-7):
        beside = evaluate(trajectory, world, end + [d, 0.0], CONFIG)
        assert float(beside.total) == pytest.approx(float(on_goal.total), abs=1e-6)
    assert float(on_goal.terms["terminal"]) == 0.0 and float(on_goal.terms["heading"]) == 0.0


@pytest.mark.parametrize("world", [World(), grid_world()], ids=["no map", "map"])
def test_heading_and_terminal_terms_approach_their_goal_values_continuously(world):
    # Ending d short of the goal, still moving toward it: both terms tend to 0 as d -> 0.
    # (On the map the heading term was 0.2 * pi for d between 1e-6 and ~5 mm: the central
    # differences of the navigation function straddled its minimum.)
    trajectory = straight()
    end = trajectory.poses[-1, :2]
    for d in (2e-6, 1e-5, 1e-3, 5e-3):
        costs = evaluate(trajectory, world, end + [d, 0.0], CONFIG)
        assert float(costs.terms["heading"]) <= 0.2 * math.radians(2.0)
        assert abs(float(costs.terms["terminal"])) <= 1e-3
