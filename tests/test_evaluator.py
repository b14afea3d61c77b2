"""The one door to the exact cost: an Evaluator per cycle keeps what it costed and reads it back."""

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.solve.exact import loader as exact
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator, evaluate_batch
from dsmpepc_nlp.solve.optimize.starts import box_samples

CONFIG = PlannerConfig()


def _cycle():
    world = World(obstacles=[DynamicObstacle.pedestrian((2.0, 0.5), (-0.5, 0.0)),
                             DynamicObstacle.pedestrian((1.0, -1.5), (0.0, 0.6))])
    return Cycle.prepare(RobotState(0.0, 0.0, 0.0, 0.4), world, (4.0, 0.5), CONFIG)


def _same(a, b):
    np.testing.assert_array_equal(a.z, b.z)
    np.testing.assert_array_equal(a.costs.total, b.costs.total)
    np.testing.assert_array_equal(a.costs.survivability, b.costs.survivability)
    np.testing.assert_array_equal(a.trajectories.poses, b.trajectories.poses)
    for name in a.costs.terms:
        np.testing.assert_array_equal(a.costs.terms[name], b.costs.terms[name])


@pytest.mark.parametrize("compiled", [None, False], ids=["kernel-when-loaded", "numpy"])
def test_rows_of_one_batch_are_read_back_as_a_fresh_evaluation_gives_them(compiled):
    cycle = _cycle()
    z = box_samples(CONFIG, 40, 3)
    evaluator = Evaluator(cycle, compiled=compiled)
    totals = evaluator.totals(z)
    assert evaluator.rows_costed == 40 and evaluator.batches == [(40, False)]
    rows = [7, 0, 31]
    again = evaluator.evaluate(z[rows])
    assert evaluator.rows_costed == 40 and evaluator.read_back == 1     # nothing costed anew
    np.testing.assert_array_equal(again.costs.total, totals[rows])
    if compiled is None and exact.kernel() is not None:     # the kernel: row for row, to the bit
        _same(again, evaluate_batch(z[rows], cycle))
    assert evaluator.times_costed(z[7]) == 1


def test_rows_from_two_batches_or_new_rows_are_costed():
    cycle = _cycle()
    z = box_samples(CONFIG, 20, 4)
    evaluator = Evaluator(cycle, SolverConfig().replace(parallel_rows=8))
    evaluator.totals(z[:10])
    evaluator.totals(z[10:], one_thread=True)
    assert evaluator.batches == [(10, False), (10, True)]
    mixed = evaluator.evaluate(z[[2, 15]])              # one row from each batch: costed again
    assert evaluator.rows_costed == 22 and evaluator.read_back == 0
    np.testing.assert_array_equal(mixed.costs.total,
                                  evaluate_batch(z[[2, 15]], cycle).costs.total)
    assert evaluator.times_costed(z[2]) == 2 and evaluator.times_costed(z[15]) == 2
    fresh = np.array([[2.0, 0.1, -0.2, 0.7]])
    evaluator.evaluate(fresh)
    assert evaluator.rows_costed == 23 and evaluator.times_costed(fresh[0]) == 1


def test_a_large_look_up_reads_back_by_index_and_a_larger_batch_is_costed_anew():
    """Many rows against a large batch are found through the batch's index of rows (not an
    all-pairs comparison); a batch with more rows than any costed before is costed anew."""
    cycle = _cycle()
    z = box_samples(CONFIG, 300, 5)
    evaluator = Evaluator(cycle)
    totals = evaluator.totals(z)
    rows = np.arange(299, 49, -1)                       # 250 x 300 pairs: the index
    again = evaluator.evaluate(z[rows])
    assert evaluator.read_back == 1 and evaluator.rows_costed == 300
    np.testing.assert_array_equal(again.costs.total, totals[rows])
    more = np.vstack([z, [[2.0, 0.1, -0.2, 0.7]]])
    evaluator.evaluate(more)
    assert evaluator.read_back == 1 and evaluator.rows_costed == 601


@pytest.mark.parametrize("preset", [PlannerConfig, PlannerConfig.paper])
def test_moves_the_law_cannot_make_cost_on_the_kernel_as_the_reference_does(preset, monkeypatch):
    """Reverses, dodges and turns in place (never above v_limit) are costed by the compiled
    kernel as given; a trajectory faster than v_limit (the cycle's culling would not hold) by
    the numpy reference; together, every breakdown field as the reference gives it, row for
    row."""
    from dsmpepc_nlp.core.control_law import Trajectory, stacked
    from dsmpepc_nlp.core.exact_cost import evaluate
    from dsmpepc_nlp.core.world import OccupancyGrid
    from dsmpepc_nlp.solve.behaviours import docking
    from dsmpepc_nlp.solve.behaviours.ways import back_up_trajectories, dodge_trajectories

    if exact.kernel() is None:
        pytest.skip("no compiled kernel (DSMPEPC_NO_COMPILE or no numba)")
    rng = np.random.default_rng(5)
    config = preset()
    occupied = rng.random((60, 60)) < 0.03
    occupied[27:33, 27:33] = False
    people = [DynamicObstacle.pedestrian(rng.uniform(0.0, 6.0, 2), rng.uniform(-1.0, 1.0, 2))
              for _ in range(30)]
    world = World(OccupancyGrid.from_array(occupied, 0.1), people)
    state = RobotState(3.0, 3.0, 0.4, 0.5, 0.2)
    goal = np.array([5.5, 1.0])
    evaluator = Evaluator(Cycle.prepare(state, world, goal, config))
    forward = stacked([dodge_trajectories(state, config),
                       docking.turn_in_place(state, config, 1.0)])
    reverses = back_up_trajectories(state, PlannerConfig())     # (the product's)
    one = forward[0]
    too_fast = Trajectory(one.z, one.poses, one.v * 10.0, one.omega, one.target)
    batch = stacked([reverses, too_fast, forward])
    kernel_rows = exact.given_in_reach(batch, evaluator.cycle)
    assert np.all(batch.v[kernel_rows] <= config.robot.v_limit) and np.any(batch.v < 0.0)
    assert kernel_rows.tolist() == [True] * len(reverses.z) + [False] + [True] * len(forward.z)
    calls = []
    given = exact.cost_given
    monkeypatch.setattr(exact, "cost_given", lambda t, *a: calls.append(len(t.z)) or given(t, *a))
    got = evaluator.evaluate_trajectories(batch)
    assert calls == [int(np.sum(kernel_rows))]
    want = evaluate(batch, world, goal, config)
    for name in ("total", "survivability", "min_distance", "ttg", "ttc_terminal"):
        np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-12,
                                   atol=1e-12, err_msg=name)
    for name in want.terms:
        np.testing.assert_allclose(got.terms[name], want.terms[name], rtol=1e-12, atol=1e-12)
    one = evaluator.evaluate_trajectories(forward[0])           # a single one: unbatched
    assert np.ndim(one.total) == 0 and one.total == pytest.approx(float(got.total[len(batch.z)
                                                                           - len(forward.z)]))
