"""Plans say why they stop, bad solver options fail at construction, and the planner's inputs
are checked (issue 31)."""

import math
import warnings

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World
from dsmpepc_nlp.solve import planner as planner_module
from dsmpepc_nlp.solve.planner import FALLBACK_WARNING, Planner

SAMPLING = SolverConfig.sampling(n_samples=64)


def walled():
    occupied = np.zeros((60, 60), dtype=bool)
    occupied[:, 30:34] = True               # a wall from x = 1.5 to 1.7 m
    return World(OccupancyGrid(occupied, 0.05))


def assert_finite(plan):
    assert all(math.isfinite(c) for c in plan.control) and not math.isnan(plan.fun)
    assert np.all(np.isfinite(plan.trajectory.poses))


def test_a_start_inside_a_wall_has_its_own_status_and_names_the_overlap():
    plan = Planner(solver=SAMPLING).plan(RobotState(1.6, 1.5, 0.0), walled(), (2.5, 1.5),
                                         dock=False)
    assert_finite(plan)
    assert plan.status == "start-in-collision" and not plan.success
    assert "occupied cells" in plan.message and "overlaps" in plan.message
    depth = float(plan.message.split(" by ")[1].split(" m")[0])
    assert 0.3 < depth < 0.5                 # 0.3 m radius + about 0.1 m inside the wall


def test_a_pedestrian_on_the_start_is_named():
    world = World(obstacles=[DynamicObstacle.pedestrian((0.2, 0.0), (0.0, 0.0), 0.3)])
    plan = Planner(solver=SAMPLING).plan(RobotState(0.0, 0.0, 0.0), world, (5.0, 0.0))
    assert plan.status == "start-in-collision"
    assert "obstacle 0 (a pedestrian at (0.20, 0.00) m)" in plan.message
    assert "by 0.400 m" in plan.message


def test_a_free_start_keeps_its_status():
    plan = Planner(solver=SAMPLING).plan(RobotState(0.3, 1.5, 0.0), walled(), (1.0, 1.5))
    assert plan.status == "docked" and "docking radius" in plan.message


def test_stopping_says_why(monkeypatch):
    def boom(*args, **kwargs):
        raise MemoryError("injected")

    monkeypatch.setattr(planner_module.Cycle, "prepare", boom)
    plan = Planner(solver=SAMPLING, strict=False).plan(RobotState(0.3, 1.5, 0.0), walled(),
                                                       (2.5, 1.5))
    assert plan.status == "stopped" and "brakes to a stop" in plan.message
    assert plan.fallbacks_in_row == 1


def test_fallbacks_in_a_row_are_counted_and_warned_once(monkeypatch):
    def boom(*args, **kwargs):
        raise MemoryError("injected")

    planner = Planner(solver=SAMPLING, strict=False)
    monkeypatch.setattr(planner_module.Cycle, "prepare", boom)
    args = (RobotState(0.3, 1.5, 0.0), walled(), (2.5, 1.5))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        counts = [planner.plan(*args).fallbacks_in_row for _ in range(FALLBACK_WARNING + 2)]
    assert counts == list(range(1, FALLBACK_WARNING + 3))
    fell_back = [w for w in caught if "plans in a row fell back" in str(w.message)]
    assert len(fell_back) == 1
    monkeypatch.undo()
    assert planner.plan(*args).fallbacks_in_row == 0


@pytest.mark.parametrize("state", [(0.3, 1.5, 0.0), [0.3, 1.5, 0.0, 0.2, 0.0],
                                   np.array([0.3, 1.5, 0.0])])
def test_a_state_may_be_a_tuple_or_array(state):
    plan = Planner(solver=SAMPLING).plan(state, walled(), (2.5, 1.5))
    assert_finite(plan)


@pytest.mark.parametrize("state", [(0.3, 1.5), "here", None, np.zeros((3, 3)),
                                   (0.0, math.nan, 0.0)])
def test_a_bad_state_is_an_input_error(state):
    with pytest.raises(InputError, match="state|phi|y"):
        Planner(solver=SAMPLING).plan(state, walled(), (2.5, 1.5))


def test_a_world_from_an_array_does_not_print_the_array():
    with pytest.raises(InputError) as info:
        World(np.zeros((10, 10)), [])
    assert "shape (10, 10)" in str(info.value) and "0., 0." not in str(info.value)
    assert len(str(info.value)) < 300


@pytest.mark.parametrize(("options", "words"), [
    ({"max_iter": 3}, "'ipopt.max_iter'"),                  # the prefix left out
    ({"ipopt.max_itr": 3}, "did you mean 'ipopt.max_iter'"),
    ({"ipopt.mu_strategy": "bogus"}, "mu_strategy"),
    ({"ipopt.print_level": "loud"}, "print_level"),
    ({"no_such_thing": 1}, "not a CasADi nlpsol option"),
])
def test_bad_ipopt_options_fail_when_the_planner_is_built(options, words):
    with pytest.raises(InputError, match="SolverConfig.local.options") as info:
        Planner(PlannerConfig(), SolverConfig().replace(options=options))
    assert words in str(info.value)


def test_good_ipopt_options_build():
    planner = Planner(PlannerConfig(), SolverConfig().replace(options={"ipopt.max_iter": 7}))
    assert planner.solver.local.options == (("ipopt.max_iter", 7),)
