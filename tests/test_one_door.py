"""One door to the exact cost (issue 67): every stage of ``Planner.plan`` that costs or measures a
trajectory exactly goes through the plan's :class:`Evaluator` (``planner.last_evaluator``).

The exact cost's entry points are wrapped wherever they are looked up (each module imports them by
name): the numpy reference ``core.exact_cost.evaluate``, its geometry ``exact_geometry`` and
``circle_gaps``, the compiled kernel's pass ``solve.exact.loader.kernel_pass`` and the evaluator's
numpy path ``_evaluate_numpy``. Each call is recorded with the innermost :class:`Evaluator` method
on the calling thread's stack (None: outside the door). Over plans that dock (straight and behind a
turn in place), solve the NLP, fall back to the sampler, climb the stall ladder's rung (a reverse,
a dodge, a turn in place) and reach its last resort (the clearest way, and the passive one), every
call must be made inside the plan's evaluator, and what the wrappers saw must be what the evaluator
counted: the rows of the z path (``rows_costed``), the behaviours' trajectories costed
(``trajectories_costed``) and measured (``trajectories_measured``).

Not covered: the Lemma 3 brake (``start_state.braking_plan``) costs its one stop trajectory
with ``core.exact_cost.evaluate`` before any cycle exists, where the robot already overlaps
someone and no other stage runs; every plan here starts clear.
"""

import dataclasses
import functools
import math
import sys
import threading

import pytest

import dsmpepc_nlp.core.exact_cost as exact_cost
import dsmpepc_nlp.solve.exact.evaluator as evaluator_module
import dsmpepc_nlp.solve.exact.loader as loader
from dsmpepc_nlp.core.config import PlannerConfig, RobotState, StallConfig
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.solve import planner as planner_module
from dsmpepc_nlp.solve.exact.evaluator import Evaluator
from dsmpepc_nlp.solve.planner import Planner

SOLVER = SolverConfig.sampling(n_samples=256)

ENTRY_POINTS = {"evaluate": exact_cost.evaluate, "exact_geometry": exact_cost.exact_geometry,
                "circle_gaps": exact_cost.circle_gaps, "kernel_pass": loader.kernel_pass,
                "cost_given": loader.cost_given,
                "_evaluate_numpy": evaluator_module._evaluate_numpy}
DOORS = {f.__code__: name for name, f in vars(Evaluator).items() if callable(f)
         and hasattr(f, "__code__")}
"""The code of every method of Evaluator, by name."""

COUNTED = {"rows_costed": {("kernel_pass", "_cost"), ("_evaluate_numpy", "_cost")},
           "trajectories_costed": {("evaluate", "evaluate_trajectories"),
                                   ("cost_given", "evaluate_trajectories")},
           "trajectories_measured": {("exact_geometry", "geometry"),
                                     ("circle_gaps", "circle_gaps")}}
"""Which (entry point, Evaluator method) calls each of the evaluator's counters counts."""


def rows(name, args) -> int:
    """The trajectories (or z) of a call: its batch's length, 1 for a single trajectory."""
    if name == "circle_gaps":                           # (world, config, points, times)
        return len(args[2])
    first = args[0]
    if name in ("evaluate", "exact_geometry", "cost_given"):
        return 1 if first.poses.ndim == 2 else len(first.poses)
    return len(first)                                   # z


def innermost_door():
    """``(evaluator, method)`` of the innermost Evaluator method on this thread's stack."""
    frame = sys._getframe(2)
    while frame is not None:
        method = DOORS.get(frame.f_code)
        if method is not None:
            return frame.f_locals.get("self"), method
        frame = frame.f_back
    return None, None


@pytest.fixture
def calls(monkeypatch):
    """Every call into the exact cost's entry points once a plan's start-in-collision check
    is over (before it: the kernel's warm-up, once a process): ``(entry, evaluator, method,
    rows)``."""
    seen, lock, checked = [], threading.Lock(), threading.Event()

    def counting(name, original):
        @functools.wraps(original)
        def wrapper(*args, **kwargs):
            if checked.is_set():
                door, method = innermost_door()
                with lock:
                    seen.append((name, door, method, rows(name, args)))
            return original(*args, **kwargs)
        return wrapper

    def start_overlap(*args, **kwargs):
        overlap = original_overlap(*args, **kwargs)
        checked.set()
        return overlap

    original_overlap = planner_module.start_overlap
    monkeypatch.setattr(planner_module, "start_overlap", start_overlap)

    by_id = {id(f): (name, counting(name, f)) for name, f in ENTRY_POINTS.items()}
    patched = set()
    for module_name, module in list(sys.modules.items()):
        if not module_name.startswith("dsmpepc_nlp") or module is None:
            continue
        for attribute, value in list(vars(module).items()):
            if id(value) in by_id:
                monkeypatch.setattr(module, attribute, by_id[id(value)][1])
                patched.add(by_id[id(value)][0])
    assert patched == set(ENTRY_POINTS)
    return seen


