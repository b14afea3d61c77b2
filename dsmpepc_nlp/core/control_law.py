"""The smooth pose-following control law and the horizon rollout, once for numpy and CasADi."""

from __future__ import annotations

from dataclasses import dataclass, fields

import casadi as ca
import numpy as np

from .config import PlannerConfig, RobotState
from .cost_config import SmoothingConfig
from .errors import InputError
from .smooth import CASADI, NUMPY, sabs, smax, smin, smin_positive

EXACT = SmoothingConfig.exact()

_RHO_GUARD = 1e-9
"""Added in quadrature to the distance to the target, m: keeps 1/rho and its derivative finite."""
_SINC_SERIES = 1e-4
"""Below this |u| the arc integration uses the series of sinc(u)."""
_KAPPA_FLOOR = 1e-12
"""Smallest |kappa| used to divide omega_limit, 1/m."""


def wrap(angle, ops=NUMPY):
    """Angle wrapped to (-pi, pi], rad."""
    return ops.atan2(ops.sin(angle), ops.cos(angle))


def target_pose(z, pose, ops=NUMPY):
    """Target pose T of ``z = (r, theta, delta, v_max)`` seen from ``pose = (x, y, phi)``.

    ``los0 = phi - delta``, ``T = p + r (cos los0, sin los0)``, ``phi_T = los0 + theta``
    (docs/method.md section 1.2). Each argument is a sequence of scalars or arrays of one shape.
    """
    r, theta, delta = z[0], z[1], z[2]
    los = pose[2] - delta
    return (pose[0] + r * ops.cos(los), pose[1] + r * ops.sin(los), los + theta)


def z_from_target(target, v_max, pose, ops=NUMPY):
    """Inverse of :func:`target_pose`: the ``z`` whose target, seen from ``pose``, is ``target``.

    This is MPEPC's warm start: last cycle's target re-expressed in the robot's new frame.
    """
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    r = ops.sqrt(dx * dx + dy * dy)
    los = ops.atan2(dy, dx)
    return (r, wrap(target[2] - los, ops), wrap(pose[2] - los, ops), v_max)


def law_command(pose, target, v_max, config: PlannerConfig, smoothing=EXACT, ops=NUMPY):
    """Speed and turn rate the law asks for at ``pose`` toward ``target``, omega limit applied.

    Returns ``(v, omega)``: m/s, rad/s. Rate limits are applied by :func:`step`.
    """
    law, robot = config.control_law, config.robot
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    rho = ops.sqrt(dx * dx + dy * dy + _RHO_GUARD**2)
    los = ops.atan2(dy, dx)
    th = wrap(target[2] - los, ops)
    de = wrap(pose[2] - los, ops)
    # Park and Kuipers (2011), eq. for kappa; theta and delta measured from the line of sight.
    k1th = law.k1 * th
    kappa = -(
        law.k2 * (de - ops.atan(-k1th)) + (1.0 + law.k1 / (1.0 + k1th * k1th)) * ops.sin(de)
    ) / rho
    abs_kappa = sabs(kappa, smoothing.curvature, ops)
    # lam = 2 squares kappa (no |kappa|); a symbolic lam (a graph parameter) is never 2 here.
    squared = isinstance(law.lam, (int, float)) and law.lam == 2.0
    slowdown = kappa * kappa if squared else abs_kappa**law.lam
    v = smin_positive(v_max / (1.0 + law.beta * slowdown), v_max * rho / law.r_thresh,
                      smoothing.speed, ops)
    # The omega limit scales v down and keeps the curvature.
    v_cap = robot.omega_limit / ops.fmax(abs_kappa, _KAPPA_FLOOR)
    v = smin_positive(v, v_cap, smoothing.speed, ops)
    return v, kappa * v


def rate_limit(value, previous, limit, dt, temperature, ops=NUMPY):
    """``value`` within ``limit * dt`` of ``previous`` (smoothed at ``temperature``; 0: exact).
    The law's rollout and the stall ladder's back-up rung both limit their commands by it."""
    if isinstance(limit, (int, float)) and limit == float("inf"):   # no limit (symbolic: a limit)
        return value
    low, high = previous - limit * dt, previous + limit * dt
    return smin(smax(value, low, temperature, ops), high, temperature, ops)


def sinc(u, ops=NUMPY):
    """``sin(u)/u`` with ``sinc(0) = 1``, safe for automatic differentiation."""
    small = ops.fabs(u) < _SINC_SERIES
    u_safe = ops.where(small, 1.0, u)
    return ops.where(small, 1.0 - u * u / 6.0, ops.sin(u_safe) / u_safe)


