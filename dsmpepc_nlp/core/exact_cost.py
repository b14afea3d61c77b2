"""The exact cost of trajectories (docs/method.md sec. 3-5): their geometry measured exactly
from the world (signed distance field, ray marching, disk closed forms), assembled by
:func:`.costs.assemble`, the formula the smooth graph uses too. This is the reference the compiled
kernel (``solve/exact/kernel``) is held to.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import PlannerConfig
from .control_law import Trajectory
from .costs import (
    GOAL_TOLERANCE,
    assemble,
    disk_inverse_ttc,
    dynamic_sigma,
    heading_error,
    inverse_ttg,
)
from .errors import InputError
from .geometry import footprint_points

_SIGNIFICANT_BELL = 6.0
"""Beyond this many sigmas exp(-d^2/sigma^2) < 3e-16: TTC is not needed there."""


@dataclass(frozen=True)
class Geometry:
    """Exact geometry of a batch of trajectories (see :func:`assemble` for the shapes)."""

    distance: np.ndarray
    inv_ttc: np.ndarray
    sigma: np.ndarray
    nf: np.ndarray
    heading_error: np.ndarray
    inv_ttg: np.ndarray
    inv_ttc_terminal: np.ndarray


@dataclass(frozen=True)
class CostBreakdown:
    """Exact cost of ``n`` trajectories.

    Attributes
    ----------
    total : ndarray, (n,)
    terms : dict of str to ndarray (n,)
        ``progress``, ``action``, ``collision``, ``heading``, ``terminal``.
    survivability : ndarray, (n, N+1)
        ``ps_k`` at each pose, start included.
    min_distance : ndarray, (n,)
        Smallest distance to any object over the horizon, m (inf with nothing around).
    ttg, ttc_terminal : ndarray, (n,)
        Expected time to goal and terminal time to collision, s (inf for never).
    """

    total: np.ndarray
    terms: dict
    survivability: np.ndarray
    min_distance: np.ndarray
    ttg: np.ndarray
    ttc_terminal: np.ndarray

    def __getitem__(self, index) -> CostBreakdown:
        return CostBreakdown(self.total[index], {k: t[index] for k, t in self.terms.items()},
                             self.survivability[index], self.min_distance[index],
                             self.ttg[index], self.ttc_terminal[index])


def _speeds_at_poses(traj_v):
    """Speed held from each pose k = 0..N: v[min(k, N-1)], shape (n, N+1)."""
    return np.concatenate([traj_v, traj_v[:, -1:]], axis=1)


def _inverse(speed, distance_along):
    """speed / distance with 0 for a miss (inf distance) and inf for contact (0 distance)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(distance_along <= 0.0, np.inf, speed / distance_along)
    return np.where(np.isinf(distance_along) | (speed <= 0.0) & (distance_along > 0.0), 0.0, inv)


def _static_geometry(poses, speeds, world, config, points):
    """Distance to the map and 1/TTC along the heading, (n, N+1) each."""
    radii = np.array([r for _, _, r in config.robot.footprint])
    distance = np.min(world.static_distance(points) - radii, axis=-1)
    inv_ttc = np.zeros_like(distance)
    if config.anticipatory_pc:
        near = distance < _SIGNIFICANT_BELL * config.cost.sigma_static
        if np.any(near):
            # along the direction of travel: backwards for a reversing pose (only the back-up
            # rung's trajectories reverse; the law's never do, and for them this is the heading)
            heading, speed = poses[near][:, 2], speeds[near]
            inv_ttc[near] = _static_inverse_ttc(points[near], np.where(speed < 0.0, heading
                                                                       + np.pi, heading),
                                                np.abs(speed), world, config)
    return distance, inv_ttc


def _static_inverse_ttc(points, headings, speeds, world, config):
    """1/TTC against the map for poses (P,) whose circles sit at points (P, C, 2)."""
    radii = np.array([r for _, _, r in config.robot.footprint])
    headings = np.broadcast_to(headings[:, None], points.shape[:-1])
    along = world.static_ray_distance(points, headings, radii, config.cost.ttc_range)
    return np.max(_inverse(speeds[:, None], along), axis=-1)


