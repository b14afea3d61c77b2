"""The trust-region Newton method on a box: exact step problem, convergence, and in the NLP."""

import numpy as np
import pytest

from dsmpepc_nlp.core import solver_config
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator
from dsmpepc_nlp.solve.optimize import newton
from dsmpepc_nlp.solve.optimize.newton import box_qp, box_qp_reference, minimize


@pytest.mark.parametrize("convex", [False, True])
def test_box_qp_is_the_global_minimum_of_the_box(convex):
    rng = np.random.default_rng(0)
    for _ in range(50):
        a = rng.normal(size=(4, 4))
        hessian = a @ a.T + 0.1 * np.eye(4) if convex else a + a.T
        g = rng.normal(size=4)
        lower, upper = -rng.random(4) * 2.0, rng.random(4) * 2.0
        d = box_qp(g, hessian, lower, upper)
        assert np.all(d >= lower) and np.all(d <= upper)
        samples = lower + rng.random((20000, 4)) * (upper - lower)
        model = samples @ g + 0.5 * np.einsum("si,ij,sj->s", samples, hessian, samples)
        assert d @ g + 0.5 * d @ hessian @ d <= model.min() + 1e-12



def test_compiled_box_qp_equals_the_numpy_reference():
    """The compiled face enumeration is held to the numpy definition on convex, indefinite,
    singular and zero Hessians (bounds straddling 0 as in a trust-region step)."""
    if newton._kernel() is None:
        pytest.skip("compiled box QP off (numba missing or DSMPEPC_NO_COMPILE)")
    rng = np.random.default_rng(1)
    cases = [(np.ones(4), np.zeros((4, 4))), (np.zeros(4), np.diag([1.0, 0.0, 0.0, 1.0])),
             (np.array([1.0, -2.0, 0.5, 0.0]), -np.eye(4))]
    for _ in range(500):
        a = rng.normal(size=(4, 4))
        kind = rng.integers(3)
        hessian = a @ a.T if kind == 0 else (a + a.T if kind == 1 else np.outer(a[0], a[0]))
        cases.append((3.0 * rng.normal(size=4), hessian))
    for g, hessian in cases:
        lower, upper = -rng.random(4) * 2.0, rng.random(4) * 2.0
        np.testing.assert_allclose(box_qp(g, hessian, lower, upper),
                                   box_qp_reference(g, hessian, lower, upper), atol=1e-9)

def _rosenbrock(x):
    return (1 - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2


def _rosenbrock_fgh(x):
    g = np.array([-2 * (1 - x[0]) - 400 * x[0] * (x[1] - x[0] ** 2), 200 * (x[1] - x[0] ** 2)])
    h = np.array([[2 - 400 * (x[1] - 3 * x[0] ** 2), -400 * x[0]], [-400 * x[0], 200.0]])
    return _rosenbrock(x), g, h


def test_minimize_converges_inside_and_stops_on_an_active_bound():
    inside = minimize(_rosenbrock, _rosenbrock_fgh, [-1.2, 1.0], [-2, -2], [2, 2],
                      max_iter=100, tol=1e-12)
    assert inside.success and np.allclose(inside.x, [1.0, 1.0], atol=1e-5)
    bounded = minimize(_rosenbrock, _rosenbrock_fgh, [-1.2, 1.0], [-2, -2], [0.5, 2],
                       max_iter=100, tol=1e-12)
    assert bounded.x[0] == pytest.approx(0.5) and bounded.x[1] == pytest.approx(0.25, abs=1e-4)


def test_minimize_never_accepts_an_increase():
    values = []

    def f(x):
        values.append(_rosenbrock(x))
        return values[-1]

    result = minimize(f, _rosenbrock_fgh, [-1.2, 1.0], [-2, -2], [2, 2], max_iter=30)
    assert result.fun <= _rosenbrock(np.array([-1.2, 1.0]))


@pytest.mark.skipif("newton" not in solver_config.SOLVER_METHODS,
                    reason="SolverConfig does not offer method='newton' yet")
def test_newton_nlp_solver_records_are_finite_and_in_the_box(monkeypatch):
    from dsmpepc_nlp.core.config import PlannerConfig, RobotState
    from dsmpepc_nlp.core.solver_config import SolverConfig
    from dsmpepc_nlp.core.world import DynamicObstacle, World
    from dsmpepc_nlp.solve.optimize.multistart import NlpSolver
    from dsmpepc_nlp.solve.optimize.starts import structured_starts
    from dsmpepc_nlp.solve.problem import GraphSizes

    monkeypatch.setenv("DSMPEPC_NO_COMPILE", "1")      # the logic, on the virtual machine
    cfg = PlannerConfig()
    solver = NlpSolver(cfg, SolverConfig().replace(method="newton", max_iter=15, n_screen=4,
                                         pose_object_buckets=(3,)),
                       GraphSizes(max_objects=3, table_cells=64, ray_samples=8))
    world = World(None, [DynamicObstacle.pedestrian([2.5, 0.6], [-0.4, 0.0])])
    state, goal = RobotState(0.0, 0.0, 0.0), np.array([5.0, 0.0])
    records = solver.solve(Evaluator(Cycle.prepare(state, world, goal, cfg)),
                           structured_starts(state, goal, cfg))
    solved = [r for r in records if r.status != "screened" and r.name != "polish"]
    assert len(solved) == solver.n_solved
    for record in solved:
        assert np.all(np.isfinite(record.z)) and np.isfinite(record.exact_cost)
        assert np.all(record.z >= np.array(cfg.z_lower)) and np.all(record.z <= cfg.z_upper)


def test_compiled_loop_compiles_the_python_loops_step_arithmetic():
    """Both loops take their step's arithmetic from one text (``trust_region``): the compiled
    loop's functions are numba's compilations of the functions the Python loop calls."""
    from dsmpepc_nlp.solve.optimize import trust_region

    module = newton._kernel()
    if module is None:
        pytest.skip("numba missing or compilation off")
    for name in ("step_bounds", "model_decrease", "converged", "next_radius", "sr1_update"):
        assert getattr(module, f"_{name}").py_func is getattr(trust_region, name)
        assert getattr(newton, name) is getattr(trust_region, name)
