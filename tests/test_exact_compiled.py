"""The compiled exact evaluator agrees with the numpy reference on every output (1e-9).

Random cycles (hypothesis): both variants and both ablations, terms switched off, multi-circle
footprints, robots of several circles among the obstacles, maps or none, obstacles or none,
states outside the limits, goals on the robot, and z on every bound of the box (rho -> 0,
v_max = 0) next to random ones.
"""

import dataclasses
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dsmpepc_nlp.core import compile_cache as cache
from dsmpepc_nlp.core.config import VARIANTS, PlannerConfig, RobotConfig, RobotState
from dsmpepc_nlp.core.cost_config import CostConfig
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.terms import TERM_NAMES
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World
from dsmpepc_nlp.solve.exact import loader as exact
from dsmpepc_nlp.solve.exact.cycle import PARAMETERS, Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator, evaluate_batch

needs_kernel = pytest.mark.skipif(exact.kernel() is None,
                                  reason="compiled evaluator off (numba missing or "
                                  "DSMPEPC_NO_COMPILE=1)")

FIELDS = ("survivability", "min_distance")


def assert_same(compiled, reference, tol=1e-9):
    """Every output of two Evaluations within ``tol`` (relative above 1); infinities equal."""
    pairs = [("total", compiled.costs.total, reference.costs.total)]
    pairs += [(name, compiled.costs.terms[name], reference.costs.terms[name])
              for name in TERM_NAMES]
    pairs += [(name, getattr(compiled.costs, name), getattr(reference.costs, name))
              for name in FIELDS]
    # Times are compared as their inverses (what the cost reads), finite even for "never".
    pairs += [(name, 1.0 / getattr(compiled.costs, name), 1.0 / getattr(reference.costs, name))
              for name in ("ttg", "ttc_terminal")]
    pairs += [(name, getattr(compiled.trajectories, name), getattr(reference.trajectories, name))
              for name in ("poses", "v", "omega", "target")]
    for name, a, b in pairs:
        np.testing.assert_allclose(a, b, rtol=tol, atol=tol, err_msg=name)


def edge_z(config, rng, n_random=24):
    """Every corner of the z box, rho -> 0 and v_max = 0 rows, and random rows."""
    lower, upper = np.array(config.z_lower), np.array(config.z_upper)
    corners = np.array([[(lower if (i >> j) & 1 else upper)[j] for j in range(4)]
                        for i in range(16)])
    special = np.array([[lower[0], 0.0, 0.0, upper[3]], [lower[0], upper[1], lower[2], 0.0],
                        [upper[0], 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, upper[3]]])
    return np.vstack([corners, special, lower + rng.random((n_random, 4)) * (upper - lower)])


