"""Constant-velocity baseline: drive at the goal, slow down when a straight-line prediction of
the people says contact.

What a user might pick instead of an MPEPC planner in a crowd, and the simplest thing that
uses predictions at all. Every cycle the robot considers driving toward the goal at each of
``SPEED_FRACTIONS`` of its speed limit (steering at the goal with the same heading law as the
ORCA baseline, slowing linearly within ``SLOW_RADIUS`` of it), rolls each out over
``HORIZON`` seconds under its acceleration and turn-rate limits, and predicts every moving
body (people, other robots) at its current velocity. It takes the fastest speed whose rollout
keeps at least ``MARGIN`` from every predicted body over the horizon; when none does, the one
whose first predicted contact comes latest (the slower on a tie), so it brakes when contact
cannot be avoided. It ignores the map: it is a baseline for the crowd benchmarks, which have
none. ``HORIZON``, ``MARGIN`` and the speed grid are our choices.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.control_law import arc_step
from ..core.geometry import footprint_points
from ..core.solver_config import SolverConfig
from ..core.terms import TERM_NAMES
from .orca import GAIN_TURN, SLOW_RADIUS, OrcaPlan, _Costs, _Trajectory

CROWD_BASELINES = ("orca", "cv")
"""The baselines the crowd benchmarks run beside the planner variants (``cv``: this one)."""
SPEED_FRACTIONS = (1.0, 0.75, 0.5, 0.25, 0.0)
"""Candidate speeds toward the goal, as fractions of ``v_limit`` (our choice)."""
HORIZON = 3.0
"""How far ahead the people are predicted and the rollouts checked, s (our choice)."""
MARGIN = 0.1
"""Smallest predicted gap counted as clear, m (as the ORCA baseline's safety margin)."""


class ConstantVelocityPlanner:
    """``plan(state, world, goal)`` like :class:`~dsmpepc_nlp.solve.planner.Planner` (module
    docstring); ``solver`` is accepted for the same signature and unused."""

    def __init__(self, config: PlannerConfig | None = None, solver: SolverConfig | None = None):
        self.config = PlannerConfig() if config is None else config

    def reset(self) -> None:
        """Nothing to forget (no state between cycles)."""

    def rollouts(self, state: RobotState, goal) -> tuple:
        """Poses ``(K, n + 1, 3)``, ``v`` and ``omega`` ``(K, n)`` of the ``K`` candidate
        speeds over the method's horizon (``n`` steps), steering at ``goal`` under the robot's
        limits from its measured state."""
        robot, dt, n = self.config.robot, self.config.horizon.dt, self.config.horizon.n_steps
        k = len(SPEED_FRACTIONS)
        poses = np.empty((k, n + 1, 3))
        poses[:, 0] = state.pose
        v_prev = np.full(k, min(max(state.v, 0.0), robot.v_limit))
        w_prev = np.full(k, min(max(state.omega, -robot.omega_limit), robot.omega_limit))
        vs, ws = np.empty((k, n)), np.empty((k, n))
        cap = robot.v_limit * np.asarray(SPEED_FRACTIONS)
        gx, gy = float(goal[0]), float(goal[1])
        for i in range(n):
            x, y, phi = poses[:, i, 0], poses[:, i, 1], poses[:, i, 2]
            error = np.remainder(np.arctan2(gy - y, gx - x) - phi + math.pi, math.tau) - math.pi
            slow = np.minimum(1.0, np.hypot(gx - x, gy - y) / SLOW_RADIUS)
            v_want = np.minimum(cap, robot.v_limit * slow) * np.maximum(np.cos(error), 0.0)
            v = np.clip(v_want, v_prev - robot.accel_limit * dt, v_prev + robot.accel_limit * dt)
            v = np.clip(v, 0.0, robot.v_limit)
            w = np.clip(GAIN_TURN * error, w_prev - robot.alpha_limit * dt,
                        w_prev + robot.alpha_limit * dt)
            w = np.clip(w, -robot.omega_limit, robot.omega_limit)
            poses[:, i + 1] = np.stack(arc_step((x, y, phi), v, w, dt), axis=-1)
            vs[:, i], ws[:, i], v_prev, w_prev = v, w, v, w
        return poses, vs, ws

    def first_contact(self, poses, world) -> np.ndarray:
        """Per rollout, the first predicted time (s) within ``HORIZON`` with a gap below
        ``MARGIN``; inf if none."""
        dt = self.config.horizon.dt
        poses = poses[:, :max(2, int(round(HORIZON / dt)) + 1)]
        centers, radii, velocities, _ = world.stacked_obstacles()
        if len(radii) == 0:
            return np.full(len(poses), math.inf)
        fp = np.asarray(self.config.robot.footprint, dtype=float)
        points = footprint_points(poses, fp[:, :2])                         # (K, T, C, 2)
        t = np.arange(poses.shape[1]) * dt
        bodies = centers[None] + t[:, None, None] * velocities[None]        # (T, M, 2)
        d = np.linalg.norm(points[:, :, :, None, :] - bodies[None, :, None], axis=-1)
        gaps = (d - fp[:, 2][None, None, :, None] - radii[None, None, None, :]).min(axis=(2, 3))
        hit = gaps < MARGIN                                                 # (K, T)
        return np.where(hit.any(axis=1), t[np.argmax(hit, axis=1)], math.inf)

    def plan(self, state: RobotState, world, goal, *, dock: bool = True,
             sample: bool = False, goal_tolerance: float = 0.0) -> OrcaPlan:
        """One cycle: the chosen rollout's first command; ``dock``, ``sample`` and
        ``goal_tolerance`` unused."""
        started = time.perf_counter()
        poses, vs, ws = self.rollouts(state, goal)
        contact = self.first_contact(poses, world)
        clear = np.flatnonzero(np.isinf(contact))
        # SPEED_FRACTIONS run from fast to slow: the first clear one is the fastest; otherwise
        # the latest contact, the slower candidate on a tie (argmax of the reversed order)
        best = int(clear[0]) if clear.size else len(contact) - 1 - int(np.argmax(contact[::-1]))
        v, omega = float(vs[best, 0]), float(ws[best, 0])
        nan = math.nan
        n = self.config.horizon.n_steps
        cost = _Costs({name: nan for name in TERM_NAMES}, np.full(n + 1, nan))
        trajectory = _Trajectory(poses[best], vs[best], ws[best],
                                 np.array([*np.asarray(goal, dtype=float), nan]))
        heading = (v * math.cos(state.phi), v * math.sin(state.phi))
        return OrcaPlan((v, omega), trajectory, cost, heading,
                        wall_time=time.perf_counter() - started, message="constant velocity")
