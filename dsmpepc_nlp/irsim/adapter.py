"""The IR-SIM adapter: one IR-SIM diff robot driven by the planner.

From an IR-SIM environment (``irsim.make(...)``) it reads the robot's body and limits
(:func:`~.shapes.robot_config`), its goal and goal threshold, and each cycle's inputs: the
robot's state and a :class:`~dsmpepc_nlp.core.world.World` (:mod:`.inputs`). It turns a plan
into IR-SIM's action for a diff robot, ``np.array([[v], [omega]])``.

Usage (a loop of one's own; ``dsmpepc irsim WORLD.yaml`` runs one for you)::

    env = irsim.make("world.yaml", display=False)
    adapter = IrsimAdapter(env, sensing="oracle")
    planner = Planner(adapter.planner_config(PlannerConfig()), SolverConfig.sampling())
    while not env.done():
        state, world = adapter.observe()
        plan = planner.plan(state, world, adapter.goal, goal_tolerance=adapter.goal_tolerance)
        for _ in range(adapter.steps_per_plan):
            env.step(adapter.action(plan))

Velocities. The robot's (v, omega) is what IR-SIM's ``robot.velocity`` reports after its step:
the command as IR-SIM clipped it to ``vel_min``/``vel_max`` and the ``acce`` window, not a
measurement (IR-SIM's motion noise, when on, is not in it). A moving object's velocity is
measured: its position change over the last planning period (IR-SIM's own velocity before
the first).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.errors import InputError, shown
from ..core.world import World
from .inputs import LidarInput, TrackedInput, measured_velocity, oracle_grid
from .shapes import describe, moving_obstacle, pose_of, robot_config

SENSING = ("oracle", "lidar", "tracked")
"""What the planner is given: ``oracle`` (the truth: the exact map and every moving object),
``lidar`` (IR-SIM's lidar scan into a local map, no prior map; moving objects the truth),
``tracked`` (the exact map; people through a tracker from noisy positions)."""
RESOLUTION = 0.05
"""Cell side of the oracle map, m (the product's scenario maps and the local map use 0.05)."""


def _check_world(env, robot) -> None:
    """InputError for the settings the planner cannot serve."""
    if env.step_mode != "internal":
        raise InputError(f"world.step_mode={env.step_mode!r}: the adapter steps IR-SIM with "
                         "actions, which needs step_mode 'internal'")
    if getattr(robot, "arrive_mode", "position") != "position":
        raise InputError(f"{describe(robot)}: arrive_mode {robot.arrive_mode!r} asks for a "
                         "heading at the goal, which the planner does not aim for (use "
                         "arrive_mode: position)")


def _pick_robot(env, robot):
    robots = env.robot_list
    if not robots:
        raise InputError("the IR-SIM world has no robot for the planner to drive")
    if isinstance(robot, str):
        named = [r for r in robots if r.name == robot]
        if not named:
            raise InputError(f"robot={robot!r}: no such robot (the world has "
                             f"{', '.join(r.name for r in robots)})")
        return named[0]
    if isinstance(robot, bool) or not isinstance(robot, int) or not 0 <= robot < len(robots):
        raise InputError(f"robot={shown(robot)}: expected a robot index in "
                         f"[0, {len(robots) - 1}] or a robot's name")
    return robots[robot]


class IrsimAdapter:
    """The planner's view of one robot of an IR-SIM environment, and its actions.

    Parameters
    ----------
    env : irsim.env.EnvBase
        The environment (``irsim.make(...)``); its state is read, never changed.
    sensing : {"oracle", "lidar", "tracked"}
        See :data:`SENSING`. ``lidar`` needs a ``lidar2d`` sensor on the robot.
    robot : int or str
        Which robot the planner drives (index among IR-SIM's robots, or name); the others
        are moving obstacles.
    resolution : float
        Cell side of the exactly rasterised static map, m.
    seed : int, optional
        Seed of the detection noise (``tracked``).

    Raises
    ------
    InputError
        Naming the object the adapter cannot map: a robot that is not a diff robot, a shape
        it does not know, a lidar that is missing.
    """

    def __init__(self, env, sensing: str = "oracle", *, robot=0, resolution: float = RESOLUTION,
                 seed=None):
        if sensing not in SENSING:
            raise InputError(f"sensing={shown(sensing)}: expected one of {', '.join(SENSING)}")
        self.env, self.sensing = env, sensing
        self.robot = _pick_robot(env, robot)
        _check_world(env, self.robot)
        self.robot_config = robot_config(self.robot)
        self.static_grid = oracle_grid(env, resolution)
        self._static_world = World(self.static_grid)
        self._lidar = LidarInput(self.robot) if sensing == "lidar" else None
        self._tracked = TrackedInput(seed) if sensing == "tracked" else None
        self._previous: dict = {}
        self._cache = None
        self.moving_obstacles()               # every moving object can be mapped, or raise

    # -- the task ----------------------------------------------------------------------------

    @property
    def goal(self) -> np.ndarray:
        """The robot's current goal (x, y), m (IR-SIM's goal queue's head)."""
        goal = self.robot.goal
        if goal is None:
            raise InputError(f"{describe(self.robot)} has no goal")
        return np.asarray(goal, dtype=float).reshape(-1)[:2].copy()

    @property
    def goal_tolerance(self) -> float:
        """IR-SIM's ``goal_threshold``, m: it counts arrival when nearer than this."""
        return float(self.robot.goal_threshold)

    @property
    def step_time(self) -> float:
        """IR-SIM's step, s."""
        return float(self.env.step_time)

    def planner_config(self, config: PlannerConfig | None = None) -> PlannerConfig:
        """``config`` (default ``PlannerConfig()``) with this robot's body and limits, and its
        period ``horizon.dt`` made the multiple of IR-SIM's step nearest to it."""
        config = PlannerConfig() if config is None else config
        dt = self.steps_for(config) * self.step_time
        return dataclasses.replace(config, robot=self.robot_config,
                                   horizon=dataclasses.replace(config.horizon, dt=dt))

    def steps_for(self, config: PlannerConfig) -> int:
        """IR-SIM steps per planning period of ``config``: ``round(dt / step_time)``, >= 1."""
        return max(1, int(round(config.horizon.dt / self.step_time)))

    @property
    def steps_per_plan(self) -> int:
        """IR-SIM steps per plan under the default period (:meth:`steps_for` otherwise)."""
        return self.steps_for(PlannerConfig())

    # -- each cycle --------------------------------------------------------------------------

    def state(self) -> RobotState:
        """The robot now: pose from IR-SIM's state, (v, omega) from ``robot.velocity``."""
        x, y, phi = pose_of(self.robot)
        v, omega = np.asarray(self.robot.velocity, dtype=float).reshape(-1)[:2]
        return RobotState(float(x), float(y), float(phi), float(v), float(omega))

    def moving_objects(self) -> list:
        """IR-SIM's objects the planner sees as moving: every other robot, and every obstacle
        that is not static; ``unobstructed`` ones (nothing collides with them) left out."""
        return [obj for obj in self.env.objects
                if obj is not self.robot and not obj.unobstructed and obj.shape != "map"
                and (obj.role == "robot" or not obj.static)]

    def moving_obstacles(self) -> list:
        """Every moving object but the robot as the planner's DynamicObstacle (the truth),
        with its measured velocity; updates the positions the next measurement starts from."""
        t = float(self.env.time)
        if self._cache is not None and self._cache[0] == t:
            return list(self._cache[1])
        found, seen = [], {}
        for obj in self.moving_objects():
            xy = pose_of(obj)[:2]
            velocity = measured_velocity(self._previous.get(obj.id), (t, xy), obj.velocity_xy)
            found.append(moving_obstacle(obj, velocity))
            seen[obj.id] = (t, xy)
        self._previous, self._cache = seen, (t, found)
        return list(found)

    def observe(self) -> tuple[RobotState, World]:
        """``(state, world)`` for this cycle under the adapter's sensing."""
        t = float(self.env.time)
        truth = self.moving_obstacles()
        people = self._tracked.people(t, truth) if self._tracked is not None else truth
        if self._lidar is not None:
            return self.state(), World(self._lidar.grid(t, truth), people)
        return self.state(), self._static_world.with_obstacles(people)

    @staticmethod
    def action(plan) -> np.ndarray:
        """IR-SIM's diff-robot action ``[[v], [omega]]`` of a Plan (or a ``(v, omega)``)."""
        control = getattr(plan, "control", plan)
        v, omega = (float(c) for c in control)
        return np.array([[v], [omega]])
