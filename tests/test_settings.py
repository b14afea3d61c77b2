"""The configuration's numbers are parameters of the compiled graph, keyed by structure alone."""

import dataclasses
import math

import casadi as ca
import numpy as np
import pytest

from dsmpepc_nlp.core import compile_cache as cache
from dsmpepc_nlp.core.config import ControlLawConfig, HorizonConfig, PlannerConfig, RobotConfig
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.cost_config import CostConfig, SmoothingConfig
from dsmpepc_nlp.core.exact_cost import evaluate
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.terms import TERM_NAMES
from dsmpepc_nlp.solve import problem as g
from dsmpepc_nlp.solve.build import compiled
from dsmpepc_nlp.solve.build.library import structure_key
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.problem import parameters as settings

SIZES = g.GraphSizes(max_objects=3, table_cells=48, pose_objects=2)


def _other(config: PlannerConfig) -> PlannerConfig:
    """``config`` with every number the graph reads changed (structure kept)."""
    return dataclasses.replace(
        config,
        robot=RobotConfig(v_limit=0.8, omega_limit=1.2, accel_limit=2.0, alpha_limit=2.5,
                          footprint=((0.0, 0.0, 0.27),)),
        control_law=ControlLawConfig(k1=1.2, k2=2.5, beta=0.3, lam=2.0, r_thresh=1.0,
                                     r_thresh_from_robot=False),
        horizon=HorizonConfig(dt=0.25, n_steps=config.horizon.n_steps),
        cost=CostConfig(sigma_static=0.05, sigma_dynamic=0.25, c_heading=0.3, c_v=0.15,
                        c_w=0.12, c_collision=0.2, w_progress=1.1, w_action=0.9,
                        w_terminal=1.3, a=0.6, s_ttc=0.37, s_ttg=2e-3, ttc_range=7.0),
        smoothing=SmoothingConfig(distance=0.03, speed=0.03, acceleration=0.02, rate=0.03,
                                  curvature=0.02, inverse_time=0.03, angle=0.02),
    )


def _scene(config):
    from dsmpepc_nlp.bench.scenes import demo_cycles

    state, world, goal = demo_cycles(config, 2, seed=0, n_samples=64)[1]
    return Cycle.prepare(state, world, goal, config), (state, world, goal)


def _evaluate(function, cycle, sizes, z):
    params = g.pack_parameters(cycle, sizes)
    out = function.map(len(z))(z.T, *(params[n] for n in g.PARAMETER_NAMES))
    return {name: np.array(o).ravel() for name, o in zip(["cost", *TERM_NAMES], out)}


def test_every_number_is_a_parameter_not_structure():
    base = PlannerConfig()
    other = _other(base)
    assert settings.structure(base) == settings.structure(other)
    assert structure_key(base, SIZES) == structure_key(other, SIZES)
    assert not np.array_equal(settings.values(base), settings.values(other))
    # A circle's offsets are parameters too, once off the centre (0 is structure: nothing to
    # rotate).
    shifted = [dataclasses.replace(base, robot=RobotConfig(footprint=(circle,)))
               for circle in ((0.05, -0.02, 0.27), (0.1, 0.03, 0.25))]
    assert structure_key(*shifted[:1], SIZES) == structure_key(shifted[1], SIZES)
    # Every float field of the sections the graph reads is in the block (derived, not listed).
    for section in settings.SECTIONS:
        for field in dataclasses.fields(getattr(base, section)):
            if field.type == "float":
                assert f"{section}.{field.name}" in settings.names(base)


@pytest.mark.parametrize("change", [
    dict(horizon=HorizonConfig(n_steps=20)),
    dict(robot=RobotConfig(footprint=((0.2, 0, 0.3), (-0.2, 0, 0.3)))),
    dict(robot=RobotConfig(accel_limit=math.inf)),
    dict(control_law=ControlLawConfig(lam=3.0)),
    dict(smoothing=SmoothingConfig.exact()),
    dict(cost=CostConfig(disabled=("heading",))),
], ids=["steps", "circles", "accel-inf", "lam", "exact", "disabled"])
def test_structure_changes_the_key(change):
    base = PlannerConfig()
    assert structure_key(base, SIZES) != structure_key(dataclasses.replace(base, **change),
                                                       SIZES)


