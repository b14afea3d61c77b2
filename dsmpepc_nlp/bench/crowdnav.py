"""The CrowdNav protocol (Chen et al., ICRA 2019; vita-epfl/CrowdNav ``env.config``) in our loop.

Circle crossing: ``N_HUMANS`` humans start on a circle of ``CIRCLE_RADIUS`` with each
coordinate perturbed uniformly by +-v_pref/2 and walk to the antipode of their perturbed start.
Square crossing: humans start on one side of a ``SQUARE_WIDTH`` square (left or right half, fair
coin) and walk to a uniform point of the other half. In both, a human is redrawn while its start
(and goal) is closer than ``radius + other radius + DISCOMFORT_DIST`` to a start (goal) of the
robot or of a human already placed, as CrowdNav does. The robot starts at ``(0, -4)`` facing
``+y`` and must reach ``(0, 4)`` within ``SUCCESS_RADIUS`` (CrowdNav's robot radius) by
``DURATION``.

Humans (radius 0.3 m, preferred speed 1 m/s) are driven by ORCA (``pyrvo``) with CrowdNav's
parameters: every ``TIME_STEP`` each human takes ORCA's velocity for its preferred velocity (the
goal offset, capped at v_pref) given the other humans' current positions and velocities, and all
of them move holonomically at once. ORCA's answer for one agent does not depend on the other
agents' preferred velocities, so one simulator for all humans gives what CrowdNav's one
simulator per human gives. Setting ``invisible`` (the standard): the humans ignore the robot.
Setting ``visible``: the robot is one more ORCA agent for them, at its current position and
velocity (its own ORCA answer is discarded).

Episodes are CrowdNav's test cases: with ``--seed 0`` episode ``k`` draws the humans from
numpy's legacy generator seeded ``1000 + k`` in CrowdNav's order of draws, as CrowdNav's test
phase does (:func:`case_rng`), so episodes 0-499 are the 500 test cases of the literature.

Control period: CrowdNav's time step is 0.25 s, our horizon step 0.2 s (docs/method.md section
2). The loop runs at 0.25 s and the robot holds its plan's first control over each step (a
zero-order hold, as a 4 Hz controller would), within what the limits allow over 0.2 s.

Outcomes as CrowdNav decides them: a collision is any overlap with a human within a step
(closest approach of the straight-line relative motion between two states, CrowdNav's check;
:func:`~dsmpepc_nlp.sim.metrics.swept_contact_time`), checked before success; success is the
robot within its radius of the goal; CrowdNav's ``time_limit = 25`` ends an episode as a timeout
once ``global_time >= time_limit - 1``, so the last state that can succeed is at 24 s
(``DURATION``); there is no deadlock rule (a robot that stalls runs on to the time limit).
Humans that reach their goal stay there as ORCA agents (preferred velocity toward the goal), still
stepping aside for the other humans, never for an invisible robot.

Differences from CrowdNav, stated rather than hidden: the robot is our unicycle with its
limits (radius 0.3 m, as CrowdNav's robot), not CrowdNav's holonomic or unicycle action set;
CrowdNav's collision check uses each human's velocity of the previous step, ours the human's
actual motion over the step."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.config import PlannerConfig, RobotConfig, RobotState
from ..core.errors import InputError
from ..core.solver_config import SolverConfig
from ..sim.episode import config_to_dict
from ..sim.metrics import DISCOMFORT_GAP, swept_contact_time
from ..sim.outcomes import OutcomeConfig
from ..sim.simulate import simulate
from ..sim.types import Agent, FixedGoal, Scenario
from ..solve.planner import Planner
from .crowd_rows import measured_row, run_variants
from .cv import CROWD_BASELINES, ConstantVelocityPlanner
from .orca import OrcaPlanner, check_variants, require_pyrvo
from .params import config_meta, planner_config, robot_with, solver_of
from .results import ResultTable

SCENES = ("circle", "square")
"""CrowdNav's test scenes: circle crossing and square crossing."""
SETTINGS = ("invisible", "visible")
"""Whether the humans see the robot (``invisible`` is CrowdNav's standard)."""
N_HUMANS = 5
CIRCLE_RADIUS = 4.0
"""m."""
SQUARE_WIDTH = 10.0
"""m."""
HUMAN_RADIUS = 0.3
"""m."""
HUMAN_SPEED = 1.0
"""Preferred speed of the humans, m/s."""
DISCOMFORT_DIST = DISCOMFORT_GAP
"""Extra spacing between starts (and goals) when placing humans, m (CrowdNav's 0.2)."""
TIME_STEP = 0.25
"""Control period of the robot and step of the humans, s."""
TIME_LIMIT = 25.0
"""CrowdNav's ``time_limit``, s."""
DURATION = TIME_LIMIT - 1.0
"""Episode length, s: CrowdNav declares a timeout once ``global_time >= time_limit - 1``."""
CASE_OFFSET = 1000
"""CrowdNav seeds test case ``k`` with ``1000 + k`` (its validation cases take 0-999)."""
SUCCESS_RADIUS = 0.3
"""Success radius, m (CrowdNav: within the robot radius of the goal)."""
ROBOT_START = (0.0, -CIRCLE_RADIUS)
ROBOT_GOAL = (0.0, CIRCLE_RADIUS)
ORCA_NEIGHBOR_DIST = 10.0
"""CrowdNav's ORCA parameters: neighbour distance (m), neighbours, horizons (s), radius pad."""
ORCA_MAX_NEIGHBORS = 10
ORCA_TIME_HORIZON = 5.0
ORCA_TIME_HORIZON_OBST = 5.0
ORCA_RADIUS_PAD = 0.01
BASELINES = {"orca": OrcaPlanner, "cv": ConstantVelocityPlanner}
"""The planner class of each baseline in :data:`~dsmpepc_nlp.bench.cv.CROWD_BASELINES`."""
PLACEMENT_DRAWS = 1000
"""Draws of one human's start (goal) before the placement is declared impossible."""


