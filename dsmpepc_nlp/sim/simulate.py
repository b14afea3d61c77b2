"""The closed loop (docs/method.md section 7): a scenario's robots plan and move together, logged.

Every ``dt`` each robot that has no outcome yet plans once, from what it sees now, and then all
of them execute the first step of their plans at once (exact arc integration). Robots plan
independently, each with its own planner (and so its own warm start), and see each other as
constant-velocity dynamic obstacles. Pedestrians replay scripted paths and do not react. A robot
with an outcome (:mod:`.outcomes`, decided after every step) stops where it is and stays there
as a static obstacle for the others.

The planner is whatever ``planner_factory(config, solver)`` builds (default
:class:`~dsmpepc_nlp.solve.planner.Planner`): any
:class:`~dsmpepc_nlp.solve.policy.PlanningPolicy` drives a robot, which is how the ORCA
baseline runs in the very same loop. The scenario types live in :mod:`.types`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.control_law import arc_step
from ..core.errors import InputError
from ..core.geometry import footprint_points
from ..core.solver_config import SolverConfig
from ..core.terms import TERM_NAMES
from ..core.world import DynamicObstacle, World
from ..solve.plan import STATUSES
from ..solve.planner import Planner
from ..solve.policy import PlanningPolicy
from .belief import belief_log
from .checks import start_states
from .episode import Episode, config_to_dict, robot_obstacle
from .outcomes import (
    OutcomeConfig,
    footprint_gap,
    outcome,
    window_progress,
)
from .senses import Senses
from .sensing import SensingProfile, load_profile
from .types import FixedGoal, Scenario

_footprint_gap = footprint_gap  # the old private name


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
               "out_of_time": np.zeros((r, n_cycles), dtype=bool),
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
                out["out_of_time"][i, k] = bool(plan.cut)
                if record_trajectories:
                    out["plan_poses"][i, k] = plan.trajectory.poses
        return out


class _Loop:
    """The state of one episode while it runs: robots, pedestrians, outcomes and history."""

    def __init__(self, scenario: Scenario, config: PlannerConfig, solver: SolverConfig, rng,
                 planner_factory, rules: OutcomeConfig, sensing: SensingProfile | None = None):
        self.scenario, self.dt, self.rules = scenario, config.horizon.dt, rules
        self.agents = agents = scenario.agents
        self.n = len(agents)
        if self.n == 0:
            raise InputError(f"scenario {scenario.name!r}: agents is empty: need at least one "
                             "robot")
        self.configs = [config if a.robot is None else dataclasses.replace(config, robot=a.robot)
                        for a in agents]
        self.planners = [planner_factory(c, solver) for c in self.configs]
        # Compile ahead: no cycle of an episode plans on a fallback. A robot never sees more
        # dynamic objects than the others, the pedestrians and the parked robots.
        objects = len(agents) - 1 + len(scenario.pedestrians) + len(scenario.parked)
        for planner in self.planners:
            prepare = getattr(planner, "prepare", None)
            if prepare is not None:
                prepare(max_objects=objects)
        self.footprints = [np.array(c.robot.footprint) for c in self.configs]
        self.states = start_states(scenario, rng)  # noise first, then the free-space checks
        # The senses draw after the starts, so a profile's episode starts where oracle's does.
        self.sensing = sensing if sensing is not None and not sensing.is_oracle else None
        self.senses = None if self.sensing is None else [
            Senses(self.sensing, c, scenario.grid, np.random.default_rng(rng.integers(2**63)))
            for c in self.configs]
        self.hist_believed = []
        self.hist_believed_people = []         # per cycle: robot -> (m, 5) people it planned with
        self.perception = [None] * self.n      # at a collision: what it touched, believed?
        self.base_world = World(scenario.grid)
        self.parked = [DynamicObstacle.robot(p.pose, (0.0, 0.0), p.footprint)
                       for p in scenario.parked]
        self.peds = scenario.pedestrians
        self.window = int(round(rules.deadlock_window / self.dt))
        self.times = [0.0]
        self.hist_states = [[s.copy()] for s in self.states]
        ped_pos, ped_vel = self.ped_now(0.0)
        self.hist_ped = [(ped_pos, ped_vel)]
        self.hist_goals = [[self.goal_now(i, ped_pos)] for i in range(self.n)]
        self.outcomes = [None] * self.n
        self.outcome_times = [math.nan] * self.n
        # NF values (fixed goals) or path length driven (follow goals), one per state
        self.progress_ref = [[self.nf_value(i) if a.goal.kind == "fixed" else 0.0]
                             for i, a in enumerate(agents)]

    def ped_now(self, t):
        pos = np.array([p.position(t) for p in self.peds]).reshape(-1, 2)
        vel = np.array([p.velocity_at(t) for p in self.peds]).reshape(-1, 2)
        return pos, vel

    def goal_now(self, i, ped_pos):
        """Robot ``i``'s goal point now: fixed, or the followed pedestrian pulled back."""
        goal = self.agents[i].goal
        if isinstance(goal, FixedGoal):
            return np.asarray(goal.position, dtype=float)
        target = ped_pos[goal.pedestrian]
        away = self.states[i][:2] - target
        norm = float(np.hypot(*away))
        return target + (goal.distance * away / norm if norm > 1e-9 else 0.0)

    def nf_value(self, i):
        goal = self.agents[i].goal
        # The planner's window (around the robot for a goal beyond the map), so progress toward
        # a far goal keeps counting once the robot has left the map.
        config, position = self.configs[i], self.states[i][:2]
        nav = self.base_world.navigation(np.asarray(goal.position, dtype=float),
                                         config.robot.inflation_radius, near=position,
                                         reach=config.reach)
        return float(nav.value(position))

    def collided(self, i, points, radii, ped_pos) -> bool:
        """Robot ``i``'s footprint overlaps the map, a pedestrian, a robot or a parked robot."""
        hit = bool(np.any(self.base_world.static_distance(points[i]) - radii[i] < 0))
        ped_r = np.array([p.radius for p in self.peds])
        hit = hit or footprint_gap(points[i], radii[i], ped_pos, ped_r) < 0
        for j in range(self.n):
            if j != i and footprint_gap(points[i], radii[i], points[j], radii[j]) < 0:
                hit = True
        for o in self.parked:
            hit = hit or footprint_gap(points[i], radii[i], o.centers, o.radii) < 0
        return hit

    def decide(self, t, ped_pos) -> None:
        """Outcomes at time ``t`` for robots without one; a robot with one stops."""
        points = [footprint_points(s[:3], fp[:, :2]) for s, fp in zip(self.states,
                                                                       self.footprints)]
        radii = [fp[:, 2] for fp in self.footprints]
        new = {}
        for i in range(self.n):
            if self.outcomes[i] is not None:
                continue
            goal = self.agents[i].goal
            if goal.kind == "fixed":
                near = np.hypot(*(self.states[i][:2] - np.asarray(goal.position))) \
                    <= goal.tolerance
            else:
                distance = float(np.hypot(*(self.states[i][:2] - ped_pos[goal.pedestrian])))
                near = distance <= goal.distance + goal.tolerance
            result = outcome(t, self.scenario.duration, kind=goal.kind,
                             collided=self.collided(i, points, radii, ped_pos), near=bool(near),
                             progress=window_progress(self.progress_ref[i], self.window,
                                                      goal.kind) if self.rules.deadlock else None,
                             rules=self.rules)
            if result is not None:
                new[i] = result
        for i, result in new.items():
            if result == "collision" and self.senses is not None:
                self.perception[i] = self.senses[i].perceived(
                    self.states[i], points[i], radii[i], ped_pos,
                    np.array([p.radius for p in self.peds]))
            self.outcomes[i] = result
            self.outcome_times[i] = t
            self.states[i][3:] = 0.0

    def plan(self, k, record_samples, max_samples, samples) -> dict:
        """Every moving robot plans once from what it sees now; the plans by robot index."""
        ped_pos, ped_vel = self.hist_ped[-1]
        ped_obs = [DynamicObstacle.pedestrian(p, v, ped.radius)
                   for p, v, ped in zip(ped_pos, ped_vel, self.peds)]
        plans, believed, believed_people = {}, {}, {}
        self.hist_believed.append(believed)
        self.hist_believed_people.append(believed_people)
        for i in range(self.n):
            if self.outcomes[i] is not None:
                continue
            others = [robot_obstacle(self.states[j], self.footprints[j]) for j in range(self.n)
                      if j != i]
            if self.senses is None:
                world = self.base_world.with_obstacles(ped_obs + others + self.parked)
                state = RobotState(*(float(v) for v in self.states[i]))
            else:
                people = (ped_pos, ped_vel, np.array([p.radius for p in self.peds]))
                state, world = self.senses[i].perceive(self.times[-1], self.states[i], people,
                                                       others + self.parked)
                believed[i] = np.array([state.x, state.y, state.phi, state.v, state.omega])
                believed_people[i] = np.array(
                    [[*o.centers[0], *o.velocity, o.radii[0]] for o in world.obstacles
                     if o.kind == "pedestrian"], dtype=float).reshape(-1, 5)
            sample = k in record_samples
            fixed = self.agents[i].goal.kind == "fixed"
            dock = fixed or self.configs[i].docking.follow
            plan = self.planners[i].plan(state, world, self.hist_goals[i][-1], dock=dock,
                                         sample=sample,
                                         goal_tolerance=self.agents[i].goal.tolerance
                                         if fixed else 0.0)
            plans[i] = plan
            if sample and plan.evaluated is not None:
                samples[(i, k)] = _best_samples(plan.evaluated, max_samples)
        return plans

    def step(self, k, plans) -> None:
        """Execute the first step of every plan, move the pedestrians, decide outcomes."""
        for i, plan in plans.items():
            v, omega = plan.control if self.senses is None else \
                self.senses[i].execute(plan.control, self.states[i])
            x, y, phi = arc_step(self.states[i][:3], v, omega, self.dt)
            self.states[i] = np.array([x, y, phi, v, omega], dtype=float)
        t_next = (k + 1) * self.dt
        self.times.append(t_next)
        ped_pos, ped_vel = self.ped_now(t_next)
        self.hist_ped.append((ped_pos, ped_vel))
        for i in range(self.n):
            if self.agents[i].goal.kind == "fixed":
                self.progress_ref[i].append(self.nf_value(i))
            else:
                step = float(np.hypot(*(self.states[i][:2] - self.hist_states[i][-1][:2])))
                self.progress_ref[i].append(self.progress_ref[i][-1] + step)
        self.decide(t_next, ped_pos)
        for i in range(self.n):
            self.hist_states[i].append(self.states[i].copy())
            self.hist_goals[i].append(self.goal_now(i, ped_pos))

    def finish(self) -> None:
        """Robots still running when the loop ran out of cycles: ``timeout``."""
        for i in range(self.n):
            if self.outcomes[i] is None:
                self.outcomes[i] = "timeout"
                self.outcome_times[i] = self.times[-1]