@pytest.mark.parametrize("other", [
    PlannerConfig.variant("mpepc"), PlannerConfig.variant("pc-only"),
    PlannerConfig.variant("terminal-only"), _other(PlannerConfig()),
], ids=["mpepc", "pc-only", "terminal-only", "every-number"])
def test_a_graph_built_for_one_configuration_serves_another(other):
    """The graph built from the defaults, given another configuration's settings, is that
    configuration's own graph to the bit (the same key; no number of the first is built in):
    MPEPC and the ablations are DS-MPEPC's graph with a switch's 0."""
    base = PlannerConfig()
    assert structure_key(base, SIZES) == structure_key(other, SIZES)
    cycle, _ = _scene(other)
    z = np.random.default_rng(1).uniform(other.z_lower, other.z_upper, (30, 4))
    got = _evaluate(g.build_cost_function(base, SIZES), cycle, SIZES, z)
    own = _evaluate(g.build_cost_function(other, SIZES), cycle, SIZES, z)
    for name in got:
        np.testing.assert_array_equal(got[name], own[name])
    # ... and it is not the first configuration's cost.
    first = _evaluate(g.build_cost_function(base, SIZES), _scene(base)[0], SIZES, z)
    assert not np.allclose(first["cost"], got["cost"])
    if not other.terminal_cost:
        assert np.all(got["terminal"] == 0.0)


def test_parametric_graph_at_exact_temperatures_is_the_exact_cost_of_another_configuration():
    other = dataclasses.replace(_other(PlannerConfig()), anticipatory_pc=False)
    cycle, (state, world, goal) = _scene(other)
    z = np.random.default_rng(2).uniform(other.z_lower, other.z_upper, (60, 4))
    exact = evaluate(rollout(z, state, other), world, goal, other)
    sizes = g.GraphSizes()          # the whole map in the window, as the exact cost reads it
    got = _evaluate(g.build_cost_function(other, sizes, SmoothingConfig.exact()), cycle, sizes,
                    z)
    for name in ("progress", "action", "heading", "collision"):
        np.testing.assert_allclose(got[name], exact.terms[name], atol=1e-9)


def test_a_settings_layout_change_gives_a_new_library_key(monkeypatch):
    config = PlannerConfig()
    key = compiled.library_key(*structure_key(config, SIZES))
    monkeypatch.setattr(settings, "SECTIONS", tuple(reversed(settings.SECTIONS)))
    assert compiled.library_key(*structure_key(config, SIZES)) != key


def test_source_closure_is_derived_from_the_imports(tmp_path, monkeypatch):
    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path))
    names = {p.name for p in cache.source_closure("dsmpepc_nlp.solve.problem.build")}
    # The graph's own modules and what they import, not the planner that uses them.
    assert {"build.py", "pieces.py", "geometry.py", "layout.py", "parameters.py", "costs.py",
            "control_law.py", "smooth.py", "config.py"} <= names
    assert "planner.py" not in names and "simulate.py" not in names
    kernel = {p.name for p in cache.source_closure("dsmpepc_nlp.solve.exact.kernel.costs")}
    # The kernel's modules, and cycle.py: the kernel freezes cycle.PARAMETERS' positions.
    assert {"cycle.py", "layout.py", "law.py", "geometry.py", "costs.py"} <= kernel
    first = cache.sources_hash("dsmpepc_nlp.solve.exact.kernel.costs")
    assert cache.sources_hash("dsmpepc_nlp.solve.exact.kernel.costs") == first   # memo read back


def test_sources_hash_follows_an_edit(tmp_path, monkeypatch):
    """A module of the closure edited (here: a copy of the package) gives a new hash."""
    import shutil

    package = tmp_path / "dsmpepc_nlp"
    shutil.copytree(cache._PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(cache, "_PACKAGE", package)
    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path / "cache"))
    before = cache.sources_hash("dsmpepc_nlp.solve.exact.kernel.costs")
    cycle = package / "solve" / "exact" / "cycle.py"
    cycle.write_text(cycle.read_text() + "\n# an edit\n")
    assert cache.sources_hash("dsmpepc_nlp.solve.exact.kernel.costs") != before