def case_rng(seed: int, episode: int) -> np.random.RandomState:
    """The generator of the humans of episode ``episode``: numpy's legacy generator seeded
    ``CASE_OFFSET * (1 + seed) + episode`` (seed 0: CrowdNav's test case ``episode``; seed
    ``s``: the cases ``1000 s`` further on)."""
    return np.random.RandomState(CASE_OFFSET * (1 + int(seed)) + int(episode))


def _clear(point, others, radius) -> bool:
    """``point`` is at least ``radius + r + DISCOMFORT_DIST`` from every ``(xy, r)`` in others."""
    return all(math.hypot(point[0] - xy[0], point[1] - xy[1]) >= radius + r + DISCOMFORT_DIST
               for xy, r in others)


def _draw(make, others, radius, what):
    for _ in range(PLACEMENT_DRAWS):
        point = make()
        if _clear(point, others, radius):
            return point
    raise InputError(f"crowdnav: no clear {what} for a human in {PLACEMENT_DRAWS} draws "
                     "(too many humans for the scene?)")


def circle_crossing(rng, n_humans=N_HUMANS, robot_radius=0.3, *, radius=HUMAN_RADIUS,
                    v_pref=HUMAN_SPEED) -> tuple:
    """Starts and goals (each (n, 2), m) of CrowdNav's circle crossing, drawn from ``rng``."""
    starts, goals = [], []
    robot = [(ROBOT_START, robot_radius), (ROBOT_GOAL, robot_radius)]

    def make():
        angle = rng.random() * 2 * math.pi
        noise = (rng.random(2) - 0.5) * v_pref
        return (CIRCLE_RADIUS * math.cos(angle) + noise[0],
                CIRCLE_RADIUS * math.sin(angle) + noise[1])

    for _ in range(n_humans):
        placed = robot + [(p, radius) for p in starts + goals]
        start = _draw(make, placed, radius, "start")
        starts.append(start)
        goals.append((-start[0], -start[1]))
    return np.array(starts).reshape(-1, 2), np.array(goals).reshape(-1, 2)