@st.composite
def cycles(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    variant = draw(st.sampled_from(sorted(VARIANTS)))
    n_circles = draw(st.integers(1, 3))
    footprint = tuple((float(rng.uniform(-0.3, 0.3)) * (i > 0), float(rng.uniform(-0.2, 0.2))
                       * (i > 0), float(rng.uniform(0.1, 0.35))) for i in range(n_circles))
    robot = RobotConfig(footprint=footprint, accel_limit=draw(st.sampled_from([1.5, math.inf])),
                        alpha_limit=draw(st.sampled_from([3.0, math.inf])))
    disabled = tuple(name for name in TERM_NAMES if draw(st.booleans()) and rng.random() < 0.3)
    cost = CostConfig(disabled=disabled, sigma_static=float(rng.uniform(0.05, 0.3)),
                      sigma_dynamic=float(rng.uniform(0.1, 0.4)),
                      s_ttg=draw(st.sampled_from([1e-3, 0.3])),
                      sigma_dynamic_growth=draw(st.sampled_from([0.0, 0.16])))
    config = PlannerConfig.variant(variant, robot=robot, cost=cost)
    grid = None
    if draw(st.booleans()):
        occupied = rng.random((int(rng.integers(1, 40)), int(rng.integers(1, 40)))) < 0.15
        grid = OccupancyGrid(occupied, float(rng.uniform(0.1, 0.4)),
                             rng.uniform(-6.0, -1.0, 2))
    obstacles = []
    for _ in range(draw(st.integers(0, 5))):
        if rng.random() < 0.3:
            body = [(float(rng.uniform(-0.4, 0.4)), float(rng.uniform(-0.3, 0.3)),
                     float(rng.uniform(0.1, 0.4))) for _ in range(int(rng.integers(1, 4)))]
            obstacles.append(DynamicObstacle.robot(
                (*rng.uniform(-6, 6, 2), rng.uniform(-3, 3)), rng.uniform(-1.5, 1.5, 2), body))
        else:
            obstacles.append(DynamicObstacle.pedestrian(rng.uniform(-6, 6, 2),
                                                        rng.uniform(-1.5, 1.5, 2),
                                                        float(rng.uniform(0.1, 0.5))))
    state = RobotState(*rng.uniform(-2, 2, 2), float(rng.uniform(-4, 4)),
                       float(rng.uniform(-0.5, 1.5)), float(rng.uniform(-2, 2)))
    goal = (state.x, state.y) if rng.random() < 0.1 else tuple(rng.uniform(-6, 6, 2))
    return Cycle.prepare(state, World(grid, obstacles), goal, config), edge_z(config, rng)


@needs_kernel
@settings(max_examples=200)
@given(cycles())
def test_compiled_equals_numpy_on_random_cycles(case):
    cycle, z = case
    reference = evaluate_batch(z, cycle, compiled=False)
    compiled = evaluate_batch(z, cycle, compiled=True)
    assert_same(compiled, reference)            # one thread
    assert_same(evaluate_batch(z, cycle, compiled=True, parallel_rows=1), reference)  # all
    # The totals alone (the multistart's path) are the full evaluation's, to the bit, and a
    # batch costed once is read back, not costed again.
    for solver in (SolverConfig(), SolverConfig().replace(parallel_rows=1)):
        evaluator = Evaluator(cycle, solver)
        np.testing.assert_array_equal(evaluator.totals(z), compiled.costs.total)
        assert_same(evaluator.evaluate(z), compiled, tol=0.0)
        assert evaluator.rows_costed == len(z)


@needs_kernel
def test_overlap_and_far_objects():
    """Starting inside a pedestrian and beside a wall; some objects beyond reach (culled)."""
    occupied = np.zeros((30, 30), bool)
    occupied[:, 14:16] = True
    far = [DynamicObstacle.pedestrian((40.0 + i, 0.0), (-0.5, 0.0)) for i in range(3)]
    world = World(OccupancyGrid(occupied, 0.1, (-1.5, -1.5)),
                  [DynamicObstacle.pedestrian((0.1, 0.0), (0.0, 0.0)), *far])
    for config in (PlannerConfig.ds_mpepc(), PlannerConfig.mpepc()):
        cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.0), world, (1.0, 1.0), config)
        assert not cycle.in_reach[1:].any() and cycle.in_reach[0]
        z = edge_z(config, np.random.default_rng(1), 200)
        compiled = evaluate_batch(z, cycle, compiled=True)
        assert_same(compiled, evaluate_batch(z, cycle, compiled=False))
        assert np.all(compiled.costs.survivability[:, 0] == 0.0)


@needs_kernel
def test_min_distance_reaches_culled_objects():
    """With only far objects, the smallest distance still comes from them (exactly)."""
    world = World(obstacles=[DynamicObstacle.pedestrian((30.0, 0.0), (0.0, 0.0), 0.3)])
    cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.0), world, (5.0, 0.0), PlannerConfig())
    assert not cycle.in_reach.any()
    z = edge_z(cycle.config, np.random.default_rng(2))
    compiled = evaluate_batch(z, cycle, compiled=True)
    assert_same(compiled, evaluate_batch(z, cycle, compiled=False))
    assert np.all(compiled.costs.min_distance < 30.0)


class _MarksFragile:
    """The compiled kernel, with the rows ``rows`` of every first pass marked fragile (a
    rollout passing the law's discontinuity is too rare to draw at random) and their first
    pass's outputs spoilt (NaN): only the redone pass may reach the caller."""

    def __init__(self, module, rows):
        self.module, self.rows = module, rows
        self.OUT, self.numba = module.OUT, module.numba

    def _marked(self, run):
        def call(z, *args):
            run(z, *args)
            out, given = args[-3], args[-2]
            if not given:
                marked = [i for i in self.rows if i < len(z)]
                out[marked] = np.nan
                out[marked, self.OUT.index("fragile")] = 1.0
        return call

    def __getattr__(self, name):
        found = getattr(self.module, name)
        return self._marked(found) if name.startswith("exact_costs") else found


@needs_kernel
def test_the_kernel_pass_redoes_fragile_rows_with_the_reference_rollout():
    """``exact.kernel_pass`` rolls the rows the kernel marks fragile out again with the numpy
    reference and costs them again: those rows go the reference's way, the others are
    untouched, on one thread and on every core."""
    occupied = np.zeros((30, 30), bool)
    occupied[:, 20:22] = True
    world = World(OccupancyGrid(occupied, 0.1, (-1.5, -1.5)),
                  [DynamicObstacle.pedestrian((1.0, 0.4), (-0.5, 0.0))])
    cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.0, 0.5, 0.2), world, (2.0, 1.0),
                          PlannerConfig())
    z = edge_z(cycle.config, np.random.default_rng(5), 40)
    total = exact.kernel().OUT.index("total")
    plain = exact.kernel_pass(z, cycle, exact.kernel())[-1][:, total]
    stub = _MarksFragile(exact.kernel(), rows=(0, 7, 30, len(z) - 1))
    for rows in (len(z) + 1, 1):                                # one thread, every core
        raw = exact.kernel_pass(z, cycle, stub, rows)
        totals = raw[-1][:, total]
        np.testing.assert_array_equal(totals, exact.as_breakdown(raw, stub)[1].total)
        # The redone rows went the reference's way (not the spoilt first pass); the others
        # are untouched.
        np.testing.assert_array_equal(np.delete(totals, stub.rows), np.delete(plain, stub.rows))
        np.testing.assert_allclose(totals[list(stub.rows)], plain[list(stub.rows)],
                                   rtol=1e-9, atol=1e-9)


