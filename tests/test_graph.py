"""The global cost graph (tables in the graph) against the exact cost, and its compiled form."""

import dataclasses
import shutil
import subprocess
import warnings

import casadi as ca
import numpy as np
import pytest

from dsmpepc_nlp.core import compile_cache as cache
from dsmpepc_nlp.core.config import HorizonConfig, PlannerConfig
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.cost_config import SmoothingConfig
from dsmpepc_nlp.core.exact_cost import evaluate
from dsmpepc_nlp.core.grid import FAR
from dsmpepc_nlp.core.terms import TERM_NAMES
from dsmpepc_nlp.solve import problem as g
from dsmpepc_nlp.solve.build import compiled
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator
from dsmpepc_nlp.solve.problem.geometry import table_lookup

CONFIG = PlannerConfig()


def _demo():
    from dsmpepc_nlp.bench.scenes import demo_cycles

    return demo_cycles(CONFIG, 2, seed=0, n_samples=64)[1]


def _random_z(config, n, seed):
    lower, upper = np.array(config.z_lower), np.array(config.z_upper)
    return lower + np.random.default_rng(seed).random((n, 4)) * (upper - lower)


def _graph(config, sizes, smoothing, cycle, z):
    f = g.build_cost_function(config, sizes, smoothing).map(len(z))
    params = g.pack_parameters(cycle, sizes)
    out = f(z.T, *(params[n] for n in g.PARAMETER_NAMES))
    return {name: np.array(o).ravel() for name, o in zip(["cost", *TERM_NAMES], out)}


@pytest.mark.parametrize("anticipatory, growth", [(False, 0.0), (True, 0.0), (False, 0.16)],
                         ids=["mpepc-ttc-off", "ds-mpepc", "mpepc-growing-bell"])
def test_graph_equals_exact_cost_at_any_z(anticipatory, growth):
    """Exact temperatures: map, NF and objects read as the exact cost reads them, at every z
    (no reference trajectory), the moving objects' bell growing with the look-ahead or not.
    Only the static TTC forms differ: the tangent plane along the trajectory, the sampled ray
    at its end."""
    config = dataclasses.replace(CONFIG, anticipatory_pc=anticipatory, cost=dataclasses.replace(
        CONFIG.cost, sigma_dynamic_growth=growth))
    state, world, goal = _demo()
    z = _random_z(config, 120, 3)
    exact = evaluate(rollout(z, state, config), world, goal, config)
    got = _graph(config, g.GraphSizes(), SmoothingConfig.exact(),
                 Cycle.prepare(state, world, goal, config), z)
    # With the static TTC on, survivability (which weights progress and heading) carries its
    # difference; without it every term but the terminal one is exact.
    exact_terms = ("action",) if anticipatory else ("progress", "action", "heading", "collision")
    for name in exact_terms:
        np.testing.assert_allclose(got[name], exact.terms[name], atol=1e-9)
    assert np.max(np.abs(got["terminal"] - exact.terms["terminal"])) < 0.02
    error = np.abs(got["cost"] - exact.total)
    assert np.median(error) < 1e-9
    assert np.mean(error < 0.01) >= 0.95


def test_smooth_graph_is_near_the_exact_cost():
    state, world, goal = _demo()
    z = _random_z(CONFIG, 60, 4)
    exact = evaluate(rollout(z, state, CONFIG), world, goal, CONFIG).total
    cycle = Cycle.prepare(state, world, goal, CONFIG)
    errors = [np.median(np.abs(_graph(CONFIG, g.GraphSizes(), CONFIG.smoothing.scaled(f),
                                      cycle, z)["cost"] - exact)) for f in (1.0, 0.01)]
    assert errors[0] < 0.005
    assert errors[1] < errors[0]


