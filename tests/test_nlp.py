"""The NLP graph (smooth -> exact, CasADi == numpy assemble) and the multi-start solver.

The solver tests run the graph in CasADi's virtual machine on a small configuration (the
solver logic does not depend on compiled code; ``test_graph.py`` holds the compiled
functions to the virtual machine)."""

import dataclasses

import casadi as ca
import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.cost_config import SmoothingConfig
from dsmpepc_nlp.core.costs import assemble
from dsmpepc_nlp.core.exact_cost import evaluate, exact_geometry
from dsmpepc_nlp.core.smooth import CASADI
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.terms import TERM_NAMES
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World
from dsmpepc_nlp.solve import problem as graph
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator
from dsmpepc_nlp.solve.optimize.multistart import NlpSolver
from dsmpepc_nlp.solve.optimize.sampling import SamplingPlanner
from dsmpepc_nlp.solve.optimize.starts import structured_starts
from dsmpepc_nlp.solve.problem import cost_function

CONFIG = PlannerConfig()
SMALL = graph.GraphSizes(max_objects=3, table_cells=64, ray_samples=8)
BUCKETS = dict(pose_object_buckets=(3,))


@pytest.fixture(autouse=True)
def _virtual_machine(monkeypatch):
    """The solver logic on CasADi's virtual machine: no compilation in these tests."""
    monkeypatch.setenv("DSMPEPC_NO_COMPILE", "1")


def _random_z(rng, n):
    lower, upper = np.array(CONFIG.z_lower), np.array(CONFIG.z_upper)
    return lower + rng.random((n, 4)) * (upper - lower)


def _open_world():
    return World(None, [DynamicObstacle.pedestrian([2.5, 0.6], [-0.4, 0.0]),
                        DynamicObstacle.pedestrian([1.5, -2.0], [0.0, 0.5])])


def _graph_costs(z, state, world, goal, smoothing, sizes=SMALL):
    """Graph cost of each z (the global graph: the cycle's parameters, any z)."""
    f = cost_function(CONFIG, sizes, smoothing)
    params = graph.pack_parameters(Cycle.prepare(state, world, goal, CONFIG), sizes)
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
            sigma = ca.DM(geo.sigma)         # (N+1) x M: the bell widens with the look-ahead
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


def test_solve_returns_finite_records_within_bounds():
    solver = NlpSolver(CONFIG, SolverConfig().replace(n_spread=2, max_iter=15, n_screen=4,
                                                      **BUCKETS),
                       SMALL)
    state, world, goal = RobotState(0.0, 0.0, 0.0), _open_world(), np.array([5.0, 0.0])
    starts = structured_starts(state, goal, CONFIG)
    records = solver.solve(Evaluator(Cycle.prepare(state, world, goal, CONFIG)), starts)
    names = list(starts) + ["spread-0", "spread-1"] + [f"screen-{i}" for i in range(4)]
    assert [r.name for r in records] in (names, names + ["polish"])
    assert sum(r.status != "screened" and r.name != "polish" for r in records) == solver.n_solved
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
    solver = NlpSolver(CONFIG, SolverConfig().replace(n_spread=0, max_iter=8, n_screen=4,
                                                      **BUCKETS),
                       SMALL)
    state, goal = RobotState(0.0, 0.0, 0.0), np.array([4.0, 0.0])
    records = solver.solve(Evaluator(Cycle.prepare(state, world, goal, CONFIG)),
                           structured_starts(state, goal, CONFIG))
    assert records and all(np.all(np.isfinite(r.z)) for r in records)


def test_open_space_nlp_matches_or_beats_4096_samples():
    from dsmpepc_nlp.solve.planner import Planner

    state, world, goal = RobotState(0.0, 0.0, 0.0), World(None, ()), np.array([6.0, 0.5])
    planner = Planner(CONFIG, SolverConfig().replace(n_spread=2, max_iter=20))
    plan = planner.plan(state, world, goal, dock=False)
    sampled = SamplingPlanner(CONFIG).search(Evaluator(Cycle.prepare(state, world, goal, CONFIG)),
                                             structured_starts(state, goal, CONFIG))
    assert plan.fun <= sampled.costs.total[sampled.best()] + 0.01