class NoNlp:
    """An NLP whose every start fails (it returns none): the sampler falls back."""

    kernel_loading = False

    def solve(self, evaluator, starts, deadline=None):
        return ()


def stall(**changes) -> PlannerConfig:
    config = PlannerConfig()
    return dataclasses.replace(config, stall=dataclasses.replace(config.stall, **changes))


def converging(reach: float) -> World:
    """Four people walking at the robot from every side (tests/test_passive.py)."""
    return World(obstacles=[
        DynamicObstacle.pedestrian((0.0, reach), (0.0, -1.4), 0.3),
        DynamicObstacle.pedestrian((0.3 - reach, 0.4), (1.4, 0.0), 0.3),
        DynamicObstacle.pedestrian((reach - 0.3, 0.4), (-1.4, 0.0), 0.3),
        DynamicObstacle.pedestrian((0.0, 0.2 - reach), (0.0, 1.4), 0.3)])


DRIVING = RobotState(0.0, 0.0, math.pi / 2, 0.9, 0.0)
CASES = {
    # name: (config, solver, state, world, goal, plan's keywords, status, in its message)
    "docked": (PlannerConfig(), SOLVER, RobotState(2.0, 0.0, 0.0), World(), (3.0, 0.0), {},
               "docked", "heading straight"),
    "docked behind a turn": (PlannerConfig(), SOLVER, RobotState(2.0, 0.0, 3.1), World(),
                             (3.0, 0.0), {}, "docked", "turning in place"),
    "nlp": (PlannerConfig(), SolverConfig(), RobotState(0.0, 0.0, 0.0),
            World(obstacles=[DynamicObstacle.pedestrian((2.0, 0.5), (-0.5, 0.0), 0.3)]),
            (5.0, 0.0), {"dock": False, "time_budget": None}, "nlp", "NLP"),
    "sampling-fallback": (PlannerConfig(), SOLVER, RobotState(0.0, 0.0, 0.0), World(),
                          (5.0, 0.0), {"dock": False}, "sampling-fallback", "every NLP"),
    "reverse": (PlannerConfig(stall=StallConfig(back_up=0.3, back_up_level=0)), SOLVER,
                RobotState(0.0, 0.0, 0.0),
                World(obstacles=[DynamicObstacle.pedestrian((0.65, 0.0), (0.0, 0.0), 0.3)]),
                (5.0, 0.0), {}, "backing-up", "backing up"),
    "dodge": (PlannerConfig(), SOLVER, RobotState(0.0, 0.0, 0.0, 0.3, 0.0),
              World(obstacles=[DynamicObstacle.pedestrian((-1.2, 0.0), (1.3, 0.0), 0.3)]),
              (5.0, 0.0), {}, "dodging", "dodging"),
    "turn": (stall(turn_level=0), SOLVER, RobotState(0.0, 0.0, math.pi, 0.05, 0.0), World(),
             (3.0, 0.5), {"dock": False}, "turning", "turning in place"),
    "clearest": (PlannerConfig(), SOLVER, DRIVING,
                 World(obstacles=[DynamicObstacle.pedestrian((-1.2, 0.6), (1.0, 0.0), 0.3)]),
                 (0.0, 6.0), {}, "clearing", "the clearest way"),
    "passive": (PlannerConfig(), SOLVER, DRIVING, converging(1.6), (0.0, 6.0), {}, "clearing",
                "drives least toward"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_every_exact_cost_of_a_plan_goes_through_its_evaluator(calls, case):
    config, solver, state, world, goal, keywords, status, said = CASES[case]
    planner = Planner(config, solver)
    if case == "sampling-fallback":
        planner.nlp = NoNlp()
    plan = planner.plan(state, world, goal, **keywords)
    assert plan.status == status and said in plan.message, plan.message
    evaluator = planner.last_evaluator
    outside = sorted({(name, method) for name, door, method, _ in calls if door is None})
    assert not outside, f"costed outside the evaluator: {outside}"
    assert all(door is evaluator for _, door, _, _ in calls)
    for counter, routes in COUNTED.items():
        seen = sum(n for name, _, method, n in calls if (name, method) in routes)
        assert seen == getattr(evaluator, counter), counter
    assert (evaluator.rows_costed > 0) == (case != "docked behind a turn")    # z: the law's
    behaviour = case not in ("docked", "nlp", "sampling-fallback")
    assert (evaluator.trajectories_costed > 0) == behaviour
    assert (evaluator.trajectories_measured > 0) == (case in ("clearest", "passive"))