def square_crossing(rng, n_humans=N_HUMANS, robot_radius=0.3, *,
                    radius=HUMAN_RADIUS) -> tuple:
    """Starts and goals (each (n, 2), m) of CrowdNav's square crossing, drawn from ``rng``."""
    starts, goals = [], []

    def side(sign):
        return lambda: (rng.random() * SQUARE_WIDTH * 0.5 * sign,
                        (rng.random() - 0.5) * SQUARE_WIDTH)

    for _ in range(n_humans):
        sign = -1.0 if rng.random() > 0.5 else 1.0
        starts.append(_draw(side(sign),
                            [(ROBOT_START, robot_radius)] + [(p, radius) for p in starts],
                            radius, "start"))
        goals.append(_draw(side(-sign),
                           [(ROBOT_GOAL, robot_radius)] + [(p, radius) for p in goals],
                           radius, "goal"))
    return np.array(starts).reshape(-1, 2), np.array(goals).reshape(-1, 2)


class OrcaCrowd:
    """Humans walking to their goals with ORCA, stepped on demand (see the module docstring).

    The loop asks for the humans at times ``k * dt`` in increasing order (through
    :meth:`members`); the crowd steps forward to the time asked, keeping every state, so a time
    already passed is answered from the history. With ``visible`` the robot's state last
    reported by :meth:`observe_robot` (at the time the robot planned) is an ORCA agent.
    """

    def __init__(self, starts, goals, *, dt=TIME_STEP, visible=False, robot_radius=0.3,
                 radius=HUMAN_RADIUS, v_pref=HUMAN_SPEED):
        self.goals = np.asarray(goals, dtype=float).reshape(-1, 2)
        self.n = len(self.goals)
        self.dt, self.visible, self.radius, self.v_pref = float(dt), bool(visible), radius, v_pref
        self.robot_radius = float(robot_radius)
        self.positions = [np.asarray(starts, dtype=float).reshape(-1, 2).copy()]
        self.velocities = [np.zeros((self.n, 2))]
        self.robot = None                         # (position (2,), velocity (2,)) last reported
        pyrvo = require_pyrvo()
        self.sim = pyrvo.RVOSimulator()
        self.sim.set_time_step(self.dt)
        for _ in range(self.n + (1 if self.visible else 0)):
            self.sim.add_agent((0.0, 0.0), ORCA_NEIGHBOR_DIST, ORCA_MAX_NEIGHBORS,
                               ORCA_TIME_HORIZON, ORCA_TIME_HORIZON_OBST,
                               radius + ORCA_RADIUS_PAD, v_pref, (0.0, 0.0))

    def observe_robot(self, state: RobotState) -> None:
        """The robot's state now (what visible humans react to in the next step)."""
        self.robot = (np.array([state.x, state.y]),
                      state.v * np.array([math.cos(state.phi), math.sin(state.phi)]))

    def preferred_velocities(self, positions) -> np.ndarray:
        """Toward each goal, the offset capped at ``v_pref`` (CrowdNav's ORCA), m/s."""
        offset = self.goals - positions
        norm = np.linalg.norm(offset, axis=1, keepdims=True)
        return offset * np.minimum(1.0, self.v_pref / np.maximum(norm, 1e-12))

    def _step(self) -> None:
        pos, vel = self.positions[-1], self.velocities[-1]
        preferred = self.preferred_velocities(pos)
        for i in range(self.n):
            self.sim.set_agent_position(i, tuple(pos[i]))
            self.sim.set_agent_velocity(i, tuple(vel[i]))
            self.sim.set_agent_pref_velocity(i, tuple(preferred[i]))
        if self.visible:
            where, velocity = self.robot if self.robot is not None else (
                np.array([1e6, 1e6]), np.zeros(2))
            self.sim.set_agent_position(self.n, tuple(where))
            self.sim.set_agent_velocity(self.n, tuple(velocity))
            self.sim.set_agent_pref_velocity(self.n, tuple(velocity))
            self.sim.set_agent_radius(self.n, self.robot_radius + ORCA_RADIUS_PAD)
            self.sim.set_agent_max_speed(self.n, max(float(np.hypot(*velocity)), 1e-3))
        self.sim.do_step()
        new = np.array([[v.x, v.y] for v in map(self.sim.get_agent_velocity, range(self.n))])
        self.velocities.append(new.reshape(-1, 2))
        self.positions.append(pos + new.reshape(-1, 2) * self.dt)

    def at(self, t: float) -> tuple:
        """``(positions (n, 2), velocities (n, 2))`` at time ``t`` (a multiple of ``dt``)."""
        k = int(round(t / self.dt))
        if k < 0 or abs(k * self.dt - t) > 1e-6:
            raise ValueError(f"OrcaCrowd: t = {t}: must be a multiple of dt = {self.dt} >= 0")
        while len(self.positions) <= k:
            self._step()
        return self.positions[k], self.velocities[k]

    def members(self) -> tuple:
        """One pedestrian-like view per human, for :class:`~dsmpepc_nlp.sim.types.Scenario`."""
        return tuple(CrowdHuman(self, i) for i in range(self.n))


