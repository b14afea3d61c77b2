"""The control law and rollout: closed forms, limits, and numpy == CasADi."""

import dataclasses
import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dsmpepc_nlp.core.config import PlannerConfig, RobotConfig, RobotState
from dsmpepc_nlp.core.control_law import rollout, rollout_function, target_pose, z_from_target
from dsmpepc_nlp.core.cost_config import SmoothingConfig

CFG = PlannerConfig()
NO_RATE_LIMITS = dataclasses.replace(
    CFG, robot=RobotConfig(accel_limit=math.inf, alpha_limit=math.inf))

finite = st.floats(-50, 50, allow_nan=False)
unit = st.floats(0.0, 1.0)


def z_in_box(u):
    lower, upper = np.array(CFG.z_lower), np.array(CFG.z_upper)
    return lower + np.asarray(u) * (upper - lower)


states = st.builds(RobotState, finite, finite, st.floats(-4, 4), st.floats(0, 1),
                   st.floats(-1.5, 1.5))


@given(u=st.tuples(unit, unit, unit, unit), state=states,
       smooth=st.sampled_from([SmoothingConfig.exact(), CFG.smoothing]))
def test_casadi_rollout_matches_numpy(u, state, smooth):
    z = z_in_box(u)
    expected = rollout(z, state, CFG, smooth)
    f = rollout_function(CFG, smooth)
    poses, v, omega, target = f(z, state.as_array())
    np.testing.assert_allclose(np.array(poses), expected.poses, atol=1e-9, rtol=0)
    np.testing.assert_allclose(np.array(v).ravel(), expected.v, atol=1e-9, rtol=0)
    np.testing.assert_allclose(np.array(omega).ravel(), expected.omega, atol=1e-9, rtol=0)
    np.testing.assert_allclose(np.array(target).ravel(), expected.target, atol=1e-9, rtol=0)


def test_straight_line_at_full_speed_matches_closed_form():
    # theta = delta = 0: the target is dead ahead, kappa = 0; far target: v = v_max throughout.
    z = np.array([8.0, 0.0, 0.0, 0.2])
    traj = rollout(z, RobotState(1.0, 2.0, 0.5), NO_RATE_LIMITS)
    s = 0.2 * CFG.horizon.dt * np.arange(CFG.horizon.n_steps + 1)
    np.testing.assert_allclose(traj.poses[:, 0], 1.0 + s * math.cos(0.5), atol=1e-12)
    np.testing.assert_allclose(traj.poses[:, 1], 2.0 + s * math.sin(0.5), atol=1e-12)
    np.testing.assert_allclose(traj.poses[:, 2], 0.5, atol=1e-12)
    np.testing.assert_allclose(traj.omega, 0.0, atol=1e-12)


def test_straight_line_inside_slowdown_radius_is_geometric():
    # rho < r_thresh: v = v_max rho / r_thresh, so rho_k = r (1 - v_max dt / r_thresh)^k.
    r, v_max = 1.0, 0.6
    traj = rollout(np.array([r, 0.0, 0.0, v_max]), RobotState(0.0, 0.0, 0.0), NO_RATE_LIMITS)
    k = np.arange(CFG.horizon.n_steps + 1)
    rho = r * (1.0 - v_max * CFG.horizon.dt / NO_RATE_LIMITS.control_law.r_thresh) ** k
    np.testing.assert_allclose(traj.poses[:, 0], r - rho, atol=1e-12)


def test_target_pose_round_trips_through_z_from_target():
    rng = np.random.default_rng(3)
    z = z_in_box(rng.random((50, 4)))
    pose = (0.4, -1.0, 2.0)
    target = target_pose(z.T, pose)
    back = np.array(z_from_target(target, z[:, 3], pose)).T
    np.testing.assert_allclose(back, z, atol=1e-9)


def test_limits_hold_and_rate_limits_start_from_measured_velocity():
    rng = np.random.default_rng(0)
    z = z_in_box(rng.random((500, 4)))
    state = RobotState(0.0, 0.0, 0.0, v=0.8, omega=-1.0)
    traj = rollout(z, state, CFG)
    robot, dt = CFG.robot, CFG.horizon.dt
    assert np.all(traj.v >= -1e-12) and np.all(traj.v <= robot.v_limit + 1e-12)
    assert np.all(np.abs(traj.omega) <= robot.omega_limit + 1e-12)
    dv = np.diff(np.concatenate([np.full((500, 1), 0.8), traj.v], axis=1), axis=1)
    dw = np.diff(np.concatenate([np.full((500, 1), -1.0), traj.omega], axis=1), axis=1)
    assert np.all(np.abs(dv) <= robot.accel_limit * dt + 1e-9)
    assert np.all(np.abs(dw) <= robot.alpha_limit * dt + 1e-9)


def test_edge_cases_are_finite():
    lower, upper = np.array(CFG.z_lower), np.array(CFG.z_upper)
    corners = np.array([[lo if bit == 0 else hi for bit, lo, hi in zip(bits, lower, upper)]
                        for bits in itertools.product((0, 1), repeat=4)])
    extra = np.array([[CFG.bounds.r_min, 0.0, 0.0, 1.0],   # rho -> 0 at once
                      [1e-9, 0.3, -0.2, 1.0],              # below the floor: still finite
                      [3.0, 0.5, 0.5, 0.0]])               # v_max = 0: the stop trajectory
    traj = rollout(np.vstack([corners, extra]), RobotState(0.0, 0.0, 0.0, 1.0, 1.5), CFG)
    assert np.all(np.isfinite(traj.poses)) and np.all(np.isfinite(traj.omega))
    stopped = rollout(np.array([3.0, 0.5, 0.5, 0.0]), RobotState(0.0, 0.0, 0.0), CFG)
    assert np.all(stopped.v == 0.0) and np.all(stopped.poses == 0.0)


def test_bad_z_raises():
    with pytest.raises(ValueError, match="z"):
        rollout(np.zeros(3), RobotState(0.0, 0.0, 0.0), CFG)
    with pytest.raises(ValueError, match="finite"):
        rollout(np.array([1.0, 0.0, np.nan, 1.0]), RobotState(0.0, 0.0, 0.0), CFG)


PAPER_LAW = PlannerConfig.paper()


@pytest.mark.parametrize("factor", [1.0, 0.1, 0.01])
@pytest.mark.parametrize("config, bound", [(PAPER_LAW, 0.01), (CFG, 0.02)],
                         ids=["ramp-1.2m", "ramp-from-robot"])
def test_smooth_rollout_converges_to_exact(factor, config, bound):
    """The bound shrinks with the temperature (about linearly). The product's ramp
    (v_limit^2 / accel_limit = 0.67 m) is steeper than IROS 2012's 1.2 m, and the smooth speed
    cap's largest deviation at the default temperatures about doubles with it (1.3 cm
    against 0.6 cm, measured): each ramp has its own bound."""
    rng = np.random.default_rng(1)
    z = z_in_box(rng.random((300, 4)))
    state = RobotState(0.0, 0.0, 0.0, 0.5, 0.2)
    exact = rollout(z, state, config)
    smooth = rollout(z, state, config, config.smoothing.scaled(factor))
    assert np.abs(smooth.poses - exact.poses).max() < bound * factor + 1e-9