def circle_gaps(world, config, points, times):
    """Every footprint circle against every dynamic-obstacle circle, predicted at constant
    velocity: ``rel`` (n, N+1, C, K, 2), the footprint circle's centre less the obstacle
    circle's, m, and ``gap`` (n, N+1, C, K), their distance less both radii, m (below 0 where
    they overlap), for footprint centres ``points`` (n, N+1, C, 2) at ``times`` (N+1,)."""
    centers, radii, velocities, _ = world.stacked_obstacles()
    robot_radii = np.array([r for _, _, r in config.robot.footprint])
    predicted = centers[None, :, :] + velocities[None, :, :] * times[:, None, None]  # (N+1,K,2)
    rel = points[..., :, None, :] - predicted[None, :, None, :, :]           # (n,N+1,C,K,2)
    return rel, np.linalg.norm(rel, axis=-1) - robot_radii[:, None] - radii


def _dynamic_geometry(poses, speeds, world, config, points, times):
    """Distance and 1/TTC per dynamic obstacle, (n, N+1, M_dyn) each."""
    _, radii, velocities, owner = world.stacked_obstacles()
    robot_radii = np.array([r for _, _, r in config.robot.footprint])
    rel, gap = circle_gaps(world, config, points, times)                    # (n,N+1,C,K)
    starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
    distance = np.minimum.reduceat(gap.min(axis=-2), starts, axis=-1)
    inv_ttc = np.zeros_like(distance)
    if config.anticipatory_pc:
        heading = poses[..., 2]
        robot_velocity = np.stack([speeds * np.cos(heading), speeds * np.sin(heading)], -1)
        w = robot_velocity[..., None, None, :] - velocities                  # (n,N+1,1,K,2)
        radius = robot_radii[:, None] + radii
        inv = disk_inverse_ttc(rel[..., 0], rel[..., 1], w[..., 0], w[..., 1], radius)
        inv_ttc = np.maximum.reduceat(inv.max(axis=-2), starts, axis=-1)
    return distance, inv_ttc


def _terminal_inverse_ttc(pose, world, config, times_end):
    """1/TTC at the horizon's end moving along the terminal heading at v_limit, (n,)."""
    speed = np.full(pose.shape[0], config.robot.v_limit)
    points = footprint_points(pose, config.robot.footprint)                  # (n,C,2)
    inv = np.zeros(pose.shape[0])
    if world.grid is not None:
        inv = _static_inverse_ttc(points, pose[:, 2], speed, world, config)
    if world.obstacles:
        centers, radii, velocities, _ = world.stacked_obstacles()
        predicted = centers + velocities * times_end
        rel = points[:, :, None, :] - predicted                               # (n,C,K,2)
        robot_velocity = speed[:, None] * np.stack([np.cos(pose[:, 2]), np.sin(pose[:, 2])], -1)
        w = robot_velocity[:, None, None, :] - velocities
        robot_radii = np.array([r for _, _, r in config.robot.footprint])
        radius = robot_radii[:, None] + radii
        dyn = disk_inverse_ttc(rel[..., 0], rel[..., 1], w[..., 0], w[..., 1], radius)
        inv = np.maximum(inv, dyn.max(axis=(-1, -2)))
    return inv