def test_a_plan_costs_through_one_evaluator_and_reads_its_choice_back():
    """One evaluator per plan: the screen, the verdicts, the polish and the choice all cost
    through it, and the chosen z's breakdown is read back from the batch that costed it (not
    rolled out and costed again); the next plan has an evaluator of its own."""
    from dsmpepc_nlp.solve.planner import Planner

    state, world, goal = RobotState(0.0, 0.0, 0.0), _open_world(), np.array([6.0, 0.5])
    planner = Planner(CONFIG, SolverConfig().replace(n_spread=2, max_iter=10, n_screen=16,
                                                     **BUCKETS))
    # (no deadline: on CasADi's virtual machine these solves take longer than the default's)
    plan = planner.plan(state, world, goal, dock=False, time_budget=None)
    evaluator = planner.last_evaluator
    assert plan.status == "nlp" and evaluator.cycle.state == state
    assert evaluator.read_back == 1 and evaluator.times_costed(plan.x) >= 1
    assert evaluator.rows_costed == sum(rows for rows, _ in evaluator.batches)
    chosen = min((r for r in plan.starts if np.isfinite(r.exact_cost)),
                 key=lambda r: r.exact_cost)
    assert plan.fun == chosen.exact_cost and np.array_equal(plan.x, chosen.z)
    planner.plan(state, world, goal, dock=False)
    assert planner.last_evaluator is not evaluator


def test_while_the_kernel_loads_the_screen_keeps_to_the_named_and_spread_starts(monkeypatch):
    """A fresh process's first plan runs the exact cost on the numpy path while the compiled
    kernel loads: it screens the named and spread starts (not the Sobol points) and does not
    polish; once the kernel is there (or will never come), the whole screen and the polish."""
    from dsmpepc_nlp.solve.exact import loader as exact

    monkeypatch.setattr(exact, "_STATE", {"kernel": None, "failed": "", "numpy_only": False,
                                          "loading": None, "deferred": True})
    solver = NlpSolver(CONFIG, SolverConfig().replace(n_spread=2, n_screen=16, max_iter=5,
                                            polish_margin=np.inf, **BUCKETS), SMALL)
    state, world, goal = _demo_cycle()
    cycle = Cycle.prepare(state, world, goal, CONFIG)
    starts = structured_starts(state, goal, CONFIG)
    records = solver.solve(Evaluator(cycle), starts)
    assert solver.kernel_loading and solver.last_screen["rows"] == len(starts) + 2
    assert not any(r.name.startswith("screen-") or r.name == "polish" for r in records)
    monkeypatch.setitem(exact._STATE, "deferred", False)
    records = solver.solve(Evaluator(cycle), starts)
    assert not solver.kernel_loading and solver.last_screen["rows"] == len(starts) + 2 + 16
    assert sum(r.name.startswith("screen-") for r in records) == 16


def test_robot_starting_in_collision_does_not_move():
    """Lemma 3 through the Planner with the NLP solver."""
    from dsmpepc_nlp.solve.planner import Planner

    world = World(None, [DynamicObstacle.pedestrian([0.2, 0.0], [0.0, 0.0])])
    state, goal = RobotState(0.0, 0.0, 0.0), np.array([5.0, 0.0])
    plan = Planner(CONFIG, SolverConfig().replace(n_spread=1, max_iter=15)).plan(state, world, goal,
                                                                        dock=False)
    assert plan.control[0] == pytest.approx(0.0, abs=1e-6)


def test_cost_function_has_named_terms():
    f = cost_function(CONFIG, SMALL)
    assert f.name_out() == ["cost", *TERM_NAMES]
    assert f.name_in() == ["z", *graph.PARAMETER_NAMES]


def test_hessian_is_finite_at_stop_and_in_collision():
    """The Hessian the solvers use is finite where v_max = 0 and where the robot overlaps a
    wall."""
    from dsmpepc_nlp.solve.build import library as problems

    state, world, goal = _demo_cycle()
    inside = RobotState(0.4, 6.0, 0.0)                 # overlapping the outer wall at x = 0.2
    radius = CONFIG.robot.footprint[0][2]
    assert world.static_distance(np.array([inside.x, inside.y])) < radius - 0.05
    problem = problems.problem(CONFIG, SMALL, SolverConfig())
    for s, zi in ((state, [2.0, 0.0, 0.0, 0.0]), (inside, [2.0, 0.0, 0.0, 0.5])):
        problem.bind(problem.pack(Cycle.prepare(s, world, goal, CONFIG)))
        value, gradient, hessian = problem.fgh(np.array(zi))
        assert np.isfinite(value) and np.all(np.isfinite(gradient))
        assert np.all(np.isfinite(hessian))