def test_window_smaller_than_the_map_is_exact_near_the_robot():
    """A 64-cell window of the 0.1 m demo map (6.4 m) still holds short trajectories."""
    state, world, goal = _demo()
    config = CONFIG
    z = _random_z(config, 40, 5)
    z[:, 0] = np.minimum(z[:, 0], 1.5)
    z[:, 3] = np.minimum(z[:, 3], 0.3)
    exact = evaluate(rollout(z, state, config), world, goal, config)
    sizes = g.GraphSizes(table_cells=64)
    got = _graph(config, sizes, SmoothingConfig.exact(), Cycle.prepare(state, world, goal, config),
                 z)
    np.testing.assert_allclose(got["progress"], exact.terms["progress"], atol=1e-9)


SMALL_CONFIG = dataclasses.replace(CONFIG, horizon=HorizonConfig(n_steps=4))
SMALL_SIZES = g.GraphSizes(max_objects=2, table_cells=16, ray_samples=4)


def _small_functions():
    cost = g.flat_cost(SMALL_CONFIG, SMALL_SIZES)
    span = np.array(SMALL_CONFIG.z_upper) - np.array(SMALL_CONFIG.z_lower)
    return cost, 1e-6 * span


needs_compiler = pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None,
                                    reason="no C compiler")


def _compile_into(tmp_path, monkeypatch):
    """Compiled libraries go to ``tmp_path`` (a fresh cache), compilation on."""
    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("DSMPEPC_NO_COMPILE", raising=False)


def _small_cycle():
    state, world, goal = _demo()
    return Cycle.prepare(state, world, goal, SMALL_CONFIG)


def _small_parameters():
    """The graph's flat parameters (a ``Problem`` adds its difference steps: ``pack``)."""
    return g.flatten_parameters(g.pack_parameters(_small_cycle(), SMALL_SIZES))


@needs_compiler
def test_compiled_functions_equal_the_virtual_machine_and_are_cached(tmp_path, monkeypatch):
    """... and a cached library is loaded alone: the graph is built only to compile."""
    _compile_into(tmp_path, monkeypatch)
    cost, step = _small_functions()
    made = []

    def make():
        made.append(True)
        return cost

    built = compiled.load_or_compile(make, step, (SMALL_CONFIG, SMALL_SIZES))
    assert built.compiled and len(made) == 1
    again = compiled.load_or_compile(make, step, (SMALL_CONFIG, SMALL_SIZES))
    assert again.compiled and len(made) == 1          # no graph built, no compiler run
    assert again.n_params == built.n_params == cost.size1_in(1)
    assert len(list((tmp_path).rglob("*.so"))) == 1
    machine = compiled.Compiled(compiled.problem_functions(cost, step), None)
    p = _small_parameters()
    for functions in (built, again, machine):
        functions.bind(p)
    for z in _random_z(SMALL_CONFIG, 5, 6):
        for name in compiled.NAMES:
            for mine, theirs in zip(built.call(name, z), machine.call(name, z)):
                np.testing.assert_allclose(mine, theirs, rtol=1e-9, atol=1e-9)
            for mine, theirs in zip(again.call(name, z), built.call(name, z)):
                np.testing.assert_array_equal(mine, theirs)
        # The CasADi externals (what nlpsol calls) are the same code, with the parameters
        # passed or bound.
        external = built.functions["F"](z, p)
        assert float(external) == pytest.approx(machine.call("F", z)[0].item(), abs=1e-9)
        for name in compiled.NAMES:
            bound = built.functions[compiled.OF_Z_ALONE[name]](z)
            bound = bound if isinstance(bound, (list, tuple)) else [bound]
            for mine, theirs in zip(bound, machine.call(name, z)):
                np.testing.assert_allclose(np.array(mine), theirs, rtol=1e-9, atol=1e-9)


