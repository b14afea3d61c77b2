"""People who start to walk (perception/walkers.py, ``PredictionConfig.speeding_up``): a person who
stood at last plan and walks now is predicted at the speed a few plans on, capped; everyone
else, and every world at the paper's settings, is planned in as seen."""

import dataclasses

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, PredictionConfig
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.perception.walkers import SpeedingUp
from dsmpepc_nlp.solve.planner import Planner

ON = PlannerConfig(prediction=PredictionConfig(speeding_up=2.0))


def people(*rows):
    """A world of pedestrians, each ``(x, y, vx, vy)``."""
    return World(obstacles=[DynamicObstacle.pedestrian((x, y), (vx, vy)) for x, y, vx, vy in rows])


def velocities(world):
    return np.array([o.velocity for o in world.obstacles])


def test_a_person_who_starts_to_walk_is_predicted_at_the_speed_two_plans_on():
    tracker = SpeedingUp(ON)
    assert tracker.update(people((1.0, 0.0, 0.0, 0.0))).obstacles[0].velocity[0] == 0.0
    # A plan later at 0.3 m/s: a rise of 0.3 per plan, two plans on 0.9 m/s, same heading.
    seen = tracker.update(people((1.05, 0.0, 0.3, 0.0)))
    np.testing.assert_allclose(velocities(seen), [[0.9, 0.0]])
    # Walking now, and faster: seen as they walk (only a start from standing is read ahead).
    seen = tracker.update(people((1.15, 0.0, 0.6, 0.0)))
    np.testing.assert_allclose(velocities(seen), [[0.6, 0.0]])


def test_a_brisk_start_is_capped_at_walking_speed():
    tracker = SpeedingUp(ON)
    tracker.update(people((1.0, 0.0, 0.05, 0.0)))
    seen = tracker.update(people((1.0, 0.1, 0.0, 0.8)))
    np.testing.assert_allclose(velocities(seen), [[0.0, 1.3]])


def test_steady_slowing_new_and_walking_people_are_planned_in_as_seen():
    tracker = SpeedingUp(ON)
    tracker.update(people((0.0, 0.0, 1.0, 0.0), (3.0, 0.0, 0.8, 0.0), (6.0, 0.0, 0.0, 0.0),
                          (-3.0, 0.0, 0.5, 0.0)))
    now = people((0.2, 0.0, 1.0, 0.0),      # steady
                 (3.16, 0.0, 0.5, 0.0),     # slowing
                 (9.0, 0.0, 0.5, 0.0),      # nobody of last plan within the gate: new
                 (-2.9, 0.0, 0.9, 0.0))     # walked already: faster, but read as seen
    assert tracker.update(now) is now
    tracker.reset()
    fresh = people((0.4, 0.0, 1.2, 0.0))
    assert tracker.update(fresh) is fresh


def test_the_person_matched_is_the_one_predicted_there_not_the_nearest_now():
    """A walker comes up beside one who stands: each keeps their own history."""
    tracker = SpeedingUp(ON)
    tracker.update(people((0.0, 0.0, 1.0, 0.0), (0.5, 0.0, 0.0, 0.0)))
    # The walker is now at 0.2 (1.0 m/s, steady), nearer the stander's old place than their
    # own; the one who stood starts left at 0.3 m/s.
    seen = tracker.update(people((0.2, 0.0, 1.0, 0.0), (0.44, 0.0, -0.3, 0.0)))
    np.testing.assert_allclose(velocities(seen), [[1.0, 0.0], [-0.9, 0.0]])


def test_robots_are_not_people_and_off_changes_nothing():
    robot = DynamicObstacle.robot((0.0, 0.0, 0.0), (0.1, 0.0), [(0.2, 0.0, 0.3), (-0.2, 0.0, 0.3)])
    tracker = SpeedingUp(ON)
    tracker.update(World(obstacles=[robot]))
    faster = World(obstacles=[DynamicObstacle.robot((0.02, 0.0, 0.0), (0.6, 0.0),
                                                    [(0.2, 0.0, 0.3), (-0.2, 0.0, 0.3)])])
    assert tracker.update(faster) is faster
    off = SpeedingUp(PlannerConfig())
    off.update(people((1.0, 0.0, 0.0, 0.0)))
    later = people((1.05, 0.0, 0.4, 0.0))
    assert off.update(later) is later
    assert PlannerConfig.paper().prediction.speeding_up == 0.0


def test_a_planner_that_predicts_faster_walkers_plans_otherwise_and_forgets_on_reset():
    """A person 1 m ahead-left starts to cross the robot's way: seen standing, then at 0.4 m/s,
    the planner with the look-ahead costs its plan against a 1.2 m/s crosser; after ``reset``
    the same world is seen for the first time and planned in as without the look-ahead."""
    solver = SolverConfig.sampling(n_samples=256)
    first = people((1.2, 0.9, 0.0, 0.0))
    second = people((1.2, 0.85, 0.0, -0.4))
    plans = {}
    for name, config in (("off", PlannerConfig()), ("on", ON)):
        planner = Planner(config, solver, strict=True)
        planner.plan((0.0, 0.0, 0.0, 0.5, 0.0), first, (6.0, 0.0))
        plans[name] = planner.plan((0.1, 0.0, 0.0, 0.5, 0.0), second, (6.0, 0.0))
        if name == "on":
            planner.reset()
            plans["reset"] = planner.plan((0.1, 0.0, 0.0, 0.5, 0.0), second, (6.0, 0.0))
    assert plans["on"].fun != pytest.approx(plans["off"].fun, rel=1e-6)
    np.testing.assert_allclose(plans["reset"].x, plans["off"].x)
    assert plans["reset"].fun == pytest.approx(plans["off"].fun, rel=1e-12)


@pytest.mark.parametrize("field, value", [("speeding_up", -1.0), ("walking_speed", 0.0),
                                          ("gate", float("nan"))])
def test_bad_prediction_settings_are_refused_by_name(field, value):
    with pytest.raises(InputError, match=field):
        dataclasses.replace(PredictionConfig(), **{field: value})