def test_polish_never_returns_worse_than_the_best_candidate_and_costs_exactly():
    from dsmpepc_nlp.solve.exact.evaluator import evaluate_batch

    state, world, goal = _demo_cycle()
    cycle = Cycle.prepare(state, world, goal, CONFIG)
    solver = NlpSolver(CONFIG, SolverConfig.fast().replace(n_spread=0, max_iter=3, n_screen=16,
                                                 **BUCKETS), SMALL)
    records = solver.solve(Evaluator(cycle), structured_starts(state, goal, CONFIG))
    best_start = min(r.exact_cost for r in records if r.name != "polish")
    polished = [r for r in records if r.name == "polish"]
    assert len(polished) <= 1
    for record in polished:
        assert record.exact_cost < best_start
        exact = evaluate_batch(record.z[None], cycle).costs.total[0]
        assert record.exact_cost == pytest.approx(exact, abs=1e-12)
        assert np.all(record.z >= np.array(CONFIG.z_lower))
        assert np.all(record.z <= np.array(CONFIG.z_upper))
    off = NlpSolver(CONFIG, SolverConfig.fast().replace(n_spread=0, max_iter=3, n_screen=16,
                                              polish_rounds=0, **BUCKETS), SMALL)
    starts = structured_starts(state, goal, CONFIG)
    assert all(r.name != "polish" for r in off.solve(Evaluator(cycle), starts))


@pytest.mark.parametrize("margin, seeds", [(0.0, 1), (0.6, 2), (np.inf, 3)])
def test_the_polish_leaves_out_candidates_trailing_the_best_by_more_than_its_margin(
        margin, seeds):
    from dsmpepc_nlp.solve.optimize.polish import NEIGHBOURS
    from dsmpepc_nlp.solve.plan import StartRecord

    state, world, goal = _demo_cycle()
    cycle = Cycle.prepare(state, world, goal, CONFIG)
    zs = [[2.0, 0.0, 0.0, 0.5], [3.0, 0.5, -0.5, 0.8], [1.0, -0.5, 0.5, 0.3]]
    records = [StartRecord(name, np.array(z), np.array(z), "screened", False, 0, 0.0, np.nan,
                           cost) for name, z, cost in zip("abc", zs, (-1.0, -0.5, 2.0))]
    rows = len(NEIGHBOURS)
    for threads in (1, 2):
        config = SolverConfig.fast().replace(polish_margin=margin, polish_starts=5, polish_rounds=2,
                                   parallel_rows=7, pair_budget=123_456, solve_threads=threads,
                                   **BUCKETS)
        solver = NlpSolver(CONFIG, config, SMALL)
        evaluator = Evaluator(cycle, config)
        solver.polish.run(records, evaluator)
        # The configuration's batch sizes, not the defaults (the numpy path's chunks too).
        assert (evaluator.parallel_rows, evaluator.pair_budget) == (7, 123_456)
        assert len(solver.polish.last["threads"]) == min(threads, seeds)
        batches = evaluator.batches
        if threads == 1 or seeds == 1:      # one batch a round, over both cores (>= 7 rows)
            assert batches == [(seeds * rows, False)] * 2
        else:                       # the walks shared out over both threads, one core each
            assert len(batches) == 2 * 2 and sum(n for n, _ in batches) == 2 * seeds * rows
            assert all(n % rows == 0 and one_thread for n, one_thread in batches)


