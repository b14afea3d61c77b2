"""The closed loop (METHOD.md section 7): scenarios of robots and pedestrians, and logged episodes.

Every ``dt`` each robot that has no outcome yet plans once, from what it sees now, and then all
of them execute the first step of their plans at once (exact arc integration). Robots plan
independently, each with its own :class:`~dsmpepc_nlp.planner.Planner` (and so its own warm
start), and see each other as constant-velocity dynamic obstacles. Pedestrians replay scripted
paths and do not react.

Outcomes, decided after every step, in this order:

``collision``
    A footprint circle overlaps the map (``World.static_distance(centre) - radius < 0``), a
    pedestrian or another robot (circle gap < 0). Every robot involved gets it.
``success``
    Fixed goal: the robot's reference point is within ``goal.tolerance`` of the goal. Follow goal
    (moving target): decided when the scenario's duration ends: no collision through it and the
    final centre-to-centre distance to the followed pedestrian at most
    ``goal.distance + goal.tolerance``.
``deadlock``
    Not at the goal and less than ``deadlock_progress`` (0.1 m) of progress over the last
    ``deadlock_window`` (10 s). Progress toward a fixed goal is the decrease of the robot's own
    navigation function; toward a moving goal (whose NF changes every cycle) it is the path
    length driven in the window.
``timeout``
    A fixed goal not reached when the duration ends; a follow goal ending too far behind.

A robot with an outcome stops where it is and stays there as a static obstacle for the others.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..core.config import PlannerConfig, RobotConfig, RobotState, SolverConfig
from ..core.control_law import arc_step
from ..core.costs import TERM_NAMES
from .episode import Episode, config_to_dict, robot_obstacle
from ..core.errors import InputError
from ..core.geometry import footprint_points
from ..solve.planner import STATUSES, Planner
from ..core.world import DynamicObstacle, OccupancyGrid, World

OUTCOMES = ("success", "collision", "deadlock", "timeout")
"""Per-robot outcomes (METHOD.md section 7)."""

DEADLOCK_WINDOW = 10.0
"""Seconds over which progress is measured for ``deadlock`` (METHOD.md section 7)."""
DEADLOCK_PROGRESS = 0.1
"""Less progress than this (m) over the window is a deadlock (METHOD.md section 7)."""



# ---------------------------------------------------------------------------------------------
# what a scenario is made of


@dataclass(frozen=True)
class Pedestrian:
    """A scripted pedestrian: timestamped waypoints or a constant velocity.

    Attributes
    ----------
    times : ndarray, (K,)
        Strictly increasing waypoint times, s. With one waypoint the pedestrian moves at
        ``velocity`` from it forever.
    positions : ndarray, (K, 2)
        Waypoint positions, m. Before the first time the pedestrian waits at the first one,
        after the last at the last one.
    velocity : ndarray, (2,)
        Constant velocity (m/s), used only when K == 1.
    radius : float
        Body radius, m.
    """

    times: np.ndarray
    positions: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(2))
    radius: float = 0.3

    def __post_init__(self):
        times = np.atleast_1d(np.asarray(self.times, dtype=float))
        positions = np.atleast_2d(np.asarray(self.positions, dtype=float))
        velocity = np.asarray(self.velocity, dtype=float)
        if times.ndim != 1 or positions.shape != (times.size, 2) or times.size < 1:
            raise InputError(f"Pedestrian: times {times.shape} and positions {positions.shape}: "
                             "must be (K,) and (K, 2) with K >= 1")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(positions))
                and velocity.shape == (2,) and np.all(np.isfinite(velocity))):
            raise InputError("Pedestrian: times, positions and velocity must be finite")
        if np.any(np.diff(times) <= 0):
            raise InputError(f"Pedestrian.times = {times.tolist()}: must be strictly increasing")
        if not (math.isfinite(self.radius) and self.radius > 0):
            raise InputError(f"Pedestrian.radius = {self.radius!r}: must be finite and > 0")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "velocity", velocity)

    @classmethod
    def constant(cls, position, velocity, radius=0.3) -> Pedestrian:
        """Starts at ``position`` (m) at t = 0 and keeps ``velocity`` (m/s)."""
        return cls(np.zeros(1), np.reshape(position, (1, 2)), np.asarray(velocity), radius)

    def position(self, t: float) -> np.ndarray:
        """Position at time ``t`` (s), m, shape (2,)."""
        if self.times.size == 1:
            return self.positions[0] + (t - self.times[0]) * self.velocity
        return np.array([np.interp(t, self.times, self.positions[:, i]) for i in range(2)])

    def velocity_at(self, t: float) -> np.ndarray:
        """Current velocity (m/s): the slope of the waypoint segment holding ``t``."""
        if self.times.size == 1:
            return self.velocity.copy()
        if t < self.times[0] or t >= self.times[-1]:
            return np.zeros(2)
        k = int(np.searchsorted(self.times, t, side="right")) - 1
        span = self.times[k + 1] - self.times[k]
        return (self.positions[k + 1] - self.positions[k]) / span


@dataclass(frozen=True)
class FixedGoal:
    """A goal position (m); reached within ``tolerance`` (m). Docked near it."""

    position: tuple
    tolerance: float = 0.25

    @property
    def kind(self) -> str:
        return "fixed"


@dataclass(frozen=True)
class FollowGoal:
    """Follow pedestrian ``pedestrian`` (index) at ``distance`` (m); never docked.

    The goal each cycle is the pedestrian's position pulled back toward the robot by
    ``distance``. ``tolerance`` (m) is how much farther than ``distance`` the robot may end up.
    """

    pedestrian: int
    distance: float = 1.0
    tolerance: float = 1.0

    @property
    def kind(self) -> str:
        return "follow"


@dataclass(frozen=True)
class Agent:
    """A planning robot: its name, start state, goal and body (None: the config's robot)."""

    name: str
    start: RobotState
    goal: FixedGoal | FollowGoal
    robot: RobotConfig | None = None


@dataclass(frozen=True)
class ParkedRobot:
    """A robot that never moves (a dynamic obstacle of kind ``robot`` with zero velocity)."""

    pose: tuple
    footprint: tuple


@dataclass(frozen=True)
class Scenario:
    """Everything the simulator needs, already validated (see ``scenario.py`` for the YAML).

    ``start_noise`` (m) is the standard deviation of a seeded Gaussian perturbation of every
    agent's start position; ``map_path`` only records where ``grid`` came from.
    """

    name: str
    agents: tuple
    grid: OccupancyGrid | None = None
    pedestrians: tuple = ()
    parked: tuple = ()
    duration: float = 30.0
    start_noise: float = 0.0
    map_path: str | None = None
    description: str = ""


# ---------------------------------------------------------------------------------------------
# the loop


class _Log:
    """Per-cycle records, turned into arrays at the end."""

    def __init__(self, n_robots, n_steps):
        self.n_robots, self.n_steps = n_robots, n_steps
        self.rows = []

    def cycle(self, plans: dict) -> None:
        self.rows.append(plans)

    def arrays(self, record_trajectories: bool) -> dict:
        n_cycles, r = len(self.rows), self.n_robots

        def nan(*shape):
            return np.full((r, n_cycles, *shape), np.nan)

        out = {"z": nan(4), "cost_total": nan(), "cost_terms": nan(len(TERM_NAMES)),
               "survivability": nan(), "ttg": nan(), "ttc_terminal": nan(),
               "status": np.full((r, n_cycles), -1, dtype=np.int8),
               "nit": np.zeros((r, n_cycles), dtype=np.int32),
               "n_starts": np.zeros((r, n_cycles), dtype=np.int16),
               "plan_time": nan(), "active": np.zeros((r, n_cycles), dtype=bool),
               "plan_poses": nan(self.n_steps + 1, 3) if record_trajectories else None}
        for k, plans in enumerate(self.rows):
            for i, plan in plans.items():
                out["active"][i, k] = True
                out["z"][i, k] = plan.x
                out["cost_total"][i, k] = plan.fun
                out["cost_terms"][i, k] = [float(plan.cost.terms[n]) for n in TERM_NAMES]
                out["survivability"][i, k] = float(np.asarray(plan.cost.survivability)[-1])
                out["ttg"][i, k] = float(plan.cost.ttg)
                out["ttc_terminal"][i, k] = float(plan.cost.ttc_terminal)
                out["status"][i, k] = STATUSES.index(plan.status)
                out["nit"][i, k] = plan.nit
                out["n_starts"][i, k] = len(plan.starts)
                out["plan_time"][i, k] = plan.wall_time
                if record_trajectories:
                    out["plan_poses"][i, k] = plan.trajectory.poses
        return out


def _footprint_gap(points_a, radii_a, points_b, radii_b) -> float:
    """Smallest gap between two sets of circles, m (negative: overlap)."""
    if len(points_a) == 0 or len(points_b) == 0:
        return math.inf
    d = np.linalg.norm(points_a[:, None, :] - points_b[None, :, :], axis=-1)
    return float(np.min(d - radii_a[:, None] - radii_b[None, :]))


def simulate(scenario: Scenario, config: PlannerConfig, solver: SolverConfig, rng=None, *,
             record_trajectories: bool = True, record_samples=(), max_samples: int = 512,
             progress=None) -> Episode:
    """Run ``scenario`` in closed loop with every agent planning by ``config`` and ``solver``.

    Parameters
    ----------
    scenario : Scenario
    config : PlannerConfig
        The method; each agent's body (``Agent.robot``) replaces ``config.robot`` when given.
    solver : SolverConfig
    rng : numpy.random.Generator, optional
        Draws the start perturbations (``scenario.start_noise``); ``default_rng(0)`` if None.
        Nothing else is random: same scenario, config, solver and seed give the same episode.
    record_trajectories : bool
        Log every plan's chosen trajectory poses.
    record_samples : iterable of int
        Cycles whose evaluated sample trajectories (poses, exact costs) are logged, for every
        active robot; the sampler runs in those cycles even when the NLP succeeds.
    max_samples : int
        At most this many evaluated trajectories per recorded cycle (the lowest-cost ones).
    progress : callable, optional
        ``progress(cycle, time, n_cycles, n_active)`` after every cycle.

    Returns
    -------
    Episode
    """
    rng = np.random.default_rng(0) if rng is None else rng
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng = {rng!r}: must be a numpy.random.Generator")
    dt = config.horizon.dt
    n_cycles = max(1, int(math.ceil(scenario.duration / dt - 1e-9)))
    record_samples = set(int(k) for k in record_samples)
    agents = scenario.agents
    n = len(agents)
    if n == 0:
        raise InputError(f"scenario {scenario.name!r}: agents is empty: need at least one robot")
    configs = [config if a.robot is None else dataclasses.replace(config, robot=a.robot)
               for a in agents]
    planners = [Planner(c, solver) for c in configs]
    footprints = [np.array(c.robot.footprint) for c in configs]
    states = []
    for agent in agents:
        s = agent.start
        dx, dy = rng.normal(0.0, scenario.start_noise, 2) if scenario.start_noise > 0 else (0, 0)
        states.append(np.array([s.x + dx, s.y + dy, s.phi, s.v, s.omega], dtype=float))
    base_world = World(scenario.grid)
    parked = [DynamicObstacle.robot(p.pose, (0.0, 0.0), p.footprint) for p in scenario.parked]
    peds = scenario.pedestrians

    def ped_now(t):
        pos = np.array([p.position(t) for p in peds]).reshape(-1, 2)
        vel = np.array([p.velocity_at(t) for p in peds]).reshape(-1, 2)
        return pos, vel

    def goal_now(i, t, ped_pos):
        goal = agents[i].goal
        if isinstance(goal, FixedGoal):
            return np.asarray(goal.position, dtype=float)
        target = ped_pos[goal.pedestrian]
        away = states[i][:2] - target
        norm = float(np.hypot(*away))
        return target + (goal.distance * away / norm if norm > 1e-9 else 0.0)

    times = [0.0]
    hist_states = [[s.copy()] for s in states]
    ped_pos, ped_vel = ped_now(0.0)
    hist_ped = [(ped_pos, ped_vel)]
    hist_goals = [[goal_now(i, 0.0, ped_pos)] for i in range(n)]
    outcomes = [None] * n
    outcome_times = [math.nan] * n
    log = _Log(n, config.horizon.n_steps)
    samples = {}
    progress_ref = [None] * n  # NF values (fixed goals) or path length (follow) per cycle

    def nf_value(i, point):
        goal = agents[i].goal
        nav = base_world.navigation(np.asarray(goal.position, dtype=float),
                                    configs[i].robot.inflation_radius)
        return float(nav.value(point))

    for i in range(n):
        progress_ref[i] = [nf_value(i, states[i][:2]) if agents[i].goal.kind == "fixed" else 0.0]

    def check(t, ped_pos):
        """Decide outcomes at time t for robots without one."""
        points = [footprint_points(s[:3], fp[:, :2]) for s, fp in zip(states, footprints)]
        radii = [fp[:, 2] for fp in footprints]
        ped_r = np.array([p.radius for p in peds])
        parked_pts = [(o.centers, o.radii) for o in parked]
        new = {}
        for i in range(n):
            if outcomes[i] is not None:
                continue
            hit = bool(np.any(base_world.static_distance(points[i]) - radii[i] < 0))
            hit = hit or _footprint_gap(points[i], radii[i], ped_pos, ped_r) < 0
            for j in range(n):
                if j != i and _footprint_gap(points[i], radii[i], points[j], radii[j]) < 0:
                    hit = True
            for c, r in parked_pts:
                hit = hit or _footprint_gap(points[i], radii[i], c, r) < 0
            goal = agents[i].goal
            window = int(round(DEADLOCK_WINDOW / dt))
            ref = progress_ref[i]
            if hit:
                new[i] = "collision"
            elif goal.kind == "fixed":
                at_goal = np.hypot(*(states[i][:2] - np.asarray(goal.position))) <= goal.tolerance
                if at_goal:
                    new[i] = "success"
                elif len(ref) > window and ref[-1 - window] - ref[-1] < DEADLOCK_PROGRESS:
                    new[i] = "deadlock"
                elif t >= scenario.duration - 1e-9:
                    new[i] = "timeout"
            else:
                distance = float(np.hypot(*(states[i][:2] - ped_pos[goal.pedestrian])))
                near = distance <= goal.distance + goal.tolerance
                if t >= scenario.duration - 1e-9:
                    new[i] = "success" if near else "timeout"
                elif not near and len(ref) > window and ref[-1] - ref[-1 - window] < \
                        DEADLOCK_PROGRESS:
                    new[i] = "deadlock"
        for i, outcome in new.items():
            outcomes[i] = outcome
            outcome_times[i] = t
            states[i][3:] = 0.0

    check(0.0, ped_pos)
    for k in range(n_cycles):
        if all(o is not None for o in outcomes):
            break
        ped_pos, ped_vel = hist_ped[-1]
        ped_obs = [DynamicObstacle.pedestrian(p, v, ped.radius)
                   for p, v, ped in zip(ped_pos, ped_vel, peds)]
        plans = {}
        for i in range(n):
            if outcomes[i] is not None:
                continue
            others = [robot_obstacle(states[j], footprints[j]) for j in range(n) if j != i]
            world = base_world.with_obstacles(ped_obs + others + parked)
            s = states[i]
            state = RobotState(*(float(v) for v in s))
            goal = hist_goals[i][-1]
            sample = k in record_samples
            plan = planners[i].plan(state, world, goal, dock=agents[i].goal.kind == "fixed",
                                    sample=sample)
            plans[i] = plan
            if sample and plan.evaluated is not None:
                ev = plan.evaluated
                order = np.argsort(np.where(np.isfinite(ev.costs.total), ev.costs.total, np.inf),
                                   kind="stable")[:max_samples]
                samples[(i, k)] = (ev.trajectories.poses[order].astype(np.float32),
                                   np.asarray(ev.costs.total[order], dtype=float))
        log.cycle(plans)
        for i, plan in plans.items():
            v, omega = plan.control
            x, y, phi = arc_step(states[i][:3], v, omega, dt)
            states[i] = np.array([x, y, phi, v, omega], dtype=float)
        t_next = (k + 1) * dt
        times.append(t_next)
        ped_pos, ped_vel = ped_now(t_next)
        hist_ped.append((ped_pos, ped_vel))
        for i in range(n):
            if agents[i].goal.kind == "fixed":
                progress_ref[i].append(nf_value(i, states[i][:2]))
            else:
                step = float(np.hypot(*(states[i][:2] - hist_states[i][-1][:2])))
                progress_ref[i].append(progress_ref[i][-1] + step)
        check(t_next, ped_pos)
        for i in range(n):
            hist_states[i].append(states[i].copy())
            hist_goals[i].append(goal_now(i, t_next, ped_pos))
        if progress is not None:
            progress(k, t_next, n_cycles, sum(o is None for o in outcomes))
    for i in range(n):  # the loop ran out of cycles: duration reached
        if outcomes[i] is None:
            outcomes[i] = "timeout"
            outcome_times[i] = times[-1]

    arrays = log.arrays(record_trajectories)
    grid = scenario.grid
    meta = {
        "scenario": scenario.name, "map_path": scenario.map_path, "dt": dt,
        "duration": scenario.duration, "variant": config.variant_name,
        "solver": solver.method, "n_samples": solver.n_samples,
        "robots": [a.name for a in agents], "footprints": [f.tolist() for f in footprints],
        "goal_kinds": [a.goal.kind for a in agents],
        "goal_tolerances": [a.goal.tolerance for a in agents],
        "follow": [[a.goal.pedestrian, a.goal.distance] if a.goal.kind == "follow" else None
                   for a in agents],
        "parked": [{"pose": list(map(float, p.pose)),
                    "footprint": [list(map(float, c)) for c in p.footprint]}
                   for p in scenario.parked],
        "config": config_to_dict(config),
    }
    return Episode(
        times=np.array(times), states=np.array(hist_states), goals=np.array(hist_goals),
        ped_positions=np.array([p for p, _ in hist_ped]).reshape(len(times), len(peds), 2),
        ped_velocities=np.array([v for _, v in hist_ped]).reshape(len(times), len(peds), 2),
        ped_radii=np.array([p.radius for p in peds], dtype=float),
        grid_occupied=None if grid is None else np.array(grid.occupied),
        grid_resolution=None if grid is None else grid.resolution,
        grid_origin=None if grid is None else np.array(grid.origin),
        outcomes=outcomes, outcome_times=outcome_times, meta=meta, samples=samples, **arrays)
