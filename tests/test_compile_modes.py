"""No plan waits for a compiler; the paper preset; the map-derived static uncertainty."""

import dataclasses
import math
import time

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotConfig, RobotState
from dsmpepc_nlp.core.cost_config import CostConfig, SmoothingConfig
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.world import OccupancyGrid, World
from dsmpepc_nlp.solve import problem as g
from dsmpepc_nlp.solve.build import background, compiled
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.planner import Planner
from dsmpepc_nlp.solve.problem import parameters as settings

needs_compiler = pytest.mark.skipif(not compiled.compiling_possible(),
                                    reason="no C compiler (or compilation off)")


@needs_compiler
def test_background_mode_plans_with_the_sampler_while_the_library_compiles(tmp_path,
                                                                           monkeypatch):
    """A structure not compiled yet: the plan comes from the sampler at once (its own status,
    a message that says so, a finite plan) while a child process compiles; once the library
    is there the NLP plans."""
    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path))
    config = PlannerConfig(robot=RobotConfig(footprint=((0.1, 0.0, 0.25), (-0.1, 0.0, 0.25))))
    planner = Planner(config, compile="background")
    state, world, goal = (0.0, 0.0, 0.0), World(), (4.0, 0.5)
    first = planner.plan(state, world, goal, dock=False)
    assert first.status == "sampling-compiling"
    assert "compiling in the background" in first.message
    assert first.success and np.all(np.isfinite(first.x)) and np.isfinite(first.fun)
    deadline = time.monotonic() + 600
    while True:
        ready, _ = planner.nlp.readiness(Cycle.prepare(RobotState(*state), world, goal,
                                                       config))
        if ready or time.monotonic() > deadline:
            break
        time.sleep(0.5)
    assert ready, "the background compile did not finish in 10 minutes"
    assert planner.plan(state, world, goal, dock=False).status == "nlp"


def test_wait_mode_and_a_bad_mode(monkeypatch):
    assert Planner(compile="wait").compile == "wait"
    monkeypatch.setenv("DSMPEPC_COMPILE", "later")
    with pytest.raises(InputError, match="DSMPEPC_COMPILE"):
        Planner()


@needs_compiler
def test_a_failed_background_compile_is_retried_then_left_to_the_planner(tmp_path,
                                                                         monkeypatch):
    """A child that failed is started again (not ready meanwhile); after MAX_TRIES failures
    the library is ready to be built by the planner itself, with one warning; one child runs
    at a time."""
    from dsmpepc_nlp.core.solver_config import SolverConfig
    from dsmpepc_nlp.solve.build import library as problem

    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path))           # nothing is cached
    monkeypatch.setattr(problem, "_BUILT", set())                     # nor built by a test
    monkeypatch.setattr(background, "_CHILDREN", {})
    monkeypatch.setattr(background, "_TRIES", {})
    warned, spawned = [], []
    monkeypatch.setattr(background, "warn_once", lambda key, message: warned.append(message))

    class Child:
        stderr = None

        def __init__(self, code):
            self.code = code

        def poll(self):
            return self.code

    def spawn(key, *args):
        spawned.append(key)
        background._CHILDREN[key] = (Child(None), time.monotonic())     # running

    monkeypatch.setattr(background, "_spawn", spawn)
    config, solver = PlannerConfig(), SolverConfig()
    sizes, other = g.GraphSizes(pose_objects=4), g.GraphSizes(pose_objects=12)
    key = problem.library_key(config, sizes, solver)
    assert problem.readiness(config, sizes, solver)[0] is False and spawned == [key]
    ready, note = problem.readiness(config, other, solver)      # the one slot is taken
    assert not ready and "waits for another" in note and len(spawned) == 1
    background._CHILDREN[key] = (Child(1), time.monotonic())         # the first try failed
    assert problem.readiness(config, sizes, solver)[0] is False and spawned == [key, key]
    background._CHILDREN[key] = (Child(1), time.monotonic())         # the second too
    assert problem.readiness(config, sizes, solver) == (True, "")
    assert warned and "failed" in warned[0]


def test_paper_preset_is_the_paper_and_the_variants():
    paper = PlannerConfig.paper()
    assert paper.anticipatory_pc and paper.terminal_cost
    assert not paper.cost.sigma_static_from_map
    assert paper.cost.sigma_static == 0.1 and paper.cost.s_ttc == 0.5 and paper.cost.a == 0.7
    mpepc = PlannerConfig.paper("mpepc")
    assert not mpepc.anticipatory_pc and not mpepc.terminal_cost
    with pytest.raises(InputError, match="variant"):
        PlannerConfig.paper("mpc")


def _grid(resolution):
    occupied = np.zeros((40, 40), dtype=bool)
    occupied[:, :2] = True
    return OccupancyGrid(occupied, resolution, (0.0, 0.0))


def test_static_uncertainty_from_the_map():
    on = PlannerConfig(cost=CostConfig(sigma_static_from_map=True, localisation_std=0.03))
    expected = math.sqrt(0.05 ** 2 / 12 + 0.03 ** 2)
    assert on.for_map(0.05).cost.sigma_static == pytest.approx(expected, rel=1e-15)
    assert on.for_map(None) is on                          # no map: the configured value
    off = PlannerConfig.paper()
    assert off.for_map(0.05) is off
    assert PlannerConfig().cost.sigma_static_from_map      # the product's default
    # Every evaluator of a cycle reads the derived value: the cycle's configuration, the
    # kernel's parameter vector and the graph's settings block.
    world = World(_grid(0.05))
    cycle = Cycle.prepare(RobotState(1.0, 1.0, 0.0), world, (1.5, 1.0), on)
    assert cycle.config.cost.sigma_static == pytest.approx(expected, rel=1e-15)
    from dsmpepc_nlp.solve.exact.cycle import PARAMETERS

    assert cycle.parameters[PARAMETERS.index("sigma_static")] == cycle.config.cost.sigma_static
    packed = g.pack_parameters(cycle, g.GraphSizes(max_objects=1, table_cells=48))
    names = settings.names(on)
    assert packed["settings"][names.index("cost.sigma_static")] == \
        cycle.config.cost.sigma_static


def test_the_exact_cost_reads_the_derived_uncertainty():
    from dsmpepc_nlp.core.control_law import rollout
    from dsmpepc_nlp.core.exact_cost import evaluate

    world = World(_grid(0.05))
    state, goal = RobotState(0.6, 2.0, 0.0), (1.8, 2.0)
    z = np.array([[1.0, 0.0, 0.0, 0.5], [1.0, 0.6, 0.0, 0.5]])
    on = PlannerConfig(cost=CostConfig(sigma_static_from_map=True))
    by_hand = dataclasses.replace(PlannerConfig(), cost=CostConfig(
        sigma_static=on.for_map(0.05).cost.sigma_static, sigma_static_from_map=False))
    a = evaluate(rollout(z, state, on), world, goal, on).total
    b = evaluate(rollout(z, state, by_hand), world, goal, by_hand).total
    np.testing.assert_array_equal(a, b)
    paper = PlannerConfig.paper()
    c = evaluate(rollout(z, state, paper), world, goal, paper).total
    assert not np.array_equal(a, c)


def test_an_exact_smoothing_override_is_built_in_not_a_parameter():
    config = PlannerConfig()
    assert settings.structure(config, SmoothingConfig.exact()) != settings.structure(config)
    assert settings.structure(config, config.smoothing) == settings.structure(config)