def test_scouts_walk_a_round_in_one_batch_and_the_cheapest_walks_on():
    """``polish_scouts``: the candidates after the ``polish_starts`` walk ``scout_rounds``
    rounds in one batch, then the ``promoted`` cheapest of them walk the rest with the others;
    the other walks are those of the polish without scouts, so its plan is never worse."""
    from dsmpepc_nlp.solve.optimize.polish import NEIGHBOURS
    from dsmpepc_nlp.solve.plan import StartRecord

    state, world, goal = _demo_cycle()
    cycle = Cycle.prepare(state, world, goal, CONFIG)
    zs = [[2.0, 0.0, 0.0, 0.5], [3.0, 0.5, -0.5, 0.8], [1.0, -0.5, 0.5, 0.3],
          [4.0, 0.2, 0.3, 0.9], [0.5, -0.2, -0.3, 0.6]]
    records = [StartRecord(name, np.array(z), np.array(z), "screened", False, 0, 0.0, np.nan,
                           np.nan) for name, z in zip("abcde", zs)]
    base = SolverConfig.fast().replace(polish_margin=np.inf, polish_starts=2, polish_rounds=3,
                                       solve_threads=1, **BUCKETS)
    evaluator = Evaluator(cycle, base)
    exact = evaluator.totals(np.array(zs))
    records = [dataclasses.replace(r, exact_cost=float(c)) for r, c in zip(records, exact)]
    rows = len(NEIGHBOURS)
    plain = NlpSolver(CONFIG, base, SMALL).polish
    without = plain.run(records, Evaluator(cycle, base))
    scouting = NlpSolver(CONFIG, base.replace(polish_scouts=3, polish_scout_rounds=1,
                                              polish_promoted=1), SMALL).polish
    evaluator = Evaluator(cycle, base)
    with_scouts = scouting.run(records, evaluator)
    # the scouts' round (3 walks), then the two first seeds' three rounds beside the promoted
    # scout's last two
    assert evaluator.batches == [(3 * rows, False)] * 3 + [(2 * rows, False)]
    best = min(exact)
    assert with_scouts is not None and with_scouts.exact_cost < best
    assert without is None or with_scouts.exact_cost <= without.exact_cost
    seeds, _ = scouting.seeds(records, scouts=True)
    assert len(seeds) == 5 and len(scouting.seeds(records)[0]) == 2


def _assert_same_records(one, two):
    """Two multistarts' records equal to the bit: names, points, statuses, iterations, the
    smooth and the exact costs (NaN equal to NaN)."""
    assert [r.name for r in one] == [r.name for r in two]
    for a, b in zip(one, two):
        np.testing.assert_array_equal(a.z, b.z)
        assert (a.status, a.nit) == (b.status, b.nit)
        for cost in ("smooth_cost", "exact_cost"):
            x, y = getattr(a, cost), getattr(b, cost)
            assert x == y or np.isnan(x) and np.isnan(y), (a.name, cost, x, y)


def _compile_afresh(monkeypatch):
    """Both numba kernels loaded afresh (an earlier test may have turned them off)."""
    from dsmpepc_nlp.solve.exact import loader as exact
    from dsmpepc_nlp.solve.optimize import newton

    monkeypatch.delenv("DSMPEPC_NO_COMPILE", raising=False)
    monkeypatch.setattr(exact, "_STATE", {"kernel": None, "failed": "", "numpy_only": False})
    monkeypatch.setattr(newton, "_KERNEL", {})
    if exact.kernel() is None or newton._kernel() is None:
        pytest.skip("numba missing")


@pytest.mark.parametrize("method, compile_", [("ipopt", False), ("ipopt", True),
                                             ("newton", True)],
                         ids=["ipopt-numpy", "ipopt-compiled", "newton-compiled"])
def test_polishing_ahead_on_the_idle_thread_gives_the_same_plan(monkeypatch, method,
                                                                compile_):
    """``polish_ahead``: the walks run while the last solve runs are the walks the final
    polish would run, so every record of every cycle is the same to the bit, warm starts
    included; and the idle thread did polish ahead."""
    import time

    from dsmpepc_nlp.bench.scenes import demo_cycles
    from dsmpepc_nlp.solve.optimize import threads
    from dsmpepc_nlp.solve.optimize.threads import run_starts

    if compile_:
        _compile_afresh(monkeypatch)

    def last_start_late(solve, n, slots, idle=None, more=None):   # an idle thread, however
        total = [n]                                                # fast the solves

        def listed(busy):
            extra = more(busy)
            total[0] += extra
            return extra

        def late(i, slot):
            if i == total[0] - 1:
                time.sleep(0.05)
            return solve(i, slot)
        return run_starts(late, n, slots, idle, None if more is None else listed)

    monkeypatch.setattr(threads, "run_starts", last_start_late)
    ahead_rounds = []
    knobs = dict(n_spread=2, max_iter=4, n_screen=16, n_solved=3, solve_threads=2,
                 polish_rounds=4, polish_margin=np.inf, polish_starts=3, polish_scouts=3,
                 polish_promoted=1, **BUCKETS)   # solves stopped short; scouts after the walks
    make = SolverConfig.fast if method == "newton" else SolverConfig
    ahead = NlpSolver(CONFIG, make().replace(**knobs), SMALL)
    after = NlpSolver(CONFIG, make().replace(polish_ahead=False, **knobs), SMALL)
    polished = 0
    for state, world, goal in demo_cycles(CONFIG, 4, seed=0, n_samples=64):
        cycle = Cycle.prepare(state, world, goal, CONFIG)
        starts = structured_starts(state, goal, CONFIG)
        one, two = ahead.solve(Evaluator(cycle), starts), after.solve(Evaluator(cycle), starts)
        ahead_rounds.append(ahead.polish.last["ahead_rounds"])
        assert after.polish.last["ahead_rounds"] == 0
        polished += one[-1].name == "polish"
        _assert_same_records(one, two)
    assert ahead_rounds and max(ahead_rounds) > 0 and polished > 0


