"""The behaviours beyond the optimiser as a chain the configuration orders and switches
(``PlannerConfig.behaviours``, ``solve/behaviours/chain.py``)."""

from __future__ import annotations

import dataclasses

import pytest

from dsmpepc_nlp import DynamicObstacle, Planner, PlannerConfig, RobotState, World
from dsmpepc_nlp.core.config import BEHAVIOURS
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.solve.behaviours import chain
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator

SOLVER = SolverConfig.sampling(n_samples=256)
DRIVING = RobotState(0.0, 0.0, 1.5707963267948966, 1.0, 0.0)
GOAL = (0.0, 6.0)


def doomed_world():
    """A walker from the left about to cross just ahead of a robot driving up at 1 m/s: the
    law's plan is struck within the second, so the last resort takes the clearest way."""
    return World(obstacles=[DynamicObstacle.pedestrian((-1.2, 0.6), (1.0, 0.0), 0.3)])


def with_behaviours(names, config=None):
    return dataclasses.replace(config or PlannerConfig(), behaviours=names)


def test_every_behaviour_is_on_by_default_in_order_and_the_paper_docks_only():
    assert PlannerConfig().behaviours == BEHAVIOURS == ("docking", "last-resort", "moves")
    assert PlannerConfig.paper().behaviours == ("docking",)
    assert chain.configured(PlannerConfig()) == (("docking",), ("last-resort", "moves"))
    assert chain.configured(PlannerConfig.paper()) == (("docking",), ())
    assert set(chain.ON_PLAN) | set(chain.INSTEAD) == set(BEHAVIOURS)


@pytest.mark.parametrize("names, problem", [
    (("docking", "spin"), "spin"), (("moves", "moves"), "moves"), ("docking", "docking"),
    (3, "3"),
])
def test_the_chain_names_known_behaviours_once_each(names, problem):
    with pytest.raises(InputError, match=r"PlannerConfig\.behaviours = .*" + problem):
        with_behaviours(names)


def test_a_list_is_kept_as_a_tuple_and_the_ladders_switches_still_gate():
    assert with_behaviours(["moves", "docking"]).behaviours == ("moves", "docking")
    off = PlannerConfig(stall=dataclasses.replace(PlannerConfig().stall, levels=0))
    assert chain.configured(off) == (("docking",), ())
    no_doom = PlannerConfig(stall=dataclasses.replace(PlannerConfig().stall, doomed_below=0.0))
    assert chain.configured(no_doom) == (("docking",), ("moves",))


def test_the_first_behaviour_that_replaces_the_plan_ends_the_chain():
    """Over a doomed plan the last resort answers first by default ('clearing'); moved after
    the moves, the cheapest move answers instead ('dodging'); left out, it never runs."""
    world = doomed_world()
    statuses = {}
    for names in (BEHAVIOURS, ("docking", "moves", "last-resort"), ("docking", "moves")):
        config = with_behaviours(names)
        planner = Planner(config, SOLVER)
        statuses[names] = planner.plan(DRIVING, world, GOAL).status
        assert planner.on_plan == names[1:]
    assert statuses[BEHAVIOURS] == "clearing"
    assert statuses[("docking", "moves", "last-resort")] == "dodging"
    assert statuses[("docking", "moves")] == "dodging"


def test_the_optimiser_alone_runs_no_behaviour():
    """``behaviours=()``: neither docking near the goal nor anything on a doomed plan."""
    alone = with_behaviours(())
    near = Planner(alone, SOLVER).plan(RobotState(0.0, 5.0, 1.5707963267948966), World(), GOAL)
    assert near.status == "sampling"
    docked = Planner(PlannerConfig(), SOLVER).plan(RobotState(0.0, 5.0, 1.5707963267948966),
                                                   World(), GOAL)
    assert docked.status == "docked"
    assert Planner(alone, SOLVER).plan(DRIVING, doomed_world(), GOAL).status == "sampling"


def test_recover_is_the_chain_the_planner_runs():
    """:func:`chain.recover` gives what the planner's own chain gave, and None where the
    plan stands."""
    world = doomed_world()
    config = PlannerConfig()
    plan = Planner(with_behaviours(("docking",)), SOLVER).plan(DRIVING, world, GOAL)
    evaluator = Evaluator(Cycle.prepare(DRIVING, world, GOAL, config))
    replaced = chain.recover(plan, DRIVING, evaluator, 0)
    full = Planner(config, SOLVER).plan(DRIVING, world, GOAL)
    assert replaced is not None and replaced.status == full.status == "clearing"
    assert replaced.trajectory.poses.tolist() == full.trajectory.poses.tolist()
    empty = World()
    calm = Planner(with_behaviours(("docking",)), SOLVER).plan(DRIVING, empty, GOAL)
    assert chain.recover(calm, DRIVING, Evaluator(Cycle.prepare(DRIVING, empty, GOAL, config)),
                         0) is None