@needs_compiler
def test_compiled_newton_loop_takes_the_python_loops_steps(tmp_path, monkeypatch):
    """The trust-region loop in compiled code (calling the generated functions itself) is
    the Python loop with the SR1 Hessian: same iterations, evaluations, status and point
    (to rounding: numba's and numpy's 4 x 4 products may differ in the last bit)."""
    from dsmpepc_nlp.core.solver_config import SolverConfig
    from dsmpepc_nlp.solve.build import library as problems
    from dsmpepc_nlp.solve.optimize import newton, threads

    _compile_into(tmp_path, monkeypatch)
    problem = problems.Problem(SMALL_CONFIG, SMALL_SIZES, SolverConfig())
    assert problem.functions.compiled
    problem.bind(problem.pack(_small_cycle()))
    if newton._kernel() is None:
        pytest.skip("numba missing")
    starts = _random_z(SMALL_CONFIG, 8, 7)
    natives = newton.minimize_compiled(problem.functions, starts, problem.lower, problem.upper,
                                       max_iter=25)       # all at once, on parallel threads
    assert len(natives) == len(starts)
    for z0, native in zip(starts, natives):
        python = newton.minimize(problem.f, newton.sr1(problem), z0, problem.lower,
                                 problem.upper, max_iter=25)
        assert (native.nit, native.nfev, native.nhev, native.status) == \
            (python.nit, python.nfev, python.nhev, python.status)
        np.testing.assert_allclose(native.x, python.x, atol=1e-9)
        assert native.fun == pytest.approx(python.fun, abs=1e-9)
    # No start up front, all of them listed by ``more``: the same solves, in order.
    class Listing(threads.StartExecutor):
        open_ended = True

        def further(self, busy):
            return list(starts)

    listed = newton.minimize_compiled(problem.functions, starts[:0], problem.lower,
                                      problem.upper, max_iter=25, executor=Listing(2))
    assert [(r.nit, r.status, r.fun) for r in listed] == \
        [(r.nit, r.status, r.fun) for r in natives]
    assert all(np.array_equal(a.x, b.x) for a, b in zip(listed, natives))
    machine = compiled.Compiled(problem.functions.functions, None)   # not compiled: no loop
    assert newton.minimize_compiled(machine, starts, problem.lower, problem.upper) is None
    # A compiled loop that fails (say a numba that cannot type the call) warns once and hands
    # over to the Python loop: the solver still solves.
    def broken(*args):
        raise TypeError("cannot type")

    monkeypatch.setattr(newton._kernel(), "minimize_sr1", broken)
    monkeypatch.setitem(newton._KERNEL, "loop_failed", False)
    monkeypatch.setattr(cache, "_WARNED", set())
    with pytest.warns(RuntimeWarning, match="compiled Newton loop failed"):
        assert newton.minimize_compiled(problem.functions, starts, problem.lower,
                                        problem.upper) is None
    fast = SolverConfig.fast().replace(max_iter=25)
    result = newton.NewtonSolver(fast).solve(problem, starts[0])
    python = newton.minimize(problem.f, newton.sr1(problem), starts[0], problem.lower,
                             problem.upper, radius=fast.local.trust_radius, max_iter=25,
                             tol=fast.local.tol)
    assert result.nit == python.nit and result.fun == pytest.approx(python.fun, abs=1e-12)


