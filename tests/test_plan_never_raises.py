"""``Planner.plan`` never raises for a finite state and a valid world (issue 14).

Each stage of the chain is made to raise in turn; a finite plan inside the limits comes back and
its message names the stage.
"""

import math

import numpy as np
import pytest

from dsmpepc_nlp.core import control_law
from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import OccupancyGrid, World
from dsmpepc_nlp.solve import planner as planner_module
from dsmpepc_nlp.solve import start_state, verdicts
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.optimize.sampling import SamplingPlanner
from dsmpepc_nlp.solve.planner import Planner

SAMPLING = SolverConfig.sampling(n_samples=64)


@pytest.fixture(autouse=True)
def _fallbacks_on(monkeypatch):
    """These tests are of the fallbacks themselves: planners here are not strict."""
    monkeypatch.setenv("DSMPEPC_STRICT", "0")
LIMITS = PlannerConfig().robot


def boom(*args, **kwargs):
    raise MemoryError("injected")


def assert_finite(plan):
    v, omega = plan.control
    assert math.isfinite(v) and math.isfinite(omega)
    assert 0.0 <= v <= LIMITS.v_limit and abs(omega) <= LIMITS.omega_limit
    assert not math.isnan(plan.fun)
    assert np.all(np.isfinite(plan.x)) and np.all(np.isfinite(plan.trajectory.poses))


def world():
    occupied = np.zeros((60, 60), dtype=bool)
    occupied[20:40, 35:37] = True
    return World(OccupancyGrid(occupied, 0.05))


class FailingNlp:
    def solve(self, cycle, starts, deadline=None):
        raise MemoryError("injected")


STAGES = {
    "the starts": (planner_module, "structured_starts"),
    "the cycle": (Cycle, "prepare"),
    "docking": (Planner, "_docked"),
    "the NLP's verdict": (verdicts, "choose_nlp"),
    "the sampler": (SamplingPlanner, "search"),
    "the sampled verdict": (verdicts, "from_evaluation"),
}


CASES = [(stage, (2.5, 1.5)) for stage in sorted(STAGES)] + [
    (stage, (1.0, 1.5)) for stage in ("the starts", "the cycle", "docking")]  # docking range


@pytest.mark.parametrize(("stage", "goal"), CASES)
def test_a_stage_that_raises_leaves_a_finite_plan(monkeypatch, stage, goal):
    owner, name = STAGES[stage]
    monkeypatch.setattr(owner, name, boom)
    planner = Planner(solver=SAMPLING)
    planner.nlp = FailingNlp() if stage == "the NLP's verdict" else None
    plan = planner.plan(RobotState(0.3, 1.5, 0.0), world(), goal)
    assert_finite(plan)
    if stage != "docking" or goal == (1.0, 1.5):
        assert f"{stage} raised MemoryError: injected" in plan.message and not plan.success


def test_the_nlp_raising_falls_back_to_sampling():
    planner = Planner(solver=SAMPLING)
    planner.nlp = FailingNlp()
    plan = planner.plan(RobotState(0.3, 1.5, 0.0), world(), (2.5, 1.5))
    assert_finite(plan)
    assert plan.status == "sampling-fallback" and "the NLP raised MemoryError" in plan.message


def test_even_the_stop_rollout_failing_leaves_a_finite_plan(monkeypatch):
    monkeypatch.setattr(Cycle, "prepare", boom)
    monkeypatch.setattr(start_state, "rollout", boom)
    plan = Planner(solver=SAMPLING).plan(RobotState(0.3, 1.5, 0.0), world(), (2.5, 1.5))
    assert_finite(plan)
    assert plan.status == "stopped" and plan.control == (0.0, 0.0)


@pytest.mark.parametrize("state", [RobotState(1.0e6, 1.0e6, 0.0), RobotState(-1.0e300, 3.0, 1.0)])
def test_a_robot_far_from_the_map_gets_a_plan(state):
    occupied = np.zeros((200, 200), dtype=bool)
    occupied[50:60, 50:150] = True
    grid_world = World(OccupancyGrid(occupied, 0.05))
    for goal in ((state.x + 1.0, state.y), (0.0, 0.0)):
        plan = Planner(solver=SAMPLING).plan(state, grid_world, goal)
        assert_finite(plan)


def test_the_rollout_module_is_the_one_patched():
    # the stop trajectory's rollout is looked up in the start_state module (what the test
    # above patches), not captured elsewhere
    assert start_state.rollout is control_law.rollout
