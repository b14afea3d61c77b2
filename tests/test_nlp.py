"""The NLP graph (smooth -> exact, CasADi == numpy assemble) and the multi-start solver."""

import casadi as ca
import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState, SmoothingConfig, SolverConfig
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.costs import TERM_NAMES, assemble, evaluate, exact_geometry
from dsmpepc_nlp.core.smooth import CASADI
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World
from dsmpepc_nlp.solve import nlp_graph
from dsmpepc_nlp.solve.cycle import Cycle
from dsmpepc_nlp.solve.nlp import NlpSolver, cost_function
from dsmpepc_nlp.solve.sampling import SamplingPlanner, structured_starts

CONFIG = PlannerConfig()
SMALL = nlp_graph.GraphSizes(max_objects=3, near_objects=2)


def _random_z(rng, n):
    lower, upper = np.array(CONFIG.z_lower), np.array(CONFIG.z_upper)
    return lower + rng.random((n, 4)) * (upper - lower)


def _open_world():
    return World(None, [DynamicObstacle.pedestrian([2.5, 0.6], [-0.4, 0.0]),
                        DynamicObstacle.pedestrian([1.5, -2.0], [0.0, 0.5])])


def _graph_costs(z, state, world, goal, smoothing, sizes=SMALL):
    """Graph cost of each z with the local models taken along that z's own rollout."""
    f = cost_function(CONFIG, sizes, smoothing)
    costs = []
    for zi in z:
        params = nlp_graph.pack_parameters(state, world, goal, CONFIG, sizes, reference=zi)
        costs.append(float(f(z=zi, **params)["cost"]))
    return np.array(costs)


def test_graph_with_exact_geometry_equals_numpy_assemble():
    """One source of truth: CasADi assemble on exact geometry == numpy assemble."""
    rng = np.random.default_rng(0)
    state, world, goal = RobotState(0.0, 0.0, 0.2, 0.4), _open_world(), np.array([4.0, 1.0])
    traj = rollout(_random_z(rng, 5), state, CONFIG)
    geo = exact_geometry(traj, world, goal, CONFIG)
    for smoothing in (SmoothingConfig.exact(), CONFIG.smoothing):
        total, _, _ = assemble(geo.distance, geo.inv_ttc, geo.sigma, geo.nf, traj.v[..., None],
                               traj.omega[..., None], geo.heading_error, geo.inv_ttg,
                               geo.inv_ttc_terminal, CONFIG, smoothing)
        for i in range(5):
            sigma = ca.repmat(ca.DM(geo.sigma).T, geo.distance.shape[1], 1)
            got, _, _ = assemble(ca.DM(geo.distance[i]), ca.DM(geo.inv_ttc[i]), sigma,
                                 ca.DM(geo.nf[i]), ca.DM(traj.v[i][:, None]),
                                 ca.DM(traj.omega[i][:, None]), geo.heading_error[i].item(),
                                 geo.inv_ttg[i].item(), geo.inv_ttc_terminal[i].item(),
                                 CONFIG, smoothing, CASADI)
            assert float(got) == pytest.approx(float(total[i, 0, 0]), abs=1e-9)


def test_smooth_graph_converges_to_exact_cost_without_map():
    """Without a map the representation is exact; only the temperatures separate the costs."""
    rng = np.random.default_rng(1)
    state, world, goal = RobotState(0.0, 0.0, 0.1, 0.3), _open_world(), np.array([5.0, 1.0])
    z = _random_z(rng, 6)
    exact = evaluate(rollout(z, state, CONFIG), world, goal, CONFIG).total
    errors = []
    for factor in (1.0, 0.1, 0.01):
        smooth = _graph_costs(z, state, world, goal, CONFIG.smoothing.scaled(factor))
        errors.append(np.max(np.abs(smooth - exact)))
    assert errors[-1] < 0.02
    assert errors[-1] <= errors[0] + 1e-9


def test_exact_temperature_graph_matches_exact_cost_without_map():
    rng = np.random.default_rng(2)
    state, world, goal = RobotState(0.0, 0.0, -0.2, 0.5, 0.2), _open_world(), np.array([4.0, -2.0])
    z = _random_z(rng, 6)
    exact = evaluate(rollout(z, state, CONFIG), world, goal, CONFIG).total
    graph = _graph_costs(z, state, world, goal, SmoothingConfig.exact())
    # Static TTC and the terminal TTC agree exactly; tiny differences come from the guards.
    np.testing.assert_allclose(graph, exact, atol=2e-3)


