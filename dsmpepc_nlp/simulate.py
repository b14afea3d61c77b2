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
import json
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .config import PlannerConfig, RobotConfig, RobotState, SolverConfig
from .control_law import arc_step
from .costs import TERM_NAMES, footprint_points
from .planner import STATUSES, Planner
from .world import DynamicObstacle, OccupancyGrid, World

OUTCOMES = ("success", "collision", "deadlock", "timeout")
"""Per-robot outcomes (METHOD.md section 7)."""

DEADLOCK_WINDOW = 10.0
"""Seconds over which progress is measured for ``deadlock`` (METHOD.md section 7)."""
DEADLOCK_PROGRESS = 0.1
"""Less progress than this (m) over the window is a deadlock (METHOD.md section 7)."""

EPISODE_FORMAT = 1
"""Version of the NPZ layout written by :meth:`Episode.save`."""


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
            raise ValueError(f"Pedestrian: times {times.shape} and positions {positions.shape}: "
                             "must be (K,) and (K, 2) with K >= 1")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(positions))
                and velocity.shape == (2,) and np.all(np.isfinite(velocity))):
            raise ValueError("Pedestrian: times, positions and velocity must be finite")
        if np.any(np.diff(times) <= 0):
            raise ValueError(f"Pedestrian.times = {times.tolist()}: must be strictly increasing")
        if not (math.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"Pedestrian.radius = {self.radius!r}: must be finite and > 0")
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
# the episode log


_ARRAYS = (
    "times", "states", "active", "goals", "z", "cost_total", "cost_terms", "survivability",
    "ttg", "ttc_terminal", "status", "nit", "plan_time", "n_starts", "plan_poses",
    "ped_positions", "ped_velocities", "ped_radii", "grid_occupied", "grid_resolution",
    "grid_origin",
)


