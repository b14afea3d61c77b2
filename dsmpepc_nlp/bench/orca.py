"""ORCA baseline (van den Berg et al. 2011, via ``pyrvo``) as a planner in the same closed loop.

The robot is one ORCA agent: a disk of the footprint's bounding radius with ``v_limit`` as its
largest speed, preferring the velocity toward the goal at ``v_limit`` (slowing linearly inside
``SLOW_RADIUS`` of it). Every dynamic-obstacle circle the robot sees (pedestrians, other robots)
is another ORCA agent with its current velocity; the map's occupied cells become ORCA polygon
obstacles (one rectangle per horizontal run of occupied cells). ORCA assumes every agent takes
half of the avoidance effort, which non-reacting pedestrians do not: that is the baseline as
usually run (CrowdNav's ORCA), not something we correct.

The robot's ORCA radius is the bounding radius plus ``SAFETY_MARGIN`` (0.1 m). The holonomic
velocity ``u`` that ORCA returns is turned into unicycle commands in the simplest
way: with the heading error ``e = wrap(angle(u) - phi)``, ``omega = clip(GAIN_TURN * e,
+-omega_limit)`` and ``v = |u| max(cos e, 0)`` (drive only the part of ``u`` along the heading;
turn in place when ``u`` points sideways or behind), then the robot's acceleration and turn-rate
change limits are applied from its measured ``(v, omega)``, exactly as for the MPEPC robots.

``pyrvo`` is an optional dependency: ``pip install "dsmpepc_nlp[orca]"``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.config import VARIANTS, PlannerConfig, RobotState
from ..core.control_law import arc_step
from ..core.errors import InputError, MissingExtra
from ..core.solver_config import SolverConfig
from ..core.terms import TERM_NAMES
from ..sim.simulate import simulate

INSTALL_HINT = 'the ORCA baseline needs pyrvo: pip install "dsmpepc_nlp[orca]"'

SLOW_RADIUS = 1.0
"""Within this distance of the goal the preferred speed falls linearly to zero, m (our choice)."""
GAIN_TURN = 2.0
"""Proportional gain from heading error to turn rate, 1/s (our choice)."""
NEIGHBOR_DIST = 10.0
"""ORCA neighbour search distance, m (RVO2 examples use 15 at 1-2 m/s; our choice)."""
SAFETY_MARGIN = 0.1
"""Added to the robot's ORCA radius, m: ORCA plans to graze at zero gap, which the unicycle's
lag and the pedestrians' non-reciprocity turn into contact (CrowdNav's ``safety_space``)."""
PARKED = 1.0e6
"""Where unused ORCA agent slots wait, m."""
MAX_NEIGHBORS = 20
"""ORCA neighbours considered."""
TIME_HORIZON = 3.0
"""ORCA time horizon against agents, s (our choice, CrowdNav's ORCA uses 5)."""
TIME_HORIZON_OBST = 1.5
"""ORCA time horizon against static obstacles, s (our choice)."""


def require_pyrvo():
    """The ``pyrvo`` module; ImportError with the install hint when it is missing."""
    try:
        import pyrvo
    except ImportError as exc:
        raise MissingExtra(INSTALL_HINT) from exc
    return pyrvo


def check_variants(variants, baselines=("orca",)) -> None:
    """Every name is one of ``baselines`` or a planner variant; pyrvo is importable when
    ``orca`` is asked."""
    for v in variants:
        if v not in baselines and v not in VARIANTS:
            raise InputError(f"--variants: {v!r}: must be one of "
                             f"{', '.join((*baselines, *VARIANTS))}")
    if "orca" in variants:
        require_pyrvo()


def grid_polygons(grid) -> list:
    """Counter-clockwise rectangles (lists of 4 (x, y)) covering the occupied cells of ``grid``.

    One rectangle per horizontal run of occupied cells that touches a free cell (runs buried in
    a block need no polygon: ORCA only sees the edges nearest the agent).
    """
    if grid is None:
        return []
    occ = np.asarray(grid.occupied, dtype=bool)
    padded = np.pad(occ, 1, constant_values=False)
    interior = (padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:])
    edge = occ & ~interior
    res = grid.resolution
    x0, y0 = (float(v) for v in grid.origin)
    polygons = []
    for iy in range(occ.shape[0]):
        row = edge[iy]
        if not row.any():
            continue
        change = np.flatnonzero(np.diff(np.concatenate([[0], row.astype(int), [0]])))
        for start, stop in zip(change[::2], change[1::2]):
            xa, xb = x0 + start * res, x0 + stop * res
            ya, yb = y0 + iy * res, y0 + (iy + 1) * res
            polygons.append([(xa, ya), (xb, ya), (xb, yb), (xa, yb)])
    return polygons