@pytest.mark.parametrize("method, compile_", [("ipopt", False), ("ipopt", True),
                                             ("newton", True)],
                         ids=["ipopt-numpy", "ipopt-compiled", "newton-compiled"])
def test_screening_while_the_warm_start_solves_gives_the_same_plan(monkeypatch, method,
                                                                  compile_):
    """``screen_ahead``: the warm start's solve begins before the screen of the other starts
    ends (which a slowed screen makes certain), and every record of every cycle is the same
    to the bit as when the screen comes first; without a warm start the screen comes first."""
    import threading
    import time

    from dsmpepc_nlp.bench.scenes import demo_cycles
    from dsmpepc_nlp.solve.optimize import threads
    from dsmpepc_nlp.solve.optimize.threads import run_starts

    if compile_:
        _compile_afresh(monkeypatch)
    events = []
    lock = threading.Lock()

    class SlowScreen(Evaluator):
        """An evaluator whose screen (not a verdict or a polish round) is slow and logged."""

        def totals(self, z, one_thread=False):
            screening = len(z) > 24
            if screening:
                time.sleep(0.02)
            costs = super().totals(z, one_thread)
            if screening:
                with lock:
                    events.append("screened")
            return costs

    def recorded(solve, n, slots, idle=None, more=None):
        def run(i, slot):
            with lock:
                events.append(f"solve {i}")
            return solve(i, slot)
        return run_starts(run, n, slots, idle, more)

    monkeypatch.setattr(threads, "run_starts", recorded)
    knobs = dict(n_spread=2, max_iter=4, n_screen=32, n_solved=3, solve_threads=2,
                 **BUCKETS)
    make = SolverConfig.fast if method == "newton" else SolverConfig
    ahead = NlpSolver(CONFIG, make().replace(**knobs), SMALL)
    first = NlpSolver(CONFIG, make().replace(screen_ahead=False, **knobs), SMALL)
    orders, previous = [], None
    for state, world, goal in demo_cycles(CONFIG, 4, seed=0, n_samples=64):
        cycle = Cycle.prepare(state, world, goal, CONFIG)
        starts = structured_starts(state, goal, CONFIG, previous)
        events.clear()
        one = ahead.solve(SlowScreen(cycle), starts)
        orders.append(list(events))
        best = min((r for r in one if np.isfinite(r.exact_cost)), key=lambda r: r.exact_cost)
        previous = (rollout(best.z, state, CONFIG).target, float(best.z[3]))   # as a planner
        events.clear()
        two = first.solve(SlowScreen(cycle), starts)
        assert events[0] == "screened"
        _assert_same_records(one, two)
    assert orders[0][0] == "screened"                     # no warm start yet: screen first
    assert all(order[0] == "solve 0" and order.index("screened") < order.index("solve 1")
               for order in orders[1:])                    # then the warm solve starts first


@pytest.mark.parametrize("method, hessian, beside", [
    ("ipopt", "quasi-newton", True), ("newton", "differences", False)],
    ids=["ipopt-beside-the-warm-solve", "newton-python-loop-first"])
def test_the_screen_keeps_both_cores_unless_a_solve_runs_beside_it(monkeypatch, method,
                                                                   hessian, beside):
    """The screen runs on one core only while the warm start solves on the other; the fast
    method's Python loop (here with the difference Hessian) lists its starts first, and then
    the screen has both cores."""
    make = SolverConfig.fast if method == "newton" else SolverConfig
    solver = NlpSolver(CONFIG, make().replace(n_spread=2, max_iter=3, n_screen=32, n_solved=2,
                                    solve_threads=2, polish_rounds=0, hessian=hessian,
                                    **BUCKETS), SMALL)
    state, world, goal = _demo_cycle()
    cycle = Cycle.prepare(state, world, goal, CONFIG)
    previous = (rollout(np.array([1.0, 0.0, 0.0, 0.5]), state, CONFIG).target, 0.5)
    records = solver.solve(Evaluator(cycle), structured_starts(state, goal, CONFIG, previous))
    assert any(r.name == "warm" and r.status != "screened" for r in records)
    assert solver.last_screen == {"rows": len(records), "one_thread": beside}