@pytest.mark.parametrize("compile_", [True, False], ids=["compiled", "virtual-machine"])
def test_ipopt_solves_on_threads_are_the_solves_one_after_another(tmp_path, monkeypatch,
                                                                  compile_):
    """``solve_threads``: each thread slot has its own nlpsol; every start, cold or warm,
    gives the same point, cost, iterations and status as when solved alone, in order."""
    from dsmpepc_nlp.core.solver_config import SolverConfig
    from dsmpepc_nlp.solve.build import library as problems
    from dsmpepc_nlp.solve.optimize import ipopt

    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path))
    if compile_:
        monkeypatch.delenv("DSMPEPC_NO_COMPILE", raising=False)
    else:
        monkeypatch.setenv("DSMPEPC_NO_COMPILE", "1")
    problem = problems.Problem(SMALL_CONFIG, SMALL_SIZES, SolverConfig())
    assert problem.functions.compiled == compile_
    problem.bind(problem.pack(_small_cycle()))
    starts = _random_z(SMALL_CONFIG, 5, 11)
    one = ipopt.IpoptSolver(SolverConfig().replace(solve_threads=1, max_iter=15))
    warm = one.solve(problem, starts[0]).lam_x
    plan = [(z0, warm if i == 2 else None) for i, z0 in enumerate(starts)]
    alone = one.solve_many(problem, plan)
    threaded = ipopt.IpoptSolver(SolverConfig().replace(solve_threads=3, max_iter=15))
    for _ in range(2):                       # the slots' nlpsol are reused on the second call
        together = threaded.solve_many(problem, plan)
        assert len(together) == len(plan)
        for a, b in zip(alone, together):
            assert (a.nit, a.status, a.nfev, a.ngev) == (b.nit, b.status, b.nfev, b.ngev)
            np.testing.assert_array_equal(a.x, b.x)
            assert a.fun == b.fun
    assert {key[2] for key in threaded._built} == {0, 1, 2}


def test_no_compile_falls_back_to_the_virtual_machine_with_one_warning(tmp_path, monkeypatch):
    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("DSMPEPC_NO_COMPILE", "1")
    monkeypatch.setattr(cache, "_WARNED", set())
    cost, step = _small_functions()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        first = compiled.load_or_compile(lambda: cost, step, (SMALL_CONFIG, SMALL_SIZES))
        compiled.load_or_compile(lambda: cost, step, (SMALL_CONFIG, SMALL_SIZES))
    assert not first.compiled
    assert len([w for w in caught if "virtual machine" in str(w.message)]) == 1
    assert not list(tmp_path.rglob("*.so"))
    first.bind(_small_parameters())
    value, gradient, hessian = first.call("H", _random_z(SMALL_CONFIG, 1, 7)[0])
    assert np.isfinite(value).all() and np.isfinite(gradient).all()
    np.testing.assert_allclose(hessian, hessian.T, atol=1e-12)


def test_newton_on_the_global_graph_returns_finite_records(tmp_path, monkeypatch):
    """``SolverConfig.fast()``: one solve per start, records in the box, never above the
    start on the smooth cost."""
    from dsmpepc_nlp.core.solver_config import SolverConfig
    from dsmpepc_nlp.solve.optimize.multistart import NlpSolver
    from dsmpepc_nlp.solve.optimize.starts import structured_starts

    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("DSMPEPC_NO_COMPILE", "1")
    state, world, goal = _demo()
    solver = NlpSolver(SMALL_CONFIG, SolverConfig.fast().replace(n_screen=4, max_iter=10,
                                                       pose_object_buckets=(2,)), SMALL_SIZES)
    cycle = Cycle.prepare(state, world, goal, SMALL_CONFIG)
    records = solver.solve(Evaluator(cycle), structured_starts(state, goal, SMALL_CONFIG))
    solved = [r for r in records if r.status != "screened" and r.name != "polish"]
    assert len(solved) == solver.n_solved == len(solver.last_stats)
    lower, upper = np.array(SMALL_CONFIG.z_lower), np.array(SMALL_CONFIG.z_upper)
    for record in records:
        assert np.all(np.isfinite(record.z)) and np.isfinite(record.exact_cost)
        assert np.all(record.z >= lower) and np.all(record.z <= upper)
    sizes = solver.sizes_for(cycle)
    cost = g.flat_cost(SMALL_CONFIG, sizes)
    p = g.flatten_parameters(g.pack_parameters(cycle, sizes))
    for record in solved:
        assert record.smooth_cost <= float(cost(record.z0, p)) + 1e-9