def exact_geometry(trajectory: Trajectory, world, goal, config: PlannerConfig) -> Geometry:
    """Measure a batch of trajectories exactly in ``world`` (SDF, ray marching, closed forms)."""
    poses = trajectory.poses
    if poses.ndim == 2:
        raise InputError("exact_geometry takes a batch: index trajectories with [None]")
    config = config.for_map(world.grid.resolution if world.grid is not None else None)
    n, n_poses = poses.shape[:2]
    goal = np.asarray(goal, dtype=float)
    speeds = _speeds_at_poses(trajectory.v)
    points = footprint_points(poses, config.robot.footprint)                 # (n,N+1,C,2)
    times = np.arange(n_poses) * config.horizon.dt
    distances, inverses, sigmas = [], [], []
    if world.grid is not None:
        d, inv = _static_geometry(poses, speeds, world, config, points)
        distances.append(d[..., None])
        inverses.append(inv[..., None])
        sigmas.append(np.full((n_poses, 1), config.cost.sigma_static))
    if world.obstacles:
        d, inv = _dynamic_geometry(poses, speeds, world, config, points, times)
        distances.append(d)
        inverses.append(inv)
        sigmas.append(np.repeat(dynamic_sigma(times, config.cost)[:, None], d.shape[-1], 1))
    if distances:
        distance = np.concatenate(distances, axis=-1)
        inv_ttc = np.concatenate(inverses, axis=-1)
        sigma = np.concatenate(sigmas, axis=-1)
    else:
        distance = np.full((n, n_poses, 0), np.inf)
        inv_ttc = np.zeros((n, n_poses, 0))
        sigma = np.zeros((n_poses, 0))
    # The window is chosen around the first trajectory's start, as the planner's cycle does.
    nav = world.navigation(goal, config.robot.inflation_radius, near=poses[0, 0, :2],
                           reach=config.reach)
    nf = nav.value(poses[..., :2])[..., None]
    end = poses[:, -1]
    descent = -nav.gradient(end[:, :2])
    on_goal = np.hypot(end[:, 0] - goal[0], end[:, 1] - goal[1]) <= GOAL_TOLERANCE
    descent[on_goal] = 0.0
    err = heading_error(end[:, 2], descent[:, 0], descent[:, 1])
    inv_ttg = inverse_ttg((end[:, 0], end[:, 1], end[:, 2]), trajectory.v[:, -1], goal)
    inv_term = (_terminal_inverse_ttc(end, world, config, times[-1])
                if config.terminal_cost else np.zeros(n))
    def per_trajectory(values):
        return values.reshape(n, 1, 1)

    return Geometry(distance, inv_ttc, sigma, nf, per_trajectory(err), per_trajectory(inv_ttg),
                    per_trajectory(inv_term))


def evaluate(trajectory: Trajectory, world, goal, config: PlannerConfig) -> CostBreakdown:
    """Exact MPEPC / DS-MPEPC cost of one trajectory or a batch.

    Parameters
    ----------
    trajectory : Trajectory
        From :func:`~dsmpepc_nlp.core.control_law.rollout`, batched or single.
    world : World
        Static map and dynamic obstacles at the plan's start time.
    goal : array_like, (2,)
        Goal position, m.
    config : PlannerConfig

    Returns
    -------
    CostBreakdown
        Batched like ``trajectory``.
    """
    single = trajectory.poses.ndim == 2
    batch = trajectory
    if single:
        batch = Trajectory(trajectory.z[None], trajectory.poses[None], trajectory.v[None],
                           trajectory.omega[None], trajectory.target[None])
    geo = exact_geometry(batch, world, goal, config)
    total, terms, survival = assemble(
        geo.distance, geo.inv_ttc, geo.sigma, geo.nf, batch.v[..., None], batch.omega[..., None],
        geo.heading_error, geo.inv_ttg, geo.inv_ttc_terminal, config)
    def flat(values):
        return np.asarray(values, dtype=float).reshape(-1)

    nearest = (geo.distance.min(axis=(1, 2)) if geo.distance.shape[-1]
               else np.full(len(batch), np.inf))
    with np.errstate(divide="ignore"):
        result = CostBreakdown(
            flat(total), {k: flat(v) for k, v in terms.items()}, survival[..., 0], nearest,
            1.0 / flat(geo.inv_ttg), 1.0 / flat(geo.inv_ttc_terminal))
    return result[0] if single else result