def test_two_checkouts_sharing_a_cache_keep_their_own_hashes(tmp_path, monkeypatch):
    """The memo of a closure's hash belongs to one package folder: a second checkout of other
    code, with the same cache, must not read the first one's hash back (it once did: the
    memo was named by the module alone, and the first checkout's files were still unchanged)."""
    import shutil

    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path / "cache"))
    hashes = {}
    for name in ("a", "b"):
        package = tmp_path / name / "dsmpepc_nlp"
        shutil.copytree(cache._PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
        if name == "b":
            cycle = package / "solve" / "exact" / "cycle.py"
            cycle.write_text(cycle.read_text() + "\n# other code\n")
        monkeypatch.setattr(cache, "_PACKAGE", package)
        hashes[name] = cache.sources_hash("dsmpepc_nlp.solve.exact.kernel.costs")
    assert hashes["a"] != hashes["b"]


def test_prune_bounds_the_cache_and_drops_other_versions(tmp_path, monkeypatch):
    monkeypatch.setenv("DSMPEPC_CACHE_DIR", str(tmp_path))
    here = cache.cache_dir("casadi")
    old = tmp_path / "0.0.1" / "casadi"
    old.mkdir(parents=True)
    (old / "nlp_old.so").write_bytes(b"x" * 10)
    for i in range(5):
        path = here / f"nlp_{i}.so"
        path.write_bytes(b"x" * 1000)
        import os

        os.utime(path, (1000.0 + i, 1000.0 + i))   # older first
    newest = here / "nlp_4.so"
    import os

    os.utime(newest, None)
    removed = cache.prune(max_bytes=2500, max_idle_days=1e9)
    left = sorted(p.name for p in here.iterdir())
    assert left == ["nlp_3.so", "nlp_4.so"]
    assert not (tmp_path / "0.0.1").exists()
    assert {e["path"].name for e in removed} >= {"nlp_0.so", "nlp_1.so", "nlp_2.so"}
    removed = cache.prune(max_bytes=10**9, max_idle_days=1.0)   # nlp_3 is years old
    assert [p.name for p in here.iterdir()] == ["nlp_4.so"]
    assert cache.clear() == 1000
    assert not tmp_path.exists() or not any(tmp_path.iterdir())


def test_build_lock_serialises_builders(tmp_path):
    import threading
    import time

    order = []

    def build(name):
        with cache.build_lock(tmp_path / "lib.so"):
            order.append(f"{name}-in")
            time.sleep(0.05)
            order.append(f"{name}-out")

    threads = [threading.Thread(target=build, args=(n,)) for n in "ab"]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert order[0][0] == order[1][0] and order[2][0] == order[3][0]


def test_problem_binds_the_settings_and_the_difference_steps():
    from dsmpepc_nlp.solve.build.library import Problem

    other = _other(PlannerConfig())
    cycle, _ = _scene(other)
    problem = Problem(other, SIZES, SolverConfig())
    p = problem.pack(cycle)
    assert p.size == problem.n_params
    np.testing.assert_array_equal(p[-4:], SolverConfig().local.fd_step
                                  * (np.array(other.z_upper) - np.array(other.z_lower)))
    problem.bind(p)
    z = np.array([2.0, 0.1, -0.2, 0.6])
    cost = g.build_cost_function(other, SIZES)
    params = g.pack_parameters(cycle, SIZES)
    expected = float(cost(z, *(params[n] for n in g.PARAMETER_NAMES))[0])
    assert problem.f(z) == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_long_generated_functions_are_compiled_lighter():
    from dsmpepc_nlp.solve.build import csource

    head = "static int casadi_f{}(const casadi_real** arg, casadi_real** res) {{\n"
    short = head.format(1) + "  a=1;\n" * 3 + "}\n"
    long = head.format(2) + "  a=1;\n" * 12 + "}\n"
    out = csource.lighten(short + long, lines=10)
    assert out.count('optimize("O1")') == 1
    assert out.index('optimize("O1")') > out.index("casadi_f1") and out.endswith(long)
    assert csource.lighten(short + long, lines=100) == short + long


def _operations(function) -> set:
    """The CasADi operation codes an SX function runs."""
    return {function.instruction_id(k) for k in range(function.n_instructions())}


def test_a_centred_circle_is_not_rotated_and_an_offset_one_is():
    """A circle's offset of 0 is structure (in the key), so the graph builds it in: the pose's
    map query then reads no footprint offset and takes no sine or cosine of the heading (it
    did, multiplying them by a parameter that was 0, a measurable share of a call), nor does
    the pose's geometry read an offset; an offset circle rotates, and its graph still equals
    the exact cost (the tests above)."""
    from dsmpepc_nlp.solve.problem.pieces import pose_functions

    trig = {ca.OP_SIN, ca.OP_COS}
    centred = PlannerConfig()
    assert all(cx == 0 and cy == 0 for cx, cy, _ in centred.robot.footprint)
    query, geometry = pose_functions(centred, SIZES, None, True)
    assert not trig & _operations(query)
    index = {name: i for i, name in enumerate(settings.names(centred))}
    for function in (query, geometry):
        inputs = function.sx_in()
        out = ca.vertcat(*(ca.vec(o) for o in function.call(inputs)))
        for part in ("cx", "cy"):
            assert not ca.depends_on(out, inputs[-1][index[f"footprint.0.{part}"]])
    offset = dataclasses.replace(centred, robot=RobotConfig(footprint=((0.1, 0.0, 0.3),)))
    query, _ = pose_functions(offset, SIZES, None, True)
    assert trig <= _operations(query)