def test_object_bucket_is_the_smallest_holding_the_objects_in_reach():
    from dsmpepc_nlp.core.solver_config import SolverConfig
    from dsmpepc_nlp.solve.optimize.multistart import NlpSolver

    state, world, goal = _demo()
    cycle = Cycle.prepare(state, world, goal, CONFIG)
    in_reach = g.objects_in_reach(cycle)
    assert 0 < in_reach < len(world.obstacles)
    for buckets, expected in (((0, in_reach, 12), in_reach), ((0, in_reach - 1), in_reach - 1),
                              ((in_reach + 1, 40), in_reach + 1)):
        solver = NlpSolver(CONFIG, SolverConfig(pose_object_buckets=buckets))
        assert solver.sizes_for(cycle).k_pose == expected


def test_pose_objects_out_of_reach_change_nothing():
    """The per-pose block holds only objects in reach: with exact temperatures the graph with
    the smallest bucket that holds them equals the graph with every object at every pose."""
    state, world, goal = _demo()
    cycle = Cycle.prepare(state, world, goal, CONFIG)
    z = _random_z(CONFIG, 8, 9)
    everything = g.GraphSizes(max_objects=12)
    reach = dataclasses.replace(everything, pose_objects=g.objects_in_reach(cycle))
    exact = SmoothingConfig.exact()
    np.testing.assert_allclose(_graph(CONFIG, reach, exact, cycle, z)["cost"],
                               _graph(CONFIG, everything, exact, cycle, z)["cost"], atol=1e-12)


@pytest.mark.parametrize("smooth, growth", [(False, 0.0), (True, 0.0), (False, 0.16)],
                         ids=["exact", "smooth", "growing-bell"])