def arc_step(pose, v, omega, dt, ops=NUMPY):
    """Pose after holding ``(v, omega)`` for ``dt`` seconds, integrated exactly along the arc."""
    half = omega * dt / 2.0
    chord = v * dt * sinc(half, ops)
    heading = pose[2] + half
    return (pose[0] + chord * ops.cos(heading), pose[1] + chord * ops.sin(heading),
            pose[2] + omega * dt)


def step(carry, target, v_max, config: PlannerConfig, smoothing=EXACT, ops=NUMPY):
    """One horizon step: law, rate limits from the previous command, exact arc.

    ``carry = (x, y, phi, v_prev, omega_prev)``. Returns ``(carry_next, v, omega)``.
    """
    robot, dt = config.robot, config.horizon.dt
    v, omega = law_command(carry[:3], target, v_max, config, smoothing, ops)
    v = rate_limit(v, carry[3], robot.accel_limit, dt, smoothing.acceleration, ops)
    omega = rate_limit(omega, carry[4], robot.alpha_limit, dt, smoothing.rate, ops)
    x, y, phi = arc_step(carry[:3], v, omega, dt, ops)
    return (x, y, phi, v, omega), v, omega


def clamp_measured(state: RobotState, config: PlannerConfig):
    """Measured ``(v, omega)`` clipped to the robot's limits, the start of the rate limits."""
    robot = config.robot
    return (min(max(state.v, 0.0), robot.v_limit),
            min(max(state.omega, -robot.omega_limit), robot.omega_limit))


@dataclass(frozen=True)
class Trajectory:
    """A rollout of the control law.

    Attributes
    ----------
    z : ndarray, (4,) or (n, 4)
        The trajectory parameters ``(r, theta, delta, v_max)``.
    poses : ndarray, (N+1, 3) or (n, N+1, 3)
        ``(x, y, phi)`` at each step; ``poses[..., 0, :]`` is the start pose. m, rad.
    v, omega : ndarray, (N,) or (n, N)
        Speed (m/s) and turn rate (rad/s) held over each step.
    target : ndarray, (3,) or (n, 3)
        The target pose T in the world, m and rad.
    """

    z: np.ndarray
    poses: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    target: np.ndarray

    def __len__(self):
        return 1 if self.z.ndim == 1 else self.z.shape[0]

    def __getitem__(self, index) -> Trajectory:
        """The trajectories at ``index`` of a batch."""
        return Trajectory(self.z[index], self.poses[index], self.v[index], self.omega[index],
                          self.target[index])


def stacked(trajectories) -> Trajectory:
    """One batch of ``trajectories`` (each a batch or a single trajectory), in order."""
    rows = [t if t.z.ndim == 2 else Trajectory(*(getattr(t, f.name)[None]
                                                for f in fields(Trajectory)))
            for t in trajectories]
    return Trajectory(*(np.concatenate([getattr(t, f.name) for t in rows])
                        for f in fields(Trajectory)))


def rollout(z, state: RobotState, config: PlannerConfig, smoothing=EXACT) -> Trajectory:
    """Roll the control law out over the horizon for one or many ``z``.

    Parameters
    ----------
    z : array_like, (4,) or (n, 4)
        ``(r [m], theta [rad], delta [rad], v_max [m/s])``; each within the config's bounds.
    state : RobotState
        Start pose and measured velocity (the rate limits start from it).
    config : PlannerConfig
    smoothing : SmoothingConfig, optional
        Temperatures of the stand-ins; exact by default.

    Returns
    -------
    Trajectory
        With a leading batch axis exactly when ``z`` is 2-D.
    """
    z = np.asarray(z, dtype=float)
    if z.shape[-1:] != (4,) or z.ndim not in (1, 2):
        raise InputError(f"z has shape {z.shape}: must be (4,) or (n, 4)")
    if not np.all(np.isfinite(z)):
        raise InputError("z contains NaN or inf: must be finite")
    batch = np.atleast_2d(z)
    ones = np.ones(batch.shape[0])
    v0, omega0 = clamp_measured(state, config)
    carry = (state.x * ones, state.y * ones, state.phi * ones, v0 * ones, omega0 * ones)
    result = rollout_from(batch, carry, config, smoothing)
    return result[0] if z.ndim == 1 else result