def _best_samples(evaluated, max_samples) -> tuple:
    """The ``max_samples`` lowest-cost evaluated trajectories: (poses float32, costs)."""
    total = evaluated.costs.total
    order = np.argsort(np.where(np.isfinite(total), total, np.inf), kind="stable")[:max_samples]
    return (evaluated.trajectories.poses[order].astype(np.float32),
            np.asarray(total[order], dtype=float))


def simulate(scenario: Scenario, config: PlannerConfig, solver: SolverConfig, rng=None, *,
             record_trajectories: bool = True, record_samples=(), max_samples: int = 512,
             progress=None,
             planner_factory: Callable[..., PlanningPolicy] = Planner,
             outcomes: OutcomeConfig | None = None,
             sensing: SensingProfile | str | None = None) -> Episode:
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
    planner_factory : callable, optional
        ``planner_factory(config, solver)`` builds each robot's planner (default
        :class:`~dsmpepc_nlp.solve.planner.Planner`; the ORCA baseline passes its own).
    outcomes : OutcomeConfig, optional
        The outcome rules' numbers and the deadlock rule's switch (docs/method.md section 7.3;
        CrowdNav's protocol turns the rule off: a stalled robot times out).
    sensing : SensingProfile or str, optional
        What the robots sense and how their commands run (:mod:`.sensing`; a built-in name or
        a profile file); default ``oracle``, the truth. Its draws come from ``rng`` after the
        start perturbations.

    Returns
    -------
    Episode
    """
    rng = np.random.default_rng(0) if rng is None else rng
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng = {rng!r}: must be a numpy.random.Generator")
    n_cycles = max(1, int(math.ceil(scenario.duration / config.horizon.dt - 1e-9)))
    record_samples = set(int(k) for k in record_samples)
    loop = _Loop(scenario, config, solver, rng, planner_factory,
                 OutcomeConfig() if outcomes is None else outcomes,
                 None if sensing is None else load_profile(sensing))
    log = _Log(loop.n, config.horizon.n_steps)
    samples = {}
    loop.decide(0.0, loop.hist_ped[0][0])
    for k in range(n_cycles):
        if all(o is not None for o in loop.outcomes):
            break
        plans = loop.plan(k, record_samples, max_samples, samples)
        log.cycle(plans)
        loop.step(k, plans)
        if progress is not None:
            progress(k, loop.times[-1], n_cycles, sum(o is None for o in loop.outcomes))
    loop.finish()
    return _episode(loop, log.arrays(record_trajectories), samples, config, solver)


def _episode(loop: _Loop, arrays: dict, samples: dict, config, solver) -> Episode:
    """The finished loop as an :class:`Episode` (arrays, outcomes and metadata)."""
    scenario, agents, peds, grid = loop.scenario, loop.agents, loop.peds, loop.scenario.grid
    meta = {
        "scenario": scenario.name, "map_path": scenario.map_path, "dt": loop.dt,
        "duration": scenario.duration, "variant": config.variant_name,
        "solver": solver.method, "n_samples": solver.n_samples,
        "robots": [a.name for a in agents], "footprints": [f.tolist() for f in loop.footprints],
        "goal_kinds": [a.goal.kind for a in agents],
        "goal_tolerances": [a.goal.tolerance for a in agents],
        "follow": [[a.goal.pedestrian, a.goal.distance] if a.goal.kind == "follow" else None
                   for a in agents],
        "parked": [{"pose": list(map(float, p.pose)),
                    "footprint": [list(map(float, c)) for c in p.footprint]}
                   for p in scenario.parked],
        "config": config_to_dict(config),
    }
    extra = {}
    if loop.senses is not None:
        extra = belief_log(loop.senses, loop.sensing, loop.perception, loop.hist_believed,
                           loop.hist_believed_people, meta)
    n_times = len(loop.times)
    return Episode(
        times=np.array(loop.times), states=np.array(loop.hist_states),
        goals=np.array(loop.hist_goals),
        ped_positions=np.array([p for p, _ in loop.hist_ped]).reshape(n_times, len(peds), 2),
        ped_velocities=np.array([v for _, v in loop.hist_ped]).reshape(n_times, len(peds), 2),
        ped_radii=np.array([p.radius for p in peds], dtype=float),
        grid_occupied=None if grid is None else np.array(grid.occupied),
        grid_resolution=None if grid is None else grid.resolution,
        grid_origin=None if grid is None else np.array(grid.origin),
        outcomes=loop.outcomes, outcome_times=loop.outcome_times, meta=meta, samples=samples,
        **arrays, **extra)