def _walled_world():
    occupied = np.zeros((60, 80), dtype=bool)
    occupied[40:43, 10:70] = True
    return World(OccupancyGrid(occupied, 0.1, (-2.0, -3.0)), ())


def _demo_cycle():
    from dsmpepc_nlp.bench.scenes import demo_cycles

    return demo_cycles(CONFIG, 4, seed=0, n_samples=64)[3]


def test_local_models_are_exact_at_the_reference_trajectory():
    """Map, NF and wall-plane models along z's own rollout: exact temperatures give the exact
    cost (crowded demo scene: map + 12 pedestrians, 2 nearest per pose)."""
    state, world, goal = _demo_cycle()
    z = _random_z(np.random.default_rng(4), 8)
    exact = evaluate(rollout(z, state, CONFIG), world, goal, CONFIG).total
    graph = _graph_costs(z, state, world, goal, SmoothingConfig.exact(),
                         nlp_graph.GraphSizes(max_objects=12, near_objects=3))
    np.testing.assert_allclose(graph, exact, atol=1e-6)


def test_smooth_cost_converges_to_exact_at_the_reference_trajectory():
    state, world, goal = _demo_cycle()
    z = _random_z(np.random.default_rng(5), 6)
    exact = evaluate(rollout(z, state, CONFIG), world, goal, CONFIG).total
    sizes = nlp_graph.GraphSizes(max_objects=12, near_objects=3)
    errors = [np.max(np.abs(_graph_costs(z, state, world, goal, CONFIG.smoothing.scaled(f),
                                         sizes) - exact)) for f in (1.0, 0.1, 0.01)]
    assert errors[0] < 0.01
    assert errors[-1] < 1e-3
    assert errors[-1] <= errors[0] + 1e-9


def test_quadratic_model_is_exact_for_a_quadratic_and_damped_far_away():
    def quadratic(points):
        x, y = points[..., 0], points[..., 1]
        return 1.0 + 2.0 * x - y + 0.5 * (3.0 * x * x + 2.0 * x * y + y * y)

    model = nlp_graph.quadratic_models(quadratic, np.array([[0.0, 0.0]]), 0.1)[0]
    np.testing.assert_allclose(model[2:], [1.0, 2.0, -1.0, 3.0, 1.0, 1.0], atol=1e-9)
    point = ca.SX.sym("p", 2)
    value, grad = nlp_graph.local_quadratic(point, ca.DM(model))
    f = ca.Function("f", [point], [value, ca.vertcat(*grad), ca.gradient(value, point)])
    near, _, _ = f([0.01, 0.02])
    assert float(near) == pytest.approx(quadratic(np.array([0.01, 0.02])), abs=1e-5)
    _, mine, autodiff = f([3.0, -2.0])
    np.testing.assert_allclose(np.array(mine), np.array(autodiff), atol=1e-12)
    far, _, _ = f([100.0, 0.0])
    # The curvature term is bounded by 0.5 |H| R^2: no bending back far from the reference.
    assert abs(float(far) - (1.0 + 200.0)) < 0.5 * 4.0 * nlp_graph.MODEL_RADIUS**2


def test_wall_plane_inverse_ttc_matches_ray_march_head_on():
    """Static 1/TTC through the wall plane equals v / ray distance toward a flat wall."""
    world = _walled_world()            # wall surface at y = 1.0 m
    state = RobotState(0.0, 0.0, np.pi / 2)
    poses = np.array([[0.0, 0.0, np.pi / 2], [0.3, 0.2, np.pi / 2 - 0.3]])
    _, map_model, _ = nlp_graph.pack_models(poses, world, [3.0, 0.0], CONFIG)
    radius = CONFIG.robot.footprint[0][2]
    for pose, row in zip(poses, map_model):
        along = world.static_ray_distance(pose[None, :2], pose[2:], radius, 8.0)[0]
        plane_point, normal = row[8:10], row[10:12]
        plane_along = normal @ (pose[:2] - plane_point) / -(normal @ [np.cos(pose[2]),
                                                                       np.sin(pose[2])])
        assert plane_along == pytest.approx(along, abs=1e-9)
    del state