def rollout_from(batch, carry, config: PlannerConfig, smoothing=EXACT,
                 n_steps: int | None = None) -> Trajectory:
    """:func:`rollout` of ``batch`` (n, 4), each row from its own start ``carry = (x, y, phi,
    v_prev, omega_prev)``, arrays (n,) with the previous command already within the limits,
    over ``n_steps`` (default the horizon's): a batch."""
    n = batch.shape[0]
    n_steps = config.horizon.n_steps if n_steps is None else n_steps
    target = target_pose(batch.T, carry[:3])
    v_max = batch[:, 3]
    poses = np.empty((n, n_steps + 1, 3))
    poses[:, 0] = np.stack(carry[:3], axis=-1)
    v = np.empty((n, n_steps))
    omega = np.empty((n, n_steps))
    for j in range(n_steps):
        carry, v[:, j], omega[:, j] = step(carry, target, v_max, config, smoothing)
        poses[:, j + 1] = np.stack(carry[:3], axis=-1)
    return Trajectory(batch, poses, v, omega, np.stack(target, axis=-1))


def commanded(state, config: PlannerConfig, commands) -> Trajectory:
    """The trajectories of command sequences ``commands`` (m, n, 2) of ``(v, omega)``, each
    step rate-limited from the last along the exact arc, from ``clamp_measured(state)``."""
    robot, dt = config.robot, config.horizon.dt
    m, n = commands.shape[:2]
    poses = np.empty((m, n + 1, 3))
    v, omega = np.empty((m, n)), np.empty((m, n))
    start = clamp_measured(state, config)     # where the law's rollouts start too
    v_prev = np.full(m, float(start[0]))
    omega_prev = np.full(m, float(start[1]))
    poses[:, 0] = np.asarray(state.pose, dtype=float)
    for k in range(n):
        v_prev = np.asarray(rate_limit(commands[:, k, 0], v_prev, robot.accel_limit, dt, 0.0))
        omega_prev = np.asarray(rate_limit(commands[:, k, 1], omega_prev, robot.alpha_limit, dt,
                                           0.0))
        poses[:, k + 1] = np.stack(arc_step(poses[:, k].T, v_prev, omega_prev, dt), axis=-1)
        v[:, k], omega[:, k] = v_prev, omega_prev
    stop = np.array([config.bounds.r_min, 0.0, 0.0, 0.0])
    return Trajectory(np.tile(stop, (m, 1)), poses, v, omega, poses[:, -1].copy())


def symbolic_rollout(z, state, config: PlannerConfig, smoothing=None):
    """Rollout on CasADi symbols (SX or MX): ``z`` (4x1), ``state`` (5x1: x, y, phi, v, omega).

    Returns ``(poses, v, omega, target)`` as ``3x(N+1)``, ``Nx1``, ``Nx1``, ``3x1`` expressions:
    :func:`step` N times, the one loop the NLP's graph and :func:`rollout_function` share. The
    measured velocity is expected already clamped (see :func:`clamp_measured`); a negative
    ``v_max`` counts as 0 (an SQP iterate may leave the box by the QP's tolerance, seen:
    -2.8e-3, and the smooth speed cap of a negative ``v_max`` is NaN).
    """
    smoothing = config.smoothing if smoothing is None else smoothing
    target = ca.vertcat(*target_pose([z[0], z[1], z[2]], [state[0], state[1], state[2]], CASADI))
    v_max = ca.fmax(z[3], 0.0)
    carry, poses, vs, omegas = state, [state[:3]], [], []
    for _ in range(config.horizon.n_steps):
        carry, v, omega = step(ca.vertsplit(carry), ca.vertsplit(target), v_max, config,
                               smoothing, CASADI)
        carry = ca.vertcat(*carry)
        poses.append(carry[:3])
        vs.append(v)
        omegas.append(omega)
    return ca.horzcat(*poses), ca.vertcat(*vs), ca.vertcat(*omegas), target


def rollout_function(config: PlannerConfig, smoothing=None) -> ca.Function:
    """The rollout as a CasADi ``Function`` named ``rollout``.

    Inputs ``z`` (4), ``state`` (5: x, y, phi, v, omega; measured velocity already within the
    limits); outputs ``poses`` ((N+1) x 3), ``v`` (N), ``omega`` (N), ``target`` (3).
    ``smoothing`` defaults to ``config.smoothing``; pass ``SmoothingConfig.exact()`` for the
    exact law.
    """
    z = ca.SX.sym("z", 4)
    state = ca.SX.sym("state", 5)
    poses, v, omega, target = symbolic_rollout(z, state, config, smoothing)
    return ca.Function("rollout", [z, state], [poses.T, v, omega, target],
                       ["z", "state"], ["poses", "v", "omega", "target"])