@pytest.mark.parametrize("hessian", ["differences", "quasi-newton"])
def test_both_solvers_lower_the_smooth_cost_from_their_start(hessian):
    from dsmpepc_nlp.solve.build import library as problems
    from dsmpepc_nlp.solve.optimize import solvers

    state, world, goal = _demo_cycle()
    cycle = Cycle.prepare(state, world, goal, CONFIG)
    problem = problems.problem(CONFIG, SMALL, SolverConfig())
    problem.bind(problem.pack(cycle))
    z0 = np.array([2.0, 0.3, -0.2, 0.6])
    for config in (SolverConfig().replace(hessian=hessian, max_iter=15),
                   SolverConfig.fast().replace(hessian=hessian, max_iter=15)):
        result = solvers.make_solver(config).solve(problem, z0)
        assert result.success and np.all(np.isfinite(result.x))
        assert result.fun <= problem.f(z0) + 1e-9
        # Where a solve's time goes: at least one derivative per iteration taken.
        assert result.ngev >= 1
        assert result.nfev + result.ngev >= result.nit


def test_build_prepares_every_object_bucket_of_a_variant():
    from dsmpepc_nlp.solve.optimize import solvers

    result = solvers.build_problems(["mpepc"], SolverConfig(pose_object_buckets=(0, 2)))
    assert result["problems"] == 2 and result["compiled"] is False   # virtual machine here


@pytest.mark.parametrize("compile_", [False, True], ids=["numpy", "compiled"])
def test_the_final_polish_shares_its_walks_over_the_threads_and_ends_the_same(monkeypatch,
                                                                              compile_):
    """The final polish's walks run on both threads, each walk's rounds on one of them, and
    every record (the polish's winner included) is the same to the bit as when one thread
    walks them all in one batch a round."""

    from dsmpepc_nlp.bench.scenes import demo_cycles

    if compile_:
        _compile_afresh(monkeypatch)
    knobs = dict(n_spread=2, max_iter=4, n_screen=16, n_solved=3, polish_ahead=False,
                 polish_starts=4, polish_rounds=4, polish_margin=np.inf, **BUCKETS)
    shared = NlpSolver(CONFIG, SolverConfig().replace(solve_threads=2, **knobs), SMALL)
    alone = NlpSolver(CONFIG, SolverConfig().replace(solve_threads=1, **knobs), SMALL)
    for state, world, goal in demo_cycles(CONFIG, 3, seed=0, n_samples=64):
        cycle = Cycle.prepare(state, world, goal, CONFIG)
        starts = structured_starts(state, goal, CONFIG)
        one = shared.solve(Evaluator(cycle), starts)
        walkers = shared.polish.last["threads"]
        assert any(name.startswith("dsmpepc-walks") for name, _ in walkers)
        assert len(walkers) == 2 and sum(n for _, n in walkers) >= 2
        two = alone.solve(Evaluator(cycle), starts)
        assert len(alone.polish.last["threads"]) == 1
        _assert_same_records(one, two)


def test_use_screen_replaces_the_screened_points_and_keeps_the_spread_starts():
    """``use_screen`` (the tools' way to try another screen) is what the constructor does with
    the configured Sobol points: the records name and cost exactly the new points."""
    solver = NlpSolver(CONFIG, SolverConfig().replace(n_spread=2, n_screen=16, max_iter=5,
                                            **BUCKETS), SMALL)
    configured = solver.screen.copy()
    mine = configured[:5] * 0.5 + 0.5 * np.asarray(CONFIG.z_lower)
    solver.use_screen(mine)
    state, world, goal = _demo_cycle()
    starts = structured_starts(state, goal, CONFIG)
    records = solver.solve(Evaluator(Cycle.prepare(state, world, goal, CONFIG)), starts)
    assert solver.last_screen["rows"] == len(starts) + 2 + 5
    screened = [r for r in records if r.name.startswith("screen-")]
    assert len(screened) == 5 and sum(r.name.startswith("spread-") for r in records) == 2
    np.testing.assert_array_equal(np.array([r.z0 for r in screened]), mine)