def test_solve_returns_finite_records_within_bounds():
    solver = NlpSolver(CONFIG, SolverConfig(n_spread=2, max_iter=15, n_screen=4), SMALL)
    state, world, goal = RobotState(0.0, 0.0, 0.0), _open_world(), np.array([5.0, 0.0])
    starts = structured_starts(state, goal, CONFIG)
    records = solver.solve(Cycle.prepare(state, world, goal, CONFIG), starts)
    assert [r.name for r in records] == (list(starts) + ["spread-0", "spread-1"]
                                         + [f"screen-{i}" for i in range(4)])
    assert sum(r.status != "screened" for r in records) == solver.n_solved
    for record in records:
        assert np.all(np.isfinite(record.z)) and np.isfinite(record.exact_cost)
        assert np.all(record.z >= np.array(CONFIG.z_lower) - 1e-12)
        assert np.all(record.z <= np.array(CONFIG.z_upper) + 1e-12)
        if record.status == "screened":
            assert record.nit == 0 and np.array_equal(record.z, record.z0)


@pytest.mark.parametrize("world", [
    World(None, ()),
    World(None, [DynamicObstacle.pedestrian([1.0 + 0.5 * i, (-1) ** i * 1.0], [0.0, 0.1])
                 for i in range(6)]),
    World(None, [DynamicObstacle.robot([1.5, 0.5, 0.3], [0.0, -0.2],
                                       [(0.2, 0.0, 0.25), (-0.2, 0.0, 0.25)])]),
    _walled_world(),
], ids=["empty", "more-than-k-max", "two-circle-robot", "map-only"])
def test_solve_survives_unusual_worlds(world):
    solver = NlpSolver(CONFIG, SolverConfig(n_spread=0, max_iter=8, n_screen=4), SMALL)
    state, goal = RobotState(0.0, 0.0, 0.0), np.array([4.0, 0.0])
    records = solver.solve(Cycle.prepare(state, world, goal, CONFIG),
                           structured_starts(state, goal, CONFIG))
    assert records and all(np.all(np.isfinite(r.z)) for r in records)


def test_open_space_nlp_matches_or_beats_4096_samples():
    from dsmpepc_nlp.solve.planner import Planner

    state, world, goal = RobotState(0.0, 0.0, 0.0), World(None, ()), np.array([6.0, 0.5])
    planner = Planner(CONFIG, SolverConfig(n_spread=2, max_iter=20))
    plan = planner.plan(state, world, goal, dock=False)
    sampled = SamplingPlanner(CONFIG).search(Cycle.prepare(state, world, goal, CONFIG),
                                             structured_starts(state, goal, CONFIG))
    assert plan.fun <= sampled.costs.total[sampled.best()] + 0.01


def test_robot_starting_in_collision_does_not_move():
    """Lemma 3 through the Planner with the NLP solver."""
    from dsmpepc_nlp.solve.planner import Planner

    world = World(None, [DynamicObstacle.pedestrian([0.2, 0.0], [0.0, 0.0])])
    state, goal = RobotState(0.0, 0.0, 0.0), np.array([5.0, 0.0])
    plan = Planner(CONFIG, SolverConfig(n_spread=1, max_iter=15)).plan(state, world, goal,
                                                                        dock=False)
    assert plan.control[0] == pytest.approx(0.0, abs=1e-6)


def test_cost_function_has_named_terms():
    f = cost_function(CONFIG, SMALL)
    assert f.name_out() == ["cost", *TERM_NAMES]
    assert f.name_in() == ["z", *nlp_graph.PARAMETER_NAMES]


def test_hessian_is_finite_at_stop_and_in_collision():
    """The Hessian IPOPT uses is finite where v_max = 0 and where the robot overlaps a wall."""
    state, world, goal = _demo_cycle()
    f = cost_function(CONFIG, SMALL)
    z = ca.SX.sym("z", 4)
    shapes = nlp_graph.parameter_shapes(CONFIG, SMALL)
    blocks = [ca.SX.sym(n, *shapes[n]) for n in nlp_graph.PARAMETER_NAMES]
    hess = ca.Function("h", [z, *blocks], [ca.hessian(f(z, *blocks)[0], z)[0]])
    inside = RobotState(0.4, 6.0, 0.0)                 # overlapping the outer wall at x = 0.2
    radius = CONFIG.robot.footprint[0][2]
    assert world.static_distance(np.array([inside.x, inside.y])) < radius - 0.05
    for s, zi in ((state, [2.0, 0.0, 0.0, 0.0]), (inside, [2.0, 0.0, 0.0, 0.5])):
        params = nlp_graph.pack_parameters(s, world, goal, CONFIG, SMALL, reference=zi)
        value = np.array(hess(zi, *(params[n] for n in nlp_graph.PARAMETER_NAMES)))
        assert np.all(np.isfinite(value))
