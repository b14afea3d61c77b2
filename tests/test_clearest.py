"""The back-up rung's last resort (``last_resort.clearest``, ``stall.doomed_below``): over a plan
the robot expects to be struck on almost surely within ``clearance_within`` seconds, the way
that keeps the widest gap over them, not the cheapest."""

import dataclasses
import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState, StallConfig
from dsmpepc_nlp.core.control_law import stacked
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.exact_cost import evaluate, exact_geometry
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.solve.behaviours import backup, chain, last_resort, passive
from dsmpepc_nlp.solve.behaviours import ways as moves
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator
from dsmpepc_nlp.solve.planner import Planner

SOLVER = SolverConfig.sampling(n_samples=256)
GOAL = (0.0, 6.0)
DRIVING = RobotState(0.0, 0.0, math.pi / 2, 0.9, 0.0)
"""A robot driving at 0.9 m/s toward the goal straight ahead (+y)."""
CROSSING = World(obstacles=[DynamicObstacle.pedestrian((-1.2, 0.6), (1.0, 0.0), 0.3)])
"""A person walking across its way from the left, 0.6 m ahead, at 1 m/s."""


def doomed(below=0.05, within=1.0, **stall) -> PlannerConfig:
    config = PlannerConfig()
    return dataclasses.replace(config, stall=dataclasses.replace(
        config.stall, doomed_below=below, clearance_within=within, **stall))


def gap(trajectory, world, config, within=1.0) -> float:
    """The smallest footprint-to-person gap over the first ``within`` s, from the geometry."""
    steps = round(within / config.horizon.dt)
    return float(exact_geometry(stacked([trajectory]), world, GOAL,
                                config).distance[0, :steps + 1].min())


def test_a_doomed_plan_gives_way_to_the_clearest_of_the_rungs_ways():
    """The law's plan is struck almost surely; the cost takes a dodge that passes 2 cm from
    the person (the bell is 0.2 m wide), the last resort one that keeps 10 cm."""
    law = Planner(doomed(below=0.0, back_up=0.0), SOLVER).plan(DRIVING, CROSSING, GOAL)
    cheapest = Planner(doomed(below=0.0), SOLVER).plan(DRIVING, CROSSING, GOAL)
    cleared = Planner(doomed(), SOLVER).plan(DRIVING, CROSSING, GOAL)
    assert law.status == "sampling" and law.cost.survivability[5] < 0.05     # within 1 s
    assert cheapest.status == "dodging", cheapest.message
    assert cleared.status == "clearing", cleared.message
    assert "the plan is doomed (survival 0.00 < 0.05 within 1 s)" in cleared.message
    assert "the clearest way over 1 s, dodging: turning right" in cleared.message
    config = doomed()
    assert gap(cleared.trajectory, CROSSING, config) > gap(cheapest.trajectory, CROSSING,
                                                           config) + 0.05
    assert cleared.fun > cheapest.fun                     # dearer by the cost: its last resort
    again = evaluate(cleared.trajectory, CROSSING, GOAL, config)
    assert cleared.fun == pytest.approx(float(again.total))
    assert cleared.control == pytest.approx((cleared.trajectory.v[0],
                                             cleared.trajectory.omega[0]))


def test_the_clearest_way_is_the_widest_gap_of_the_plan_the_dodges_and_the_reverses():
    config = doomed()
    cycle = Cycle.prepare(DRIVING, CROSSING, GOAL, config)
    plan = Planner(doomed(below=0.0, back_up=0.0), SOLVER).plan(DRIVING, CROSSING, GOAL)
    cleared = last_resort.clearest(plan, DRIVING, Evaluator(cycle))
    ways = stacked([plan.trajectory, moves.dodge_trajectories(DRIVING, config),
                          moves.back_up_trajectories(DRIVING, config)])
    gaps = passive.clearance(ways, Evaluator(cycle), 1.0)
    assert gaps.shape == (1 + 96 + 3,)
    assert gap(cleared.trajectory, CROSSING, config) == pytest.approx(gaps.max())
    assert gaps.max() > gaps[0]
    # over the whole horizon the gap is the geometry's smallest distance, as the cost reads it
    whole = passive.clearance(ways, Evaluator(cycle), config.horizon.duration)
    np.testing.assert_allclose(whole, evaluate(ways, CROSSING, GOAL, config).min_distance)
    assert np.all(whole <= gaps + 1e-12)
    assert np.all(passive.clearance(ways, Evaluator(Cycle.prepare(DRIVING, World(), GOAL,
                                                                  config)), 1.0) == np.inf)


