"""The planner interface (a Protocol every planner implements) and the strict mode that lets a
stage's exception through instead of a fallback plan (issue 30)."""

import pytest

from dsmpepc_nlp.bench.cv import ConstantVelocityPlanner
from dsmpepc_nlp.core.config import RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import World
from dsmpepc_nlp.solve import planner as planner_module
from dsmpepc_nlp.solve.planner import Planner
from dsmpepc_nlp.solve.policy import PlanningPolicy

SAMPLING = SolverConfig.sampling(n_samples=64)


def test_the_planner_and_the_baselines_are_planning_policies():
    assert isinstance(Planner(solver=SAMPLING), PlanningPolicy)
    assert isinstance(ConstantVelocityPlanner(), PlanningPolicy)
    orca = pytest.importorskip("dsmpepc_nlp.bench.orca")
    pytest.importorskip("pyrvo")
    assert isinstance(orca.OrcaPlanner(), PlanningPolicy)


def test_an_object_without_reset_is_not_a_policy():
    class PlansOnly:
        config = None

        def plan(self, state, world, goal, *, dock=True, sample=False):
            return None

    assert not isinstance(PlansOnly(), PlanningPolicy)


def boom(*args, **kwargs):
    raise TypeError("injected: a refactoring's wrong argument")


@pytest.mark.parametrize("stage", ["Cycle.prepare", "structured_starts"])
def test_strict_reraises_what_a_stage_raises_and_the_default_falls_back(monkeypatch, stage):
    owner, name = stage.split(".") if "." in stage else (None, stage)
    target = getattr(planner_module, owner) if owner else planner_module
    monkeypatch.setattr(target, name, boom)
    state, goal = RobotState(0.0, 0.0, 0.0), (4.0, 0.0)
    with pytest.raises(TypeError, match="injected"):
        Planner(solver=SAMPLING, strict=True).plan(state, World(), goal)
    plan = Planner(solver=SAMPLING, strict=False).plan(state, World(), goal)
    assert not plan.success and "raised TypeError: injected" in plan.message


def test_the_environment_sets_the_default(monkeypatch):
    monkeypatch.setenv("DSMPEPC_STRICT", "1")
    assert Planner(solver=SAMPLING).strict
    monkeypatch.setenv("DSMPEPC_STRICT", "0")
    assert not Planner(solver=SAMPLING).strict