@dataclass(frozen=True)
class _Costs:
    """What the episode log reads from a plan's cost (no cost is computed for ORCA)."""

    terms: dict
    survivability: np.ndarray
    ttg: float = math.nan
    ttc_terminal: float = math.nan


@dataclass(frozen=True)
class _Trajectory:
    poses: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    target: np.ndarray


@dataclass(frozen=True)
class OrcaPlan:
    """The fields of :class:`~dsmpepc_nlp.solve.plan.Plan` that the closed loop and its log use.

    ``x`` and ``fun`` are NaN (ORCA has no z and no cost); ``trajectory`` holds the command of
    this cycle over the horizon; ``status`` is ``"sampling"`` (the log only knows the planner's
    statuses); ``velocity`` is ORCA's holonomic answer (m/s).
    """

    control: tuple
    trajectory: _Trajectory
    cost: _Costs
    velocity: tuple
    wall_time: float = 0.0
    x: np.ndarray = field(default_factory=lambda: np.full(4, math.nan))
    fun: float = math.nan
    status: str = "sampling"
    nit: int = 0
    starts: tuple = ()
    evaluated: object = None
    success: bool = True
    message: str = "ORCA"
    cut: tuple = ()


class OrcaPlanner:
    """ORCA with unicycle conversion; ``plan(state, world, goal)`` like :class:`Planner`."""

    def __init__(self, config: PlannerConfig | None = None, solver: SolverConfig | None = None,
                 safety_margin: float = SAFETY_MARGIN):
        self.pyrvo = require_pyrvo()
        self.safety_margin = float(safety_margin)
        self.config = PlannerConfig() if config is None else config
        self._grid = None
        self._sim = None
        self._n_agents = 0

    def reset(self) -> None:
        """Nothing to forget (ORCA keeps no state between cycles)."""

    def preferred_velocity(self, state: RobotState, goal) -> np.ndarray:
        """Toward the goal at ``v_limit``, slowing linearly within ``SLOW_RADIUS``, m/s."""
        offset = np.asarray(goal, dtype=float) - np.array([state.x, state.y])
        distance = float(np.hypot(*offset))
        if distance < 1e-9:
            return np.zeros(2)
        speed = self.config.robot.v_limit * min(1.0, distance / SLOW_RADIUS)
        return offset / distance * speed

    def holonomic_velocity(self, state: RobotState, world, goal) -> np.ndarray:
        """ORCA's new velocity for the robot (m/s), from a simulator built for this cycle."""
        robot = self.config.robot
        dt = self.config.horizon.dt
        if self._sim is None or world.grid is not self._grid:
            # The obstacle tree is built once per map (the slow part); agents are reused.
            self._sim = self.pyrvo.RVOSimulator()
            self._sim.set_time_step(dt)
            self._grid, self._n_agents = world.grid, 0
            polygons = grid_polygons(world.grid)
            for polygon in polygons:
                self._sim.add_obstacle(polygon)
            if polygons:
                self._sim.process_obstacles()
        sim = self._sim
        heading = (math.cos(state.phi), math.sin(state.phi))
        centers, radii, velocities, _ = world.stacked_obstacles()
        agents = [((state.x, state.y), robot.bounding_radius + self.safety_margin, robot.v_limit,
                   (state.v * heading[0], state.v * heading[1]),
                   tuple(self.preferred_velocity(state, goal)))]
        for c, r, v in zip(centers, radii, velocities):
            v = (float(v[0]), float(v[1]))
            agents.append(((float(c[0]), float(c[1])), float(r),
                           max(math.hypot(*v), 1e-3), v, v))
        while self._n_agents < len(agents):
            sim.add_agent((PARKED, PARKED), NEIGHBOR_DIST, MAX_NEIGHBORS, TIME_HORIZON,
                          TIME_HORIZON_OBST, 0.01, 0.0, (0.0, 0.0))
            self._n_agents += 1
        for k in range(self._n_agents):
            # Unused slots wait far away, spread out so they never meet each other.
            position, radius, max_speed, velocity, preferred = agents[k] if k < len(agents) \
                else ((PARKED + 10.0 * k, PARKED), 0.01, 0.0, (0.0, 0.0), (0.0, 0.0))
            sim.set_agent_position(k, position)
            sim.set_agent_radius(k, radius)
            sim.set_agent_max_speed(k, max_speed)
            sim.set_agent_velocity(k, velocity)
            sim.set_agent_pref_velocity(k, preferred)
        me = 0
        sim.do_step()
        u = sim.get_agent_velocity(me)
        return np.array([u.x, u.y], dtype=float)

    def to_unicycle(self, state: RobotState, velocity) -> tuple:
        """``(v, omega)`` from a holonomic velocity (module docstring), within the limits."""
        robot = self.config.robot
        dt = self.config.horizon.dt
        speed = float(np.hypot(*velocity))
        if speed < 1e-9:
            v_want, omega_want = 0.0, 0.0
        else:
            error = math.remainder(math.atan2(velocity[1], velocity[0]) - state.phi, math.tau)
            omega_want = GAIN_TURN * error
            v_want = speed * max(math.cos(error), 0.0)
        v = min(max(v_want, state.v - robot.accel_limit * dt, 0.0),
                state.v + robot.accel_limit * dt, robot.v_limit)
        v = max(v, 0.0)
        omega = min(max(omega_want, state.omega - robot.alpha_limit * dt),
                    state.omega + robot.alpha_limit * dt)
        omega = min(max(omega, -robot.omega_limit), robot.omega_limit)
        return float(v), float(omega)

    def plan(self, state: RobotState, world, goal, *, dock: bool = True,
             sample: bool = False, goal_tolerance: float = 0.0) -> OrcaPlan:
        """One cycle: ORCA's velocity, converted to ``(v, omega)``; ``dock``, ``sample`` and
        ``goal_tolerance`` unused."""
        started = time.perf_counter()
        u = self.holonomic_velocity(state, world, goal)
        v, omega = self.to_unicycle(state, u)
        n = self.config.horizon.n_steps
        dt = self.config.horizon.dt
        poses = np.empty((n + 1, 3))
        poses[0] = state.pose
        for k in range(n):
            poses[k + 1] = arc_step(poses[k], v, omega, dt)
        nan = math.nan
        cost = _Costs({name: nan for name in TERM_NAMES}, np.full(n + 1, nan))
        trajectory = _Trajectory(poses, np.full(n, v), np.full(n, omega),
                                 np.array([*np.asarray(goal, dtype=float), nan]))
        return OrcaPlan((v, omega), trajectory, cost, (float(u[0]), float(u[1])),
                        wall_time=time.perf_counter() - started)


def simulate_orca(scenario, config: PlannerConfig, rng=None, **kwargs):
    """:func:`~dsmpepc_nlp.sim.simulate.simulate` with every robot driven by :class:`OrcaPlanner`.

    ``config`` supplies the robot (speed and rate limits, footprint) and ``dt``; its cost
    settings are unused. ImportError with the install hint when pyrvo is missing.
    """
    require_pyrvo()
    return simulate(scenario, config, SolverConfig.sampling(n_samples=1), rng,
                    planner_factory=OrcaPlanner, **kwargs)
