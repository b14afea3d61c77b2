"""The NLP graph (smooth -> exact, CasADi == numpy assemble) and the multi-start solver."""

import casadi as ca
import numpy as np
import pytest

from dsmpepc_nlp import nlp_graph
from dsmpepc_nlp.config import PlannerConfig, RobotState, SmoothingConfig, SolverConfig
from dsmpepc_nlp.control_law import rollout
from dsmpepc_nlp.costs import TERM_NAMES, assemble, evaluate, exact_geometry
from dsmpepc_nlp.nlp import NlpSolver, cost_function
from dsmpepc_nlp.sampling import SamplingPlanner, structured_starts
from dsmpepc_nlp.smooth import CASADI
from dsmpepc_nlp.world import DynamicObstacle, OccupancyGrid, World

CONFIG = PlannerConfig()
SMALL = nlp_graph.GraphSizes(max_objects=3, map_disks=16, nav_waypoints=4)


def _random_z(rng, n):
    lower, upper = np.array(CONFIG.z_lower), np.array(CONFIG.z_upper)
    return lower + rng.random((n, 4)) * (upper - lower)


def _open_world():
    return World(None, [DynamicObstacle.pedestrian([2.5, 0.6], [-0.4, 0.0]),
                        DynamicObstacle.pedestrian([1.5, -2.0], [0.0, 0.5])])


def _graph_costs(z, state, world, goal, smoothing, sizes=SMALL):
    f = cost_function(CONFIG, sizes, smoothing)
    params = nlp_graph.pack_parameters(state, world, goal, CONFIG, sizes)
    return np.array([float(f(z=zi, **params)["cost"]) for zi in z])


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


def test_map_disks_distance_close_to_signed_distance_near_walls():
    world = _walled_world()
    state = RobotState(0.0, 0.0, 0.0)
    disks = nlp_graph.pack_map(state, world, CONFIG, nlp_graph.GraphSizes(map_disks=128))
    rng = np.random.default_rng(3)
    points = rng.uniform([-1.0, 0.4], [3.0, 1.0], (400, 2))
    exact = world.static_distance(points)
    near = (exact > 0) & (exact < 0.6)
    approx = np.min(np.linalg.norm(points[:, None] - disks[None, :, :2], axis=-1)
                    - disks[None, :, 2], axis=1)
    assert np.max(np.abs(approx[near] - exact[near])) < 0.06


def test_solve_returns_finite_records_within_bounds():
    solver = NlpSolver(CONFIG, SolverConfig(n_spread=2, max_iter=15), SMALL)
    state, world, goal = RobotState(0.0, 0.0, 0.0), _open_world(), np.array([5.0, 0.0])
    starts = structured_starts(state, goal, CONFIG)
    records = solver.solve(state, world, goal, starts)
    assert [r.name for r in records] == list(starts) + ["spread-0", "spread-1"]
    for record in records:
        assert np.all(np.isfinite(record.z))
        assert np.all(record.z >= np.array(CONFIG.z_lower) - 1e-12)
        assert np.all(record.z <= np.array(CONFIG.z_upper) + 1e-12)


@pytest.mark.parametrize("world", [
    World(None, ()),
    World(None, [DynamicObstacle.pedestrian([1.0 + 0.5 * i, (-1) ** i * 1.0], [0.0, 0.1])
                 for i in range(6)]),
    _walled_world(),
], ids=["empty", "more-than-k-max", "map-only"])
def test_solve_survives_unusual_worlds(world):
    solver = NlpSolver(CONFIG, SolverConfig(n_spread=0, max_iter=8), SMALL)
    state, goal = RobotState(0.0, 0.0, 0.0), np.array([4.0, 0.0])
    records = solver.solve(state, world, goal, structured_starts(state, goal, CONFIG))
    assert records and all(np.all(np.isfinite(r.z)) for r in records)


def test_open_space_nlp_matches_or_beats_4096_samples():
    from dsmpepc_nlp.planner import Planner

    state, world, goal = RobotState(0.0, 0.0, 0.0), World(None, ()), np.array([6.0, 0.5])
    planner = Planner(CONFIG, SolverConfig(n_spread=2))
    plan = planner.plan(state, world, goal, dock=False)
    sampled = SamplingPlanner(CONFIG).search(state, world, goal,
                                             structured_starts(state, goal, CONFIG))
    assert plan.fun <= sampled.costs.total[sampled.best()] + 0.01


def test_robot_starting_in_collision_does_not_move():
    """Lemma 3 through the Planner with the NLP solver."""
    from dsmpepc_nlp.planner import Planner

    world = World(None, [DynamicObstacle.pedestrian([0.2, 0.0], [0.0, 0.0])])
    state, goal = RobotState(0.0, 0.0, 0.0), np.array([5.0, 0.0])
    plan = Planner(CONFIG, SolverConfig(n_spread=1, max_iter=15)).plan(state, world, goal,
                                                                        dock=False)
    assert plan.control[0] == pytest.approx(0.0, abs=1e-6)


def test_cost_function_has_named_terms():
    f = cost_function(CONFIG, SMALL)
    assert f.name_out() == ["cost", *TERM_NAMES]
    assert f.name_in() == ["z", *nlp_graph.PARAMETER_NAMES]