def test_a_plan_that_is_not_doomed_within_the_second_is_kept():
    config = doomed()
    open_floor = Cycle.prepare(DRIVING, World(), GOAL, config)
    plan = Planner(config, SOLVER).plan(DRIVING, World(), GOAL)
    assert plan.status == "sampling"
    assert last_resort.clearest(plan, DRIVING, Evaluator(open_floor)) is None
    # three abreast walking at it: struck almost surely, but two seconds out, and within the
    # second the cost still tells the ways apart
    later = World(obstacles=[DynamicObstacle.pedestrian((x, 3.5), (0.0, -1.0), 0.3)
                             for x in (-0.7, 0.0, 0.7)])
    plan = Planner(doomed(below=0.0, back_up=0.0), SOLVER).plan(DRIVING, later, GOAL)
    within = float(plan.cost.survivability[round(1.0 / config.horizon.dt)])
    assert plan.cost.survivability[-1] < 0.05 <= within
    cycle = Cycle.prepare(DRIVING, later, GOAL, config)
    assert last_resort.clearest(plan, DRIVING, Evaluator(cycle)) is None
    longer = doomed(within=config.horizon.duration)
    assert last_resort.clearest(plan, DRIVING,
                                Evaluator(Cycle.prepare(DRIVING, later, GOAL, longer))) \
        is not None


def test_a_docked_plan_is_doomed_only_before_the_task_ends():
    """A person crosses the goal 0.6 m ahead within the second, after the docked way has come
    within the task's 0.3 m of it (0.4 s): not doomed there; a followed goal's task does not
    end on arrival, and it is."""
    state, goal = RobotState(0.0, 0.0, 0.0, 0.8, 0.0), (0.6, 0.0)
    crossing = World(obstacles=[DynamicObstacle.pedestrian((0.6, 1.5), (0.0, -1.3), 0.3)])
    docked = Planner(doomed(), SOLVER).plan(state, crossing, goal, goal_tolerance=0.3)
    assert docked.status == "docked" and docked.cost.survivability[5] < 0.05
    assert backup.arrival_time(docked, goal, 0.3, doomed()) == pytest.approx(0.4)
    cycle = Cycle.prepare(state, crossing, goal, doomed())
    assert last_resort.clearest(docked, state, Evaluator(cycle), arrival=0.4) is None
    assert last_resort.clearest(docked, state, Evaluator(cycle)).status == "clearing"  # to 1 s
    followed = Planner(doomed(), SOLVER).plan(state, crossing, goal)
    assert followed.status == "clearing", followed.message
    assert "(survival 0.00 < 0.05 within 1 s)" in followed.message


def test_on_by_default_off_in_the_paper_preset_and_without_the_rung():
    assert PlannerConfig().stall.doomed_below == 0.05
    assert PlannerConfig().stall.clearance_within == 1.0
    assert PlannerConfig.paper().stall.doomed_below == 0.0
    default = Planner(PlannerConfig(), SOLVER).plan(DRIVING, CROSSING, GOAL)
    assert default.status == "clearing", default.message
    off = Planner(doomed(below=0.0), SOLVER).plan(DRIVING, CROSSING, GOAL)
    assert off.status != "clearing"
    no_rung = Planner(doomed(back_up=0.0), SOLVER).plan(DRIVING, CROSSING, GOAL)
    assert no_rung.status == "sampling"


@pytest.mark.parametrize("changes, field", [({"doomed_below": -0.1}, "doomed_below"),
                                            ({"doomed_below": 1.5}, "doomed_below"),
                                            ({"doomed_below": math.nan}, "doomed_below"),
                                            ({"clearance_within": 0.0}, "clearance_within")])
def test_bad_last_resort_settings_are_refused_by_name(changes, field):
    with pytest.raises(InputError, match=field):
        StallConfig(**changes)


def test_a_doomed_plan_that_stays_the_clearest_builds_the_rungs_ways_once(monkeypatch):
    """Where the plan itself keeps the widest gap, the rung goes on to its cheapest way; the
    dodges and reverses the last resort built are the ones it weighs, not built again."""
    config = doomed()
    cycle = Cycle.prepare(DRIVING, CROSSING, GOAL, config)
    plan = Planner(doomed(below=0.0, back_up=0.0), SOLVER).plan(DRIVING, CROSSING, GOAL)
    built = {"dodges": 0, "reverses": 0}

    def counted(name, make):
        def build(*args):
            built[name] += 1
            return make(*args)
        return build

    monkeypatch.setattr(moves, "dodge_trajectories",
                        counted("dodges", moves.dodge_trajectories))
    monkeypatch.setattr(moves, "back_up_trajectories",
                        counted("reverses", moves.back_up_trajectories))
    monkeypatch.setattr(last_resort, "clearance",            # the plan keeps the widest gap
                        lambda ways, evaluator, within: -np.arange(len(ways), dtype=float))
    assert last_resort.clearest(plan, DRIVING, Evaluator(cycle)) is None
    assert built == {"dodges": 1, "reverses": 1}
    built.update(dodges=0, reverses=0)
    chosen = chain.recover(plan, DRIVING, Evaluator(cycle), level=0)
    assert chosen is not None and chosen.status == "dodging", chosen    # the cost's way
    assert built == {"dodges": 1, "reverses": 1}
