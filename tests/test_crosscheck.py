"""The cross-check and benchmark report shapes (tiny runs; speed is never asserted)."""
import math

import numpy as np
import pytest

from dsmpepc_nlp.bench.crosscheck import CrosscheckResult, crosscheck
from dsmpepc_nlp.bench.scenes import demo_cycles
from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import World


def test_demo_cycles_are_reproducible_and_move_the_robot():
    config = PlannerConfig()
    first = demo_cycles(config, 3, seed=4, n_samples=64)
    second = demo_cycles(config, 3, seed=4, n_samples=64)
    assert len(first) == 3
    assert len(first[0][1].obstacles) == 12 and first[0][1].grid is not None
    for (s1, _, g1), (s2, _, g2) in zip(first, second):
        assert s1 == s2 and np.array_equal(g1, g2)


def test_crosscheck_summary_fields():
    config = PlannerConfig()
    cycles = demo_cycles(config, 1, seed=0, n_samples=64)
    solver = SolverConfig().replace(n_spread=0, max_iter=5)
    result = crosscheck(cycles, config, solver, n_samples=256)
    summary = result.to_dict()
    assert set(summary) >= {"cycles", "gap_median", "gap_p95", "share_within_tol"}
    assert summary["cycles"] == 1
    assert np.allclose(result.gap, result.nlp_cost - result.sampled_cost)


def test_share_within_tol_counts_non_finite_as_miss():
    result = CrosscheckResult(np.array([1.0, math.nan]), np.array([1.0, 1.0]),
                              np.array([0.0, math.nan]))
    assert result.share_within_tol == 0.5


def test_the_share_where_the_nlp_plans_leaves_out_the_docked_cycles():
    gap = np.array([0.0, 0.5, 0.0, 0.2])
    zeros = np.zeros(4)
    docked = CrosscheckResult(zeros, zeros, gap, docked=np.array([False, True, False, False]))
    assert docked.share_within_tol == 0.5                 # every cycle: the headline
    assert docked.share_within_tol_undocked == pytest.approx(2 / 3)
    assert docked.to_dict()["docked_cycles"] == 1
    assert "within 0.01: 50.0% (the planner docks in 1" in docked.describe()
    assert "in the other 3: 66.7%" in docked.describe()
    assert math.isnan(CrosscheckResult(zeros, zeros, gap).share_within_tol_undocked)


def test_a_cycle_near_a_free_fixed_goal_is_one_the_planner_docks_in():
    """The planner's own docking test flags the cycle 1.5 m from a goal on an empty floor, not
    one 20 m away, and none where the planner would not dock (``dock=False``)."""
    config = PlannerConfig()
    state = RobotState(0.0, 0.0, 0.0)
    cycles = [(state, World(), np.array([1.5, 0.0])), (state, World(), np.array([20.0, 0.0]))]
    solver = SolverConfig().replace(n_spread=0, max_iter=5)
    result = crosscheck(cycles, config, solver, n_samples=64)
    assert result.docked.tolist() == [True, False]
    assert not crosscheck(cycles, config, solver, n_samples=64, dock=False).docked.any()


def test_run_bench_shape():
    from dsmpepc_nlp.bench.timing import run_bench

    result = run_bench(n_cycles=1, ladder=(64,))
    for name in ("default", "fast", "sampling"):
        assert {"median_ms", "p95_ms"} <= set(result[name])
    for name in ("default", "fast"):
        assert result[name]["solves_per_plan"] >= 1
        assert result[name]["derivative_evaluations"] >= 1
        assert {"polish_gain_median", "polish_gain_share"} <= set(result[name])
        row = result[name]    # the solver's runs are a part of the plan, not all of it
        assert 0 < row["solver_ms"] < row["median_ms"]
    assert math.isfinite(result["ratio_default_to_sampling"])
    assert isinstance(result["table"], str)
    fresh = result["fresh_process"]
    assert fresh["first_plan_ms"] > fresh["plan_ms"] > 0
    # where the children had no bytecode, the installed case is measured beside it
    assert fresh["bytecode"] or fresh["with_bytecode"]["bytecode"]


def test_the_fresh_process_figure_says_whether_modules_came_from_bytecode(monkeypatch,
                                                                          tmp_path):
    """With bytecode neither written nor found (PYTHONDONTWRITEBYTECODE and an empty bytecode
    folder) the children compile every module's source; the bench then measures the installed
    case too, with a bytecode folder of its own, and labels both."""
    from dsmpepc_nlp.bench.timing import fresh_first_plan, fresh_lines

    monkeypatch.setenv("PYTHONDONTWRITEBYTECODE", "1")
    monkeypatch.setenv("PYTHONPYCACHEPREFIX", str(tmp_path / "empty"))
    monkeypatch.setenv("DSMPEPC_NO_COMPILE", "1")   # the children plan in CasADi's VM
    config = PlannerConfig()
    fresh = fresh_first_plan(demo_cycles(config, 1, 0, n_samples=64)[0], config, runs=1)
    assert fresh["bytecode"] is False
    assert fresh["with_bytecode"]["bytecode"] is True
    assert not (tmp_path / "empty").exists()       # nothing was written where it may not be
    table = "\n".join(fresh_lines(fresh))
    assert "modules from source" in table and "modules from bytecode" in table


def test_bench_summary_reports_the_first_plan_beside_median_and_p95():
    from dsmpepc_nlp.bench.timing import _summary

    summary = _summary([0.30, 0.02, 0.01, 0.03])
    assert summary["first_ms"] == pytest.approx(300.0)
    assert summary["median_ms"] == pytest.approx(25.0)


def test_polish_gain_is_what_the_polish_record_beat():
    from dsmpepc_nlp.bench.timing import polish_gain
    from dsmpepc_nlp.solve.plan import StartRecord

    def record(name, cost):
        z = np.zeros(4)
        return StartRecord(name, z, z, "screened", False, 0, 0.0, math.nan, cost)

    starts = (record("warm", -1.0), record("screen-0", -1.5), record("polish", -1.75))
    assert polish_gain(starts) == pytest.approx(0.25)
    assert polish_gain(starts[:2]) == 0.0
    assert math.isnan(polish_gain(()))


def test_bench_ipopt_options_parse_and_are_checked():
    from dsmpepc_nlp.bench.params import parse_ipopt_options as ipopt_options
    from dsmpepc_nlp.core.errors import InputError

    assert ipopt_options(["max_soc=4", "nlp_scaling_method=gradient-based"]) == (
        ("ipopt.max_soc", 4), ("ipopt.nlp_scaling_method", "gradient-based"))
    assert ipopt_options([]) == ()
    for bad in (["max_soc"], ["max_soc=x"], ["no_such_option=1"]):
        with pytest.raises(InputError, match="--ipopt-option"):
            ipopt_options(bad)