@dataclass(frozen=True)
class CrowdHuman:
    """Human ``index`` of an :class:`OrcaCrowd`, answering like a scripted Pedestrian."""

    crowd: OrcaCrowd
    index: int

    @property
    def radius(self) -> float:
        return self.crowd.radius

    def position(self, t: float) -> np.ndarray:
        return self.crowd.at(t)[0][self.index].copy()

    def velocity_at(self, t: float) -> np.ndarray:
        return self.crowd.at(t)[1][self.index].copy()


class ObservedPlanner:
    """A planner that first reports the robot's state to the crowd (the visible setting)."""

    def __init__(self, planner, crowd: OrcaCrowd):
        self.planner, self.crowd = planner, crowd
        self.config = planner.config

    def reset(self) -> None:
        self.planner.reset()

    def prepare(self, **kwargs):
        """The wrapped planner's ``prepare`` (compile ahead), where it has one."""
        prepare = getattr(self.planner, "prepare", None)
        return prepare(**kwargs) if prepare is not None else None

    def plan(self, state, world, goal, **kwargs):
        self.crowd.observe_robot(state)
        return self.planner.plan(state, world, goal, **kwargs)


@dataclass(frozen=True)
class CrowdNavSettings:
    """What a CrowdNav benchmark depends on besides variant and episode (stored with results)."""

    scene: str = "circle"
    setting: str = "invisible"
    humans: int = N_HUMANS
    solver: str = "nlp"
    n_samples: int | None = None
    duration: float = DURATION
    preset: str = "product"
    """The planners' configuration: ``product`` or ``paper`` (``orca`` and ``cv`` ignore it)."""
    overrides: tuple = ()
    """``(name, value)`` pairs replacing fields of the preset (``--set``)."""
    sensing: str = "oracle"
    """``--sensing``: a profile's name or file (:mod:`dsmpepc_nlp.sim.sensing`)."""
    time_budget: float | str | None = "auto"    # --time-budget: SolverConfig.time_budget

    def __post_init__(self):
        if self.scene not in SCENES:
            raise InputError(f"--scene {self.scene!r}: must be one of {', '.join(SCENES)}")
        if self.setting not in SETTINGS:
            raise InputError(f"--robot {self.setting!r}: must be one of {', '.join(SETTINGS)}")

    def meta(self) -> dict:
        return {"benchmark": "crowdnav", "scene": self.scene, "setting": self.setting,
                "humans": self.humans, "solver": self.solver, "n_samples": self.n_samples,
                "duration": self.duration, "time_step": TIME_STEP,
                **config_meta(self.preset, self.overrides, self.sensing, self.time_budget)}


def episode_scenario(settings: CrowdNavSettings, episode: int, seed: int, robot=None):
    """Episode ``episode`` of the seeded set (the same for every variant): the scenario, its
    crowd and the humans' starts and goals."""
    robot = robot or robot_with(RobotConfig(), settings.overrides)
    rng = case_rng(seed, episode)
    draw = circle_crossing if settings.scene == "circle" else square_crossing
    starts, goals = draw(rng, settings.humans, robot.bounding_radius)
    crowd = OrcaCrowd(starts, goals, visible=settings.setting == "visible",
                      robot_radius=robot.bounding_radius)
    agent = Agent("robot", RobotState(*ROBOT_START, math.pi / 2),
                  FixedGoal(ROBOT_GOAL, SUCCESS_RADIUS), robot=robot)
    scenario = Scenario(name=f"crowdnav-{settings.scene}-{settings.setting}-{seed}-{episode}",
                        agents=(agent,), pedestrians=crowd.members(),
                        duration=float(settings.duration),
                        description=f"CrowdNav {settings.scene} crossing, robot "
                                    f"{settings.setting}")
    return scenario, crowd, starts, goals