def test_pose_mask_skips_only_pairs_that_cannot_matter(smooth, growth):
    """The per-pose mask skips most pose-object pairs of the crowded demo scene, and the
    cost and its gradient with it equal those with every pair computed (mask all ones), at
    exact and at smooth temperatures, and with a bell that grows with the look-ahead (whose
    cull distance grows with it)."""
    config = dataclasses.replace(CONFIG, cost=dataclasses.replace(
        CONFIG.cost, sigma_dynamic_growth=growth))
    state, world, goal = _demo()
    cycle = Cycle.prepare(state, world, goal, config)
    sizes = g.GraphSizes(max_objects=12)
    params = g.pack_parameters(cycle, sizes)
    mask = params["pose_mask"]
    assert mask.shape == (config.horizon.n_steps + 1, 12)
    assert 0.1 < mask.mean() < 0.9                    # some pairs skipped, some computed
    assert not mask[0].any()                          # nobody within reach at the start
    smoothing = config.smoothing if smooth else SmoothingConfig.exact()
    cost = g.build_cost_function(config, sizes, smoothing)
    z_sym = ca.MX.sym("z", 4)
    inputs = [z_sym, *(ca.MX.sym(n, *s) for n, s in g.parameter_shapes(config, sizes).items())]
    value = cost(*inputs)[0]
    fg = ca.Function("fg", inputs, [value, ca.gradient(value, z_sym)])
    everywhere = dict(params, pose_mask=np.ones_like(mask))
    for z in _random_z(config, 12, 21):
        masked = [np.array(o) for o in fg(z, *(params[n] for n in g.PARAMETER_NAMES))]
        full = [np.array(o) for o in fg(z, *(everywhere[n] for n in g.PARAMETER_NAMES))]
        np.testing.assert_allclose(masked[0], full[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(masked[1], full[1], rtol=0, atol=1e-12)


def _compile_table_reader(folder, fast: bool):
    """A table look-up and its gradient in the graph's form, compiled with or without the
    bilinear fast paths (compiled.specialise)."""
    sizes = g.GraphSizes(max_objects=1, table_cells=16, ray_samples=4)
    uv, table = ca.MX.sym("uv", 2), ca.MX.sym("table", sizes.table_cells ** 2)
    value = table_lookup(sizes)(uv, table)
    reader = ca.Function("reader", [uv, table], [value, ca.gradient(value, uv)])
    generator = ca.CodeGenerator("reader.c", {"with_header": False})
    generator.add(reader)
    generator.generate(str(folder) + "/")
    source = (folder / "reader.c").read_text()
    if fast:
        fast_source = compiled.specialise(source)
        assert fast_source.count("dsmpepc: 2-d") == 2     # both fast paths entered
        source = fast_source
    name = "fast" if fast else "generic"
    (folder / f"{name}.c").write_text(source)
    subprocess.run([shutil.which("gcc") or shutil.which("cc"), "-shared", "-fPIC", "-O1", "-o",
                    str(folder / f"{name}.so"), str(folder / f"{name}.c"), "-lm"], check=True)
    return ca.external("reader", str(folder / f"{name}.so")), reader


@needs_compiler
def test_bilinear_fast_paths_give_the_generic_codes_bits(tmp_path):
    fast, reader = _compile_table_reader(tmp_path, True)
    generic, _ = _compile_table_reader(tmp_path, False)
    rng = np.random.default_rng(3)
    table = rng.normal(size=16 * 16)
    # Inside the grid, on nodes and cell edges, and beyond it (clamped to the edge cells).
    points = np.vstack([rng.uniform(-3.0, 18.0, (300, 2)),
                        rng.integers(0, 16, (40, 2)).astype(float),
                        [[0.0, 0.0], [15.0, 15.0], [15.0, 0.5], [7.5, 15.0]]])
    for uv in points:
        mine, theirs = fast(uv, table), generic(uv, table)
        for a, b in zip(mine, theirs):
            assert np.array_equal(np.array(a), np.array(b)), uv
        for a, b in zip(mine, reader(uv, table)):
            np.testing.assert_allclose(np.array(a), np.array(b), rtol=1e-12, atol=1e-12)


def _pack_obstacles_one_by_one(cycle, sizes, k_max, reach_only):
    """pack_obstacles as a loop over the objects (its earlier form): the reference."""
    c_obj = sizes.circles_per_object
    circles = np.tile([FAR, FAR, 0.1], (k_max * c_obj, 1))
    velocities, indices = np.zeros((k_max, 2)), np.full(k_max * c_obj, -1)
    owner = cycle.owner
    gap = np.min(np.linalg.norm(cycle.predicted - [cycle.state.x, cycle.state.y], axis=-1),
                 axis=0) - cycle.radii
    per_object = np.full(int(owner.max()) + 1, np.inf)
    np.minimum.at(per_object, owner, gap)
    candidates = np.argsort(per_object, kind="stable")
    if reach_only:
        candidates = candidates[np.asarray(cycle.in_reach, dtype=bool)[candidates]]
    for slot, index in enumerate(candidates[:k_max]):
        mine = np.flatnonzero(owner == index)
        near = mine[np.argsort(gap[mine], kind="stable")[:c_obj]]
        near = np.r_[near, np.repeat(near[:1], c_obj - len(near))]
        circles[slot * c_obj:(slot + 1) * c_obj] = np.column_stack(
            [cycle.centers[near], cycle.radii[near]])
        velocities[slot] = cycle.velocities[near[0]]
        indices[slot * c_obj:(slot + 1) * c_obj] = near
    return circles, velocities, indices


def test_packed_objects_are_the_nearest_circles_of_the_nearest_objects():
    """Robots of several circles (equal gaps among them) and pedestrians, more and fewer
    objects than slots, one to three circles per slot: the vectorised packing equals the
    loop over objects to the bit."""
    from dsmpepc_nlp.core.config import RobotState
    from dsmpepc_nlp.core.world import DynamicObstacle, World

    rng = np.random.default_rng(5)
    footprint = ((0.2, 0.0, 0.2), (-0.2, 0.0, 0.2), (0.0, 0.0, 0.2))
    obstacles = []
    for _ in range(9):
        x, y = rng.uniform(-4.0, 4.0, 2)
        if rng.random() < 0.5:
            obstacles.append(DynamicObstacle.robot((x, y, rng.uniform(-3, 3)),
                                                   tuple(rng.uniform(-0.5, 0.5, 2)), footprint))
        else:
            obstacles.append(DynamicObstacle.pedestrian((x, y), tuple(rng.uniform(-1, 1, 2))))
    cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.3), World(None, obstacles), (3.0, 1.0),
                          CONFIG)
    assert len(cycle.owner) > len(obstacles)            # some objects have several circles
    for c_obj in (1, 2, 3, 4):
        sizes = dataclasses.replace(g.GraphSizes(), circles_per_object=c_obj)
        for k_max in (1, 4, 9, 12):
            for reach_only in (False, True):
                mine = g.pack_obstacles(cycle, sizes, k_max, reach_only)
                theirs = _pack_obstacles_one_by_one(cycle, sizes, k_max, reach_only)
                for a, b in zip(mine, theirs):
                    np.testing.assert_array_equal(a, b)