def test_totals_alone_on_the_numpy_path_are_its_totals():
    """Without the kernel, an evaluator's totals are the numpy reference's, chunked or not."""
    cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.0), World(obstacles=[
        DynamicObstacle.pedestrian((1.5, 0.2), (-0.5, 0.0))]), (3.0, 0.0), PlannerConfig())
    z = edge_z(cycle.config, np.random.default_rng(6))
    with exact.numpy_only():
        reference = evaluate_batch(z, cycle).costs.total
        np.testing.assert_array_equal(Evaluator(cycle).totals(z), reference)
        np.testing.assert_array_equal(
            Evaluator(cycle, SolverConfig().replace(pair_budget=50)).totals(z), reference)


def test_out_of_box_speed_runs_the_reference():
    """A v_max outside [0, v_limit] breaks the reach bound the culling rests on: numpy runs."""
    config = PlannerConfig()
    world = World(obstacles=[DynamicObstacle.pedestrian((9.0, 0.0), (-1.0, 0.0))])
    cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.0), world, (9.0, 0.0), config)
    for v_max in (3.0 * config.robot.v_limit, -1.0):
        z = np.array([[8.0, 0.0, 0.0, v_max]])
        assert not exact.inside_reach(z, cycle)
        assert_same(evaluate_batch(z, cycle), evaluate_batch(z, cycle, compiled=False))


def test_fallback_warns_once_and_agrees(tmp_path):
    """With DSMPEPC_NO_COMPILE=1 the numpy path runs after one warning line."""
    script = (
        "import warnings, numpy as np\n"
        "warnings.simplefilter('always')\n"
        "from dsmpepc_nlp.core.config import PlannerConfig, RobotState\n"
        "from dsmpepc_nlp.core.world import World, DynamicObstacle\n"
        "from dsmpepc_nlp.solve.exact.cycle import Cycle\n"
        "from dsmpepc_nlp.solve.exact import evaluator, loader as exact\n"
        "w = World(obstacles=[DynamicObstacle.pedestrian((2.0, 0.5), (-0.5, 0.0))])\n"
        "c = Cycle.prepare(RobotState(0.0, 0.0, 0.0), w, (4.0, 0.0), PlannerConfig())\n"
        "z = np.array([[2.0, 0.1, 0.2, 0.8], [1.0, 0.0, 0.0, 0.5]])\n"
        "with warnings.catch_warnings(record=True) as caught:\n"
        "    warnings.simplefilter('always')\n"
        "    a = evaluator.evaluate_batch(z, c)\n"
        "    b = evaluator.evaluate_batch(z, c)\n"
        "assert exact.kernel() is None\n"
        "print(len([x for x in caught if 'numpy path' in str(x.message)]))\n"
        "print(repr(a.costs.total.tolist()))\n"
    )
    env = dict(os.environ, DSMPEPC_NO_COMPILE="1", PYTHONPATH=os.getcwd())
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                         text=True, check=True, cwd=tmp_path).stdout.splitlines()
    assert out[0] == "1", "exactly one warning line"
    w = World(obstacles=[DynamicObstacle.pedestrian((2.0, 0.5), (-0.5, 0.0))])
    c = Cycle.prepare(RobotState(0.0, 0.0, 0.0), w, (4.0, 0.0), PlannerConfig())
    compiled = evaluate_batch(np.array([[2.0, 0.1, 0.2, 0.8], [1.0, 0.0, 0.0, 0.5]]), c)
    np.testing.assert_allclose(compiled.costs.total, eval(out[1]), rtol=1e-9, atol=1e-9)


@needs_kernel
def test_cache_path_names_version_and_source():
    import numba

    path = exact.kernel_cache_dir()
    # The kernel's source closure (the kernel and what it imports) and numba's version.
    assert exact.kernel_source_hash() in path.name and numba.__version__ in path.name
    assert path.parent.parent.name == cache.package_version()
    assert any(path.rglob("*.nbi")), "the compiled kernel is cached on disk"