@dataclass
class Episode:
    """A logged closed-loop run. Arrays are indexed ``[robot, cycle, ...]``.

    Attributes
    ----------
    times : ndarray, (K+1,)
        Time of every state, s; cycle k plans at ``times[k]``.
    states : ndarray, (R, K+1, 5)
        ``(x, y, phi, v, omega)`` of every robot; after its outcome a robot stays put (v = 0).
    active : ndarray of bool, (R, K)
        Whether the robot planned in cycle k.
    goals : ndarray, (R, K+1, 2)
        Goal position at every time (moving for follow goals), m.
    z : ndarray, (R, K, 4)
        Each plan's ``(r, theta, delta, v_max)``; NaN when inactive.
    cost_total : ndarray, (R, K)
        Exact cost of each plan.
    cost_terms : ndarray, (R, K, len(term_names))
        Per-term exact cost (``progress, action, collision, heading, terminal``).
    survivability, ttg, ttc_terminal : ndarray, (R, K)
        Survivability at the horizon, time to goal and terminal time to collision (s) of the plan.
    status : ndarray of int, (R, K)
        Index into ``statuses`` (planner.STATUSES); -1 when inactive.
    nit, n_starts : ndarray of int, (R, K)
        NLP iterations summed over starts and number of starts.
    plan_time : ndarray, (R, K)
        Wall time of ``Planner.plan``, s.
    plan_poses : ndarray, (R, K, N+1, 3) or None
        The chosen trajectory of each plan (when recorded).
    ped_positions, ped_velocities : ndarray, (K+1, P, 2)
        Pedestrians over time, m and m/s.
    ped_radii : ndarray, (P,)
    grid_occupied, grid_resolution, grid_origin
        The map (None without one).
    samples : dict
        ``{(robot, cycle): (poses (n, N+1, 3) float32, costs (n,))}``: evaluated trajectories of
        the recorded cycles.
    outcomes : list of str
        One of :data:`OUTCOMES` per robot.
    outcome_times : list of float
        When each outcome was decided, s.
    meta : dict
        JSON-able: scenario name, map path, variant, solver, seed, dt, robot names, footprints,
        goal kinds, parked robots, the planner configuration.
    """

    times: np.ndarray
    states: np.ndarray
    active: np.ndarray
    goals: np.ndarray
    z: np.ndarray
    cost_total: np.ndarray
    cost_terms: np.ndarray
    survivability: np.ndarray
    ttg: np.ndarray
    ttc_terminal: np.ndarray
    status: np.ndarray
    nit: np.ndarray
    plan_time: np.ndarray
    n_starts: np.ndarray
    plan_poses: np.ndarray | None
    ped_positions: np.ndarray
    ped_velocities: np.ndarray
    ped_radii: np.ndarray
    grid_occupied: np.ndarray | None
    grid_resolution: float | None
    grid_origin: np.ndarray | None
    outcomes: list
    outcome_times: list
    meta: dict
    samples: dict = field(default_factory=dict)

    term_names = TERM_NAMES
    statuses = STATUSES

    # -- views ----------------------------------------------------------------------------------

    @property
    def n_robots(self) -> int:
        return self.states.shape[0]

    @property
    def n_cycles(self) -> int:
        return self.times.size - 1

    @property
    def dt(self) -> float:
        return float(self.meta["dt"])

    @property
    def grid(self) -> OccupancyGrid | None:
        """The map as an :class:`OccupancyGrid` (None without one)."""
        if self.grid_occupied is None:
            return None
        return OccupancyGrid(self.grid_occupied, self.grid_resolution, self.grid_origin)

    def footprint(self, robot: int) -> np.ndarray:
        """Body-frame circles of robot ``robot``, (C, 3)."""
        return np.asarray(self.meta["footprints"][robot], dtype=float)

    def status_names(self, robot: int) -> list:
        """Plan status of every active cycle of ``robot``, as words."""
        return [self.statuses[s] for s in self.status[robot] if s >= 0]

    def config(self) -> PlannerConfig:
        """The planner configuration of the run (robot body: the first agent's)."""
        return config_from_dict(self.meta["config"])

    def world_at(self, cycle: int, robot: int = 0, grid: OccupancyGrid | None = None) -> World:
        """The world robot ``robot`` saw when it planned in ``cycle``."""
        grid = self.grid if grid is None else grid
        return World(grid, self._obstacles(cycle, robot))

    def planning_inputs(self, robot: int = 0) -> list:
        """``(state, world, goal)`` of every cycle in which ``robot`` planned."""
        grid = self.grid
        base = World(grid)
        out = []
        for k in np.flatnonzero(self.active[robot]):
            x, y, phi, v, omega = self.states[robot, k]
            state = RobotState(float(x), float(y), float(phi), float(v), float(omega))
            out.append((state, base.with_obstacles(self._obstacles(k, robot)),
                        self.goals[robot, k].copy()))
        return out

    def _obstacles(self, cycle: int, robot: int) -> list:
        obstacles = [DynamicObstacle.pedestrian(p, v, r) for p, v, r in zip(
            self.ped_positions[cycle], self.ped_velocities[cycle], self.ped_radii)]
        for j in range(self.n_robots):
            if j != robot:
                obstacles.append(_robot_obstacle(self.states[j, cycle], self.footprint(j)))
        obstacles += [DynamicObstacle.robot(p["pose"], (0.0, 0.0), p["footprint"])
                      for p in self.meta["parked"]]
        return obstacles

    # -- files ----------------------------------------------------------------------------------

    def save(self, path) -> Path:
        """Write the episode to ``path`` (NPZ with the JSON metadata inside), atomically."""
        path = Path(path)
        arrays = {name: getattr(self, name) for name in _ARRAYS if getattr(self, name) is not None}
        meta = dict(self.meta, outcomes=list(self.outcomes),
                    outcome_times=[float(t) for t in self.outcome_times],
                    samples=[list(key) for key in self.samples], format=EPISODE_FORMAT)
        arrays["meta_json"] = np.array(json.dumps(meta))
        for i, (poses, costs) in enumerate(self.samples.values()):
            arrays[f"sample{i}_poses"] = poses
            arrays[f"sample{i}_costs"] = costs
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.name}.",
                                             suffix=".tmp", delete=False)
        try:
            with handle:
                np.savez_compressed(handle, **arrays)
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(handle.name, path)
        except BaseException:
            Path(handle.name).unlink(missing_ok=True)
            raise
        return path

    @classmethod
    def load(cls, path) -> Episode:
        """Read an episode written by :meth:`save`; ValueError for a file that is not one."""
        try:
            with np.load(path, allow_pickle=False) as data:
                content = {name: data[name] for name in data.files}
        except (OSError, ValueError) as exc:
            raise ValueError(f"episode file {str(path)!r}: cannot read ({exc})") from None
        if "meta_json" not in content:
            raise ValueError(f"episode file {str(path)!r}: no metadata: not an episode")
        meta = json.loads(str(content.pop("meta_json")))
        if meta.get("format") != EPISODE_FORMAT:
            raise ValueError(f"episode file {str(path)!r}: format {meta.get('format')!r}: "
                             f"expected {EPISODE_FORMAT}")
        samples = {tuple(key): (content[f"sample{i}_poses"], content[f"sample{i}_costs"])
                   for i, key in enumerate(meta.pop("samples"))}
        outcomes, outcome_times = meta.pop("outcomes"), meta.pop("outcome_times")
        meta.pop("format")
        fields = {name: content.get(name) for name in _ARRAYS}
        if fields["grid_resolution"] is not None:
            fields["grid_resolution"] = float(fields["grid_resolution"])
        return cls(**fields, outcomes=outcomes, outcome_times=outcome_times, meta=meta,
                   samples=samples)


# ---------------------------------------------------------------------------------------------
# the loop


def _robot_obstacle(state, footprint) -> DynamicObstacle:
    x, y, phi, v = (float(s) for s in state[:4])
    return DynamicObstacle.robot((x, y, phi), (v * math.cos(phi), v * math.sin(phi)), footprint)


def config_to_dict(config: PlannerConfig) -> dict:
    """A JSON-able dict of a planner configuration (inf written as the string ``"inf"``)."""
    def clean(value):
        if isinstance(value, float) and not math.isfinite(value):
            return str(value)
        if isinstance(value, (list, tuple)):
            return [clean(v) for v in value]
        if isinstance(value, dict):
            return {k: clean(v) for k, v in value.items()}
        return value
    return clean(dataclasses.asdict(config))


def config_from_dict(data: dict) -> PlannerConfig:
    """Inverse of :func:`config_to_dict`."""
    parts = {f.name: f.type for f in dataclasses.fields(PlannerConfig)}
    kinds = {name: type(getattr(PlannerConfig(), name)) for name in parts}
    values = {}
    for name, value in data.items():
        if isinstance(value, dict):
            value = {k: float(v) if isinstance(v, str) else v for k, v in value.items()}
            values[name] = kinds[name](**value)
        else:
            values[name] = value
    return PlannerConfig(**values)


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
        raise ValueError(f"scenario {scenario.name!r}: agents is empty: need at least one robot")
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
            others = [_robot_obstacle(states[j], footprints[j]) for j in range(n) if j != i]
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