@needs_compiler
def test_a_compiler_without_the_extra_options_still_compiles(tmp_path, monkeypatch):
    """Options the compiler refuses fall back to plain -O2, not to the virtual machine."""
    _compile_into(tmp_path, monkeypatch)
    cost, step = _small_functions()
    functions = compiled.problem_functions(cost, step)
    library = compiled.compile_library(functions, "refused_option",
                                       flags=("-O2", "--no-such-option-for-any-compiler"))
    assert library is not None and library.exists()
    loaded = compiled.Compiled(functions, library)
    machine = compiled.Compiled(functions, None)
    p = _small_parameters()
    loaded.bind(p)
    machine.bind(p)
    z = _random_z(SMALL_CONFIG, 1, 2)[0]
    np.testing.assert_allclose(loaded.call("G", z)[1], machine.call("G", z)[1], rtol=1e-9,
                               atol=1e-9)



def test_a_failing_compiler_is_tried_once_more_only_without_the_extra_options(tmp_path,
                                                                               monkeypatch):
    """A compiler that always fails: the level with the other options, then the level alone
    (once when it is alone), then CasADi's virtual machine after one warning."""
    _compile_into(tmp_path, monkeypatch)
    cost, step = _small_functions()
    functions = compiled.problem_functions(cost, step)
    calls = []

    def failing(command, **options):
        calls.append(tuple(command[3:command.index("-o")]))    # after cc -shared -fPIC
        return subprocess.CompletedProcess(command, 1, "", "refused")

    monkeypatch.setattr(compiled.subprocess, "run", failing)
    monkeypatch.setattr(compiled, "_compiler", lambda: "cc")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert compiled.compile_library(functions, "fails_a", flags=("-O2", "-fx")) is None
        assert calls == [("-O2", "-fx"), ("-O2",)]
        calls.clear()
        assert compiled.compile_library(functions, "fails_b", flags=("-O1",)) is None
        assert calls == [("-O1",)]


def test_the_far_branch_reads_only_what_is_differentiated():
    """Where an object cannot matter the conditional's far branch is exactly 1 with a zero
    derivative. In the solvers' graph (parameters fixed) it reads only the pose and speed, the
    inputs whose adjoints the gradient carries, not the 37 settings, the circles or the
    velocity (37 additions a call, on every far pose of every object); in the graph to embed
    (nothing fixed) it reads every input."""
    from dsmpepc_nlp.solve.problem.layout import resolved_sizes
    from dsmpepc_nlp.solve.problem.pieces import object_function

    sizes = resolved_sizes(CONFIG, g.GraphSizes(max_objects=3, table_cells=48, pose_objects=2))
    for fixed, read in ((True, {0, 1}), (False, {0, 1, 2, 3, 4, 5})):
        far = object_function(CONFIG, sizes, None, fixed).find_function("dsmpepc_object_far")
        inputs = far.sx_in()
        out = far.call(inputs)[0]
        assert {i for i, x in enumerate(inputs) if ca.depends_on(out, x)} == read
        values = [np.random.default_rng(i).uniform(-3, 3, x.shape) for i, x in enumerate(inputs)]
        assert float(far(*values)) == 1.0