def test_parameter_vector_names_every_field():
    cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.0), World(), (1.0, 0.0),
                          dataclasses.replace(PlannerConfig(), terminal_cost=False))
    assert cycle.parameters.shape == (len(PARAMETERS),)
    values = dict(zip(PARAMETERS, cycle.parameters))
    assert values["terminal"] == 0.0 and values["on_terminal"] == 0.0
    assert values["goal_x"] == 1.0 and values["has_grid"] == 0.0


def test_build_command_compiles_or_says_numpy(capsys):
    from dsmpepc_nlp.cli import main

    assert main(["build"]) == 0
    out = capsys.readouterr().out
    assert ("exact evaluator ready" in out) == (exact.kernel() is not None)


def test_bench_reports_both_paths_side_by_side():
    from dsmpepc_nlp.bench.scenes import demo_cycles
    from dsmpepc_nlp.bench.timing import exact_timing

    config = PlannerConfig()
    result = exact_timing(demo_cycles(config, 1, 0, n_samples=64), config, n=128, repeats=2)
    for name in ("exact_us_per_trajectory", "exact_cpu_us_per_trajectory", "sampling_4096_ms"):
        assert result[name] > 0 and result[f"{name}_numpy"] > 0
        assert result[f"{name}_speedup"] == pytest.approx(result[f"{name}_numpy"] / result[name])
    assert result["compiled"] == (exact.kernel() is not None)


@needs_kernel
def test_long_horizon_sums_like_numpy():
    """Over 128 steps numpy's pairwise summation splits the sum: the kernel follows it."""
    from dsmpepc_nlp.core.config import HorizonConfig

    config = PlannerConfig(horizon=HorizonConfig(dt=0.05, n_steps=300))
    world = World(obstacles=[DynamicObstacle.pedestrian((3.0, 0.4), (-0.6, 0.0))])
    cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.1, 0.4, 0.0), world, (8.0, 1.0), config)
    z = edge_z(config, np.random.default_rng(3))
    assert_same(evaluate_batch(z, cycle, compiled=True), evaluate_batch(z, cycle, compiled=False))


def _wall_and_pedestrian():
    """``(config, cycle)``: DS-MPEPC beside a wall with one pedestrian."""
    occupied = np.zeros((30, 30), bool)
    occupied[:, 14:16] = True
    world = World(OccupancyGrid(occupied, 0.1, (-1.5, -1.5)),
                  [DynamicObstacle.pedestrian((1.0, 0.3), (-0.5, 0.0))])
    config = PlannerConfig.ds_mpepc()
    return config, Cycle.prepare(RobotState(0.0, 0.0, 0.0), world, (3.0, 1.0), config)


@needs_kernel
def test_small_batches_on_two_threads_at_once_equal_them_one_after_another():
    """The serial kernel runs on several threads at once (only the parallel one queues for
    numba's pool): batches costed side by side equal the same batches costed in turn."""
    import threading

    config, cycle = _wall_and_pedestrian()
    batches = [edge_z(config, np.random.default_rng(seed), 24) for seed in range(8)]
    alone = [evaluate_batch(z, cycle, parallel_rows=len(z) + 1).costs.total for z in batches]
    side_by_side = [None] * len(batches)
    inside = [0]
    lock = threading.Lock()
    overlapped = [False]

    def work(indices):
        for i in indices:
            with lock:
                inside[0] += 1
                overlapped[0] |= inside[0] > 1
            for _ in range(20):
                side_by_side[i] = evaluate_batch(batches[i], cycle,
                                                 parallel_rows=len(batches[i]) + 1).costs.total
            with lock:
                inside[0] -= 1

    workers = [threading.Thread(target=work, args=(range(k, len(batches), 2),))
               for k in range(2)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    assert overlapped[0]
    for a, b in zip(alone, side_by_side):
        np.testing.assert_array_equal(a, b)


@needs_kernel
def test_only_the_parallel_kernel_queues_for_the_thread_pool():
    """While the pool's lock is held elsewhere, a small batch (the serial kernel) still runs
    and a large one (the parallel kernel) waits for the lock."""
    import threading

    config, cycle = _wall_and_pedestrian()
    z = edge_z(config, np.random.default_rng(4), 24)
    expected = evaluate_batch(z, cycle, parallel_rows=len(z) + 1).costs.total
    results = {}

    def batch(name, rows):
        results[name] = evaluate_batch(z, cycle, parallel_rows=rows).costs.total

    with exact._LOCK:
        serial = threading.Thread(target=batch, args=("serial", len(z) + 1))
        parallel = threading.Thread(target=batch, args=("parallel", 1))
        serial.start()
        parallel.start()
        serial.join(timeout=20.0)
        assert not serial.is_alive()            # ran although the lock was held
        parallel.join(timeout=0.5)
        assert parallel.is_alive()              # waits for the lock
    parallel.join(timeout=60.0)
    np.testing.assert_array_equal(results["serial"], expected)
    np.testing.assert_array_equal(results["parallel"], expected)
