"""The exact cost: time to collision by hand, the paper's three lemmas, the breakdown."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.cost_config import SmoothingConfig
from dsmpepc_nlp.core.costs import assemble, collision_probability, disk_inverse_ttc, inverse_ttg
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.exact_cost import evaluate
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.terms import TERM_NAMES
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World
from dsmpepc_nlp.solve.planner import Planner

DS = PlannerConfig.ds_mpepc()
MP = PlannerConfig.mpepc()


EXACT = SmoothingConfig.exact()


def ttc(p, w, radius):
    inv = disk_inverse_ttc(p[0], p[1], w[0], w[1], radius, EXACT)
    return math.inf if inv == 0 else 1.0 / inv


# Relative position and velocity are "robot minus object".
def test_ttc_head_on():
    # Robot at 0 moving +x at 1 m/s, object at x = 5 moving -x at 1 m/s, radii sum 1: 5 - 2t = 1.
    assert ttc((-5.0, 0.0), (2.0, 0.0), 1.0) == pytest.approx(2.0)


def test_ttc_crossing():
    # Robot (t, 0); object (4, -4 + t): |(t - 4, 4 - t)| = sqrt(2) |4 - t| = 0.5.
    assert ttc((-4.0, 4.0), (1.0, -1.0), 0.5) == pytest.approx(4.0 - 0.5 / math.sqrt(2.0))


def test_ttc_parallel_receding_missing_and_overlapping():
    assert ttc((-3.0, 0.0), (0.0, 0.0), 1.0) == math.inf          # same velocity
    assert ttc((-3.0, 0.0), (-1.0, 0.0), 1.0) == math.inf         # moving apart
    assert ttc((-3.0, 2.0), (1.0, 0.0), 1.0) == math.inf          # passes 2 m off, R = 1
    assert ttc((-0.5, 0.0), (1.0, 0.0), 1.0) == 0.0               # already overlapping


def test_smooth_ttc_converges_away_from_grazing():
    cases = [((-5.0, 0.0), (2.0, 0.0), 1.0), ((-4.0, 4.0), (1.0, -1.0), 0.5),
             ((-3.0, 2.0), (1.0, 0.0), 1.0), ((-3.0, 0.0), (-1.0, 0.0), 1.0)]
    for p, w, radius in cases:
        exact = disk_inverse_ttc(*p, *w, radius)
        errors = [abs(disk_inverse_ttc(*p, *w, radius, SmoothingConfig(distance=t)) - exact)
                  for t in (0.1, 0.01, 0.001)]
        assert errors[-1] < 1e-3 and errors[0] >= errors[-1]


def test_inverse_ttg():
    # 3 m from the goal, moving at 1 m/s straight at it: TTG = 3 s.
    assert inverse_ttg((0.0, 0.0, 0.0), 1.0, (3.0, 0.0)) == pytest.approx(1.0 / 3.0)
    # Facing away or stopped: never.
    assert inverse_ttg((0.0, 0.0, math.pi), 1.0, (3.0, 0.0)) == 0.0
    assert inverse_ttg((0.0, 0.0, 0.0), 0.0, (3.0, 0.0)) == 0.0


distances = st.floats(-1.0, 2.0)
inverses = st.one_of(st.floats(0.0, 50.0), st.just(math.inf))


@given(d=distances, inv=inverses, sigma=st.floats(0.05, 1.0))
def test_lemma1_pc_bounds(d, inv, sigma):
    pc = collision_probability(np.array(d), np.array(inv), sigma, MP)
    pc_ds = collision_probability(np.array(d), np.array(inv), sigma, DS)
    assert (1.0 - DS.cost.a) * pc - 1e-15 <= pc_ds <= pc + 1e-15


def _assemble(config, distance, inv_ttc):
    n, steps, m = distance.shape
    zeros = np.zeros((n, steps - 1, 1))
    return assemble(distance, inv_ttc, np.full(m, 0.2), np.zeros((n, steps, 1)), zeros, zeros,
                    np.zeros((n, 1, 1)), np.zeros((n, 1, 1)), np.zeros((n, 1, 1)), config)


@given(seed=st.integers(0, 2**32 - 1))
def test_lemma1_ds_survivability_never_lower(seed):
    rng = np.random.default_rng(seed)
    distance = rng.uniform(-0.2, 1.0, (4, 26, 3))
    inv = np.where(rng.random((4, 26, 3)) < 0.2, np.inf, rng.exponential(2.0, (4, 26, 3)))
    *_, survival_mp = _assemble(MP, distance, inv)
    *_, survival_ds = _assemble(DS, distance, inv)
    assert np.all(survival_ds >= survival_mp - 1e-15)


@given(seed=st.integers(0, 2**32 - 1), step=st.integers(0, 25),
       config=st.sampled_from([MP, DS]))
def test_lemma2_collision_zeroes_survivability(seed, step, config):
    rng = np.random.default_rng(seed)
    distance = rng.uniform(0.05, 1.0, (2, 26, 2))
    inv = rng.exponential(1.0, (2, 26, 2))
    distance[:, step, 1] = -rng.uniform(0.0, 0.3)
    inv[:, step, 1] = np.inf      # overlapping: TTC = 0
    *_, survival = _assemble(config, distance, inv)
    assert np.all(survival[:, step:] == 0.0)


def _in_contact(where):
    occupied = np.zeros((40, 40), bool)
    obstacles = ()
    if where == "wall":
        occupied[:, 21:] = True       # the robot at x = 2.0 sits 0.1 m inside the wall
    else:
        obstacles = (DynamicObstacle.pedestrian((2.2, 2.0), (-0.3, 0.0), 0.3),)
    return World(OccupancyGrid.from_array(occupied, 0.1), obstacles)


@pytest.mark.parametrize("config", [MP, DS], ids=["mpepc", "ds-mpepc"])
@pytest.mark.parametrize("where", ["pedestrian", "wall"])
def test_lemma3_robot_in_collision_does_not_move(config, where):
    """The cost's lemma, for the planner with every behaviour on (the last resort included):
    a robot at rest in contact stays at rest, even with a person walking into it."""
    assert config.stall.doomed_below > 0.0
    planner = Planner(config, SolverConfig.sampling(n_samples=512))
    plan = planner.plan(RobotState(2.0, 2.0, 0.0), _in_contact(where), (0.5, 0.5), dock=False)
    assert plan.status == "start-in-collision" and "Lemma 3" in plan.message, plan.message
    assert plan.control == (0.0, 0.0)
    assert np.all(plan.trajectory.v == 0.0) and np.all(plan.trajectory.omega == 0.0)
    assert np.all(plan.trajectory.poses == plan.trajectory.poses[0])


def _open_world():
    occupied = np.zeros((60, 60), bool)
    occupied[25:35, 30:34] = True
    return World(OccupancyGrid.from_array(occupied, 0.1, (-3.0, -3.0)),
                 (DynamicObstacle.pedestrian((2.0, 0.8), (-0.5, 0.0), 0.3),
                  DynamicObstacle.robot((1.0, -1.5, 1.0), (0.0, 0.3),
                                        ((-0.2, 0.0, 0.2), (0.2, 0.0, 0.2)))))


def test_breakdown_sums_to_total_and_batch_equals_single():
    rng = np.random.default_rng(2)
    lower, upper = np.array(DS.z_lower), np.array(DS.z_upper)
    z = lower + rng.random((64, 4)) * (upper - lower)
    traj = rollout(z, RobotState(-2.0, 0.0, 0.0, 0.3, 0.0), DS)
    costs = evaluate(traj, _open_world(), (2.5, 0.0), DS)
    assert set(costs.terms) == set(TERM_NAMES)
    np.testing.assert_allclose(sum(costs.terms.values()), costs.total, atol=1e-12)
    assert np.all(np.isfinite(costs.total))
    single = evaluate(traj[5], _open_world(), (2.5, 0.0), DS)
    assert single.total == pytest.approx(costs.total[5], abs=1e-12)
    assert costs.survivability.shape == (64, DS.horizon.n_steps + 1)


def test_free_space_progress_is_the_distance_gained():
    world = World()
    traj = rollout(np.array([3.0, 0.0, 0.0, 0.8]), RobotState(0.0, 0.0, 0.0), MP)
    costs = evaluate(traj, world, (10.0, 0.0), MP)
    gained = traj.poses[-1, 0] - traj.poses[0, 0]
    assert costs.terms["progress"] == pytest.approx(-gained, abs=1e-9)
    assert costs.survivability[-1] == 1.0
    assert costs.terms["terminal"] == 0.0 and costs.terms["heading"] == pytest.approx(0.0)


def test_mpepc_and_ds_differ_only_in_the_marked_terms():
    traj = rollout(np.array([2.0, 0.3, -0.4, 0.7]), RobotState(-2.0, 0.0, 0.0), DS)
    world = _open_world()
    ds = evaluate(traj, world, (2.5, 0.0), DS)
    mp = evaluate(traj, world, (2.5, 0.0), MP)
    pc_only = evaluate(traj, world, (2.5, 0.0), PlannerConfig.variant("pc-only"))
    assert mp.terms["terminal"] == 0.0
    assert pc_only.total == pytest.approx(ds.total - ds.terms["terminal"])
    assert np.all(ds.survivability >= mp.survivability - 1e-15)
    assert -1.0 <= ds.terms["terminal"] <= 0.0


def test_terminal_cost_rewards_stopping_facing_free_space():
    # The hazard docs/method.md section 5.4 names: a stop trajectory facing free space earns
    # about -1.
    stop = rollout(np.array([2.0, 0.0, 0.0, 0.0]), RobotState(0.0, 0.0, 0.0), DS)
    costs = evaluate(stop, World(), (5.0, 0.0), DS)
    assert costs.terms["terminal"] == pytest.approx(-1.0)
    occupied = np.zeros((40, 40), bool)
    occupied[:, 26:] = True       # cells from x = 1.1 m: a wall 0.8 m ahead of the 0.3 m robot
    walled = evaluate(stop, World(OccupancyGrid.from_array(occupied, 0.1, (-1.5, -2.0))),
                      (5.0, 0.0), DS)
    # Clear of the wall (survivability 1), so only C_TTC can lift the reward: at v_limit the
    # terminal TTC is 0.8 s, and C_TTC = exp(-(1/0.8)^2 / s_ttc^2).
    assert walled.min_distance == pytest.approx(0.8)
    assert walled.survivability[-1] == pytest.approx(1.0)
    assert walled.ttc_terminal == pytest.approx(0.8 / DS.robot.v_limit)
    expected = -np.exp(-(DS.robot.v_limit / 0.8) ** 2 / DS.cost.s_ttc ** 2)
    assert walled.terms["terminal"] == pytest.approx(expected)
    assert walled.terms["terminal"] > -0.01


def test_a_growing_bell_widens_with_the_look_ahead_and_is_off_by_default():
    """``sigma_dynamic_growth``: the moving objects' bell at a pose t seconds ahead is
    ``sigma_dynamic + growth * t`` wide; off (0) in the product and the paper preset, where the
    width is ``sigma_dynamic`` to the bit at every pose."""

    from dsmpepc_nlp.core.costs import dynamic_sigma

    times = np.arange(26) * 0.2
    for config in (PlannerConfig(), PlannerConfig.paper()):
        assert config.cost.sigma_dynamic_growth == 0.0
        assert np.all(dynamic_sigma(times, config.cost) == config.cost.sigma_dynamic)
    grown = dataclasses.replace(DS, cost=dataclasses.replace(DS.cost, sigma_dynamic_growth=0.16))
    np.testing.assert_allclose(dynamic_sigma(times, grown.cost), 0.2 + 0.16 * times)
    # A pedestrian standing 1 m beside a stopped robot: the same at the start, a higher
    # collision probability (a lower survivability) the further ahead.
    stop = rollout(np.array([2.0, 0.0, 0.0, 0.0]), RobotState(0.0, 0.0, 0.0), DS)
    world = World(obstacles=[DynamicObstacle.pedestrian((0.0, 1.6), (0.0, 0.0))])
    flat, wide = (evaluate(stop, world, (5.0, 0.0), c).survivability for c in (DS, grown))
    assert flat[0] == wide[0]
    assert np.all(wide[1:] < flat[1:])
    with pytest.raises(InputError, match="sigma_dynamic_growth"):
        dataclasses.replace(DS.cost, sigma_dynamic_growth=-0.1)
