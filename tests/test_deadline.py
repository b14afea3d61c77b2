"""A plan by its deadline: the time budget's settings, what a spent budget cuts (no solve, polish
round, sampler chunk or recovery starts after it) and that a budget that never runs out changes
no plan. How late a plan may be on a loaded machine is measured by the benchmarks' tables
(``plan_time_max``, ``plans_out_of_time``), not here."""

import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.deadline import BUDGET_VARIABLE, Deadline, budget_seconds, is_budget
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.solve.build.library import NOT_RUN
from dsmpepc_nlp.solve.exact import loader as exact
from dsmpepc_nlp.solve.optimize import sampling
from dsmpepc_nlp.solve.optimize.ipopt import WALL_LIMITS, wall_limit
from dsmpepc_nlp.solve.optimize.multistart import SOLVES
from dsmpepc_nlp.solve.plan import STATUSES
from dsmpepc_nlp.solve.planner import Planner

SPENT = 1e-9
"""A budget spent before the plan's first stage ends."""


def _scene():
    people = [DynamicObstacle.pedestrian((2.0 + 0.5 * i, (-1) ** i * 0.6), (-0.5, 0.0), 0.3)
              for i in range(4)]
    return RobotState(0.0, 0.0, 0.0, 0.3, 0.0), World(None, people), np.array([6.0, 0.0])


def test_the_default_budget_is_three_quarters_of_the_period_at_most_0_2_s(monkeypatch):
    monkeypatch.delenv(BUDGET_VARIABLE, raising=False)      # (the suite sets none)
    assert SolverConfig().time_budget == "auto"
    assert budget_seconds("auto", 0.2) == pytest.approx(0.15)
    assert budget_seconds("auto", 1.0) == pytest.approx(0.2)
    assert budget_seconds(None, 0.2) == math.inf
    assert budget_seconds(0.05, 0.2) == 0.05
    monkeypatch.setenv(BUDGET_VARIABLE, "0.05")             # what "auto" means, elsewhere
    assert budget_seconds("auto", 0.2) == 0.05 and budget_seconds(0.1, 0.2) == 0.1
    monkeypatch.setenv(BUDGET_VARIABLE, "none")
    assert budget_seconds("auto", 0.2) == math.inf
    monkeypatch.setenv(BUDGET_VARIABLE, "soon")
    with pytest.raises(InputError, match=BUDGET_VARIABLE):
        budget_seconds("auto", 0.2)


@pytest.mark.parametrize("bad", [0, -0.1, math.nan, "soon", True, [0.1]])
def test_a_bad_budget_is_refused_naming_the_field(bad):
    assert not is_budget(bad)
    with pytest.raises(InputError, match="SolverConfig.time_budget"):
        SolverConfig(time_budget=bad)
    state, world, goal = _scene()
    with pytest.raises(InputError, match="time_budget"):
        Planner(PlannerConfig(), SolverConfig.sampling(n_samples=64)).plan(
            state, world, goal, time_budget=bad)


def test_a_deadline_records_each_cut_stage_once():
    deadline = Deadline(SPENT)
    assert deadline.left() < 0.0
    assert not deadline.check("a") and not deadline.check("a") and not deadline.check("b")
    assert deadline.cut == ["a", "b"]
    never = Deadline()
    assert never.check("a") and never.left() == math.inf and never.cut == []


def test_ipopts_wall_limit_is_the_largest_built_one_the_time_left_allows():
    assert wall_limit(math.inf) is None
    assert wall_limit(0.001) == 0.0                       # no time for a solve: not run
    assert wall_limit(0.149) == 0.1
    assert wall_limit(0.15) == 0.15
    assert wall_limit(100.0) == WALL_LIMITS[-1]
    assert all(wall_limit(w) == w for w in WALL_LIMITS)


@pytest.mark.parametrize("method", ["nlp", "fast"])
def test_a_spent_budget_runs_no_solve_and_no_polish_and_says_so(method):
    planner = Planner(PlannerConfig(), SolverConfig.named(method))
    planner.prepare(4)
    state, world, goal = _scene()
    plan = planner.plan(state, world, goal, dock=False, time_budget=SPENT)
    assert plan.status == "deadline" and not plan.success
    assert SOLVES in plan.cut and {"the last resort", "the moves"} <= set(plan.cut)
    assert "time budget" in plan.message
    solved = [r for r in plan.starts if r.status != "screened"]
    assert solved and all(r.status == NOT_RUN for r in solved)    # every solve skipped
    assert not any(r.name == "polish" for r in plan.starts)
    # The plan is the best screened start by its exact cost: a candidate like any other.
    best = min(r.exact_cost for r in plan.starts if math.isfinite(r.exact_cost))
    assert plan.fun == pytest.approx(best)
    assert np.all(np.isfinite(plan.control)) and np.all(np.isfinite(plan.x))


def test_a_spent_budget_costs_one_chunk_of_the_samplers_rows():
    state, world, goal = _scene()
    plans = {}
    for budget in (None, SPENT):
        planner = Planner(PlannerConfig(), SolverConfig.sampling())
        planner.prepare()
        if exact.kernel() is None:
            pytest.skip("the numpy path costs the sampler's rows in one batch, unchunked")
        plans[budget] = planner.plan(state, world, goal, dock=False, time_budget=budget)
    full, cut = plans[None], plans[SPENT]
    assert cut.status == "deadline" and sampling.STAGE in cut.cut
    n = len(cut.evaluated.z)
    assert n == sampling.CHUNK < len(full.evaluated.z)
    # the chunk's rows cost what they cost in the full batch, and the best of them is the plan
    np.testing.assert_array_equal(cut.evaluated.z, full.evaluated.z[:n])
    np.testing.assert_array_equal(cut.evaluated.costs.total, full.evaluated.costs.total[:n])
    assert cut.fun == pytest.approx(np.min(full.evaluated.costs.total[:n]))


@pytest.mark.parametrize("method", ["sampling", "fast", "nlp"])
def test_a_budget_that_never_runs_out_changes_no_plan(method):
    state, world, goal = _scene()
    plans = {}
    for budget in (None, 100.0):
        planner = Planner(PlannerConfig(), SolverConfig.named(method))
        planner.prepare(4)
        plans[budget] = [planner.plan(state, world, goal, time_budget=budget)
                         for _ in range(3)]
    for a, b in zip(plans[None], plans[100.0]):
        np.testing.assert_array_equal(a.x, b.x)
        assert a.status == b.status and a.cut == b.cut == ()


def test_deadline_is_a_status_appended_last():
    assert STATUSES[-1] == "deadline"


def test_a_stage_that_cannot_stop_runs_only_when_the_time_left_covers_its_last_run():
    """The moves once took 1 s: with 0.5 s they are skipped (and cut), and what is expected of
    them shrinks each plan, run or skipped, so one slow run does not keep them off for good."""
    planner = Planner(PlannerConfig(), SolverConfig.sampling(n_samples=64))
    state, world, goal = _scene()
    planner._took["the moves"] = 1.0
    plan = planner.plan(state, world, goal, dock=False, time_budget=0.5)
    assert "the moves" in plan.cut
    assert planner._took["the moves"] == pytest.approx(0.95)
    plan = planner.plan(state, world, goal, dock=False, time_budget=None)
    assert plan.cut == () and planner._took["the moves"] < 0.95 * 0.95 + 1e-9