def simulate_episode(settings: CrowdNavSettings, variant: str, episode: int, seed: int,
                     **kwargs) -> tuple:
    """Run episode ``episode`` with ``variant`` (``orca``, ``cv`` included):
    ``(Episode, OrcaCrowd)``.

    The robot plans with the method's 0.2 s horizon and the loop runs at ``TIME_STEP`` (module
    docstring); every plan first reports the robot's state to the crowd. ``kwargs`` go to
    :func:`~dsmpepc_nlp.sim.simulate.simulate`.
    """
    scenario, crowd, _, _ = episode_scenario(settings, episode, seed)
    if variant in CROWD_BASELINES:
        config, make = PlannerConfig(), BASELINES[variant]
        solver = SolverConfig.sampling(n_samples=1)
    else:
        config, make = planner_config(settings, variant), Planner
        solver = solver_of(settings)

    def factory(loop_config, solver_config):
        planning = dataclasses.replace(loop_config, horizon=config.horizon)
        return ObservedPlanner(make(planning, solver_config), crowd)

    loop_config = dataclasses.replace(
        config, horizon=dataclasses.replace(config.horizon, dt=TIME_STEP))
    kwargs.setdefault("sensing", settings.sensing)
    log = simulate(scenario, loop_config, solver, np.random.default_rng([seed, episode]),
                   planner_factory=factory, outcomes=OutcomeConfig(deadlock=False), **kwargs)
    # The episode's configuration is the one its planner planned with: the method's 0.2 s
    # steps (the loop's 0.25 s is the episode's ``dt``) and the robot that drove. What re-costs
    # a logged cycle and the escape search (accel_limit * plan step a step) read it.
    planned = dataclasses.replace(config, robot=scenario.agents[0].robot)
    log = dataclasses.replace(log, meta={**log.meta, "config": config_to_dict(planned)})
    return with_swept_contact(log), crowd


def with_swept_contact(log):
    """``log`` with the robot's outcome turned into a collision when it touched a human
    between two states before (or at) its outcome (CrowdNav checks contact over the step)."""
    t = swept_contact_time(log, 0)
    if math.isnan(t) or (log.outcomes[0] == "collision" and log.outcome_times[0] <= t):
        return log
    return dataclasses.replace(log, outcomes=["collision"], outcome_times=[t])


def run_episode(settings: CrowdNavSettings, variant: str, episode: int, seed: int,
                out_dir=None) -> dict:
    """One CrowdNav episode with one planner variant (``orca``, ``cv`` included); the row."""
    row = {"episode": int(episode), "seed": int(seed), "variant": variant,
           "scene": settings.scene, "setting": settings.setting}
    return measured_row(row, lambda: simulate_episode(settings, variant, episode, seed,
                                                      record_trajectories=False)[0],
                        keep=(out_dir, f"crowdnav-{settings.scene}-{settings.setting}-"
                                       f"{variant}-{seed}-{episode}"))


def run_benchmark(settings: CrowdNavSettings, variants, episodes: int, seed: int, out_dir, *,
                  workers=None, scheduler=None, resume=False, overwrite=False,
                  progress=True) -> dict:
    """Every (variant, episode) into ``out_dir/crowdnav.{json,csv}``; the summary.

    The first variant's figures are at the top level, every variant's under ``variants``
    (:func:`~dsmpepc_nlp.bench.crowd_rows.summarise`: success, at-fault and struck collisions,
    timeout, deadlock, time, SPL, distances, discomfort, jerk, plan time).
    """
    check_variants(variants, CROWD_BASELINES)
    require_pyrvo()  # the humans are ORCA agents whatever the robot
    table = ResultTable(out_dir, "crowdnav", ("variant", "episode", "seed"), settings.meta(),
                        resume=resume, overwrite=overwrite)
    per_variant = run_variants(run_episode, settings, variants, episodes, seed, table,
                               label=f"crowdnav {settings.scene} {settings.setting}",
                               workers=workers, scheduler=scheduler, progress=progress)
    summary = dict(per_variant[variants[0]])
    summary.update(scene=settings.scene, setting=settings.setting, solver=settings.solver,
                   seed=seed, variants=per_variant, out=str(Path(out_dir) / "crowdnav.csv"))
    return summary
