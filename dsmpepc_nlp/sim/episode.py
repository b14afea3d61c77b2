"""A logged closed-loop run: every state, plan and outcome, saved to and loaded from NPZ."""

from __future__ import annotations

import dataclasses
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.errors import InputError
from ..core.files import atomic_write_bytes
from ..core.jsonio import json_clean
from ..core.terms import TERM_NAMES
from ..core.world import DynamicObstacle, OccupancyGrid, World
from ..solve.plan import STATUSES

EPISODE_FORMAT = 1
"""Version of the episode file layout."""


# ---------------------------------------------------------------------------------------------


_ARRAYS = (
    "times", "states", "active", "goals", "z", "cost_total", "cost_terms", "survivability",
    "ttg", "ttc_terminal", "status", "nit", "plan_time", "n_starts", "plan_poses",
    "ped_positions", "ped_velocities", "ped_radii", "grid_occupied", "grid_resolution",
    "grid_origin", "believed_states", "believed_occupied", "believed_people", "out_of_time",
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
        Index into ``statuses`` (records.STATUSES); -1 when inactive.
    nit, n_starts : ndarray of int, (R, K)
        NLP iterations summed over starts and number of starts.
    plan_time : ndarray, (R, K)
        Wall time of ``Planner.plan``, s.
    out_of_time : ndarray of bool, (R, K) or None
        The plan's time budget ran out (``Plan.cut`` not empty); None in logs written before
        it was recorded.
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
    believed_states : ndarray, (R, K, 5) or None
        Under a sensing profile (``meta["sensing"]``), the state each robot believed it was in
        when it planned (NaN when it did not); None when it was told the truth.
    believed_occupied : ndarray of bool, (R, ny, nx) or None
        Under a profile with a lidar, each robot's local map at the end of the run, its lower
        left corner at ``meta["believed_origin"][robot]`` and cells ``meta["believed_resolution"]``
        m wide (:meth:`believed_grid`).
    believed_people : ndarray, (R, K, M, 5) or None
        Under a sensing profile, the people each robot planned with at each cycle, as it
        believed them (a tracker's tracks, or the truth placed by its believed pose): rows
        ``[x, y, vx, vy, radius]`` (m, m/s; the radius as handed to the planner, a track's
        inflation included), NaN-padded to the most people of any cycle.
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
    believed_states: np.ndarray | None = None
    believed_occupied: np.ndarray | None = None
    believed_people: np.ndarray | None = None
    out_of_time: np.ndarray | None = None

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

    def believed_grid(self, robot: int) -> OccupancyGrid | None:
        """Robot ``robot``'s local map at the end of the run (None without a lidar)."""
        if self.believed_occupied is None:
            return None
        return OccupancyGrid(self.believed_occupied[robot], self.meta["believed_resolution"],
                             self.meta["believed_origin"][robot])

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
                obstacles.append(robot_obstacle(self.states[j, cycle], self.footprint(j)))
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
        buffer = io.BytesIO()
        np.savez_compressed(buffer, **arrays)
        return atomic_write_bytes(path, buffer.getvalue())

    @classmethod
    def load(cls, path) -> Episode:
        """Read an episode written by :meth:`save`; InputError for a file that is not one."""
        try:
            with np.load(path, allow_pickle=False) as data:
                content = {name: data[name] for name in data.files}
        except (OSError, ValueError) as exc:
            raise InputError(f"episode file {str(path)!r}: cannot read ({exc})") from None
        if "meta_json" not in content:
            raise InputError(f"episode file {str(path)!r}: no metadata: not an episode")
        meta = json.loads(str(content.pop("meta_json")))
        if meta.get("format") != EPISODE_FORMAT:
            raise InputError(f"episode file {str(path)!r}: format {meta.get('format')!r}: "
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


def robot_obstacle(state, footprint) -> DynamicObstacle:
    x, y, phi, v = (float(s) for s in state[:4])
    return DynamicObstacle.robot((x, y, phi), (v * math.cos(phi), v * math.sin(phi)), footprint)


def config_to_dict(config: PlannerConfig) -> dict:
    """A JSON-able dict of a planner configuration (inf written as the string ``"inf"``)."""
    return json_clean(dataclasses.asdict(config), nonfinite=str)


BEFORE_THEY_WERE = {"stall": {"doomed_below": 0.0, "min_progress": 0.0}}
"""Fields a saved configuration may lack, with the value that plans as the package did before
they existed (each now on by default): an episode saved then replays its own plans."""


REMOVED = {"stall": {"judge_beyond": (0.0,), "judge_level": None, "judge_sooner": (False,)},
           "cost": {"ttg_along_nf": (False,)}}
"""Fields a saved configuration may still hold though the package no longer has them, each with
the values that planned as the package does now (None: any value, a field that acted only with
another of them): such a field is dropped; another value cannot be replayed."""

REMOVED_PARTS = ("prediction",)
"""Parts a saved configuration may hold that the package no longer has, dropped whatever they
held: ``prediction`` held the standing map (``prediction.standing_map``, on by default until
2026-12-06), so an episode saved with it replays without it, and its plans may differ where a
person stood in a world without a map."""


def _without_removed(name: str, value: dict) -> dict:
    """``value`` (the saved ``name`` part) without the fields of :data:`REMOVED`; InputError
    for one whose value planned otherwise than the package can now."""
    removed = REMOVED.get(name, {})
    for key, off in removed.items():
        if key in value and off is not None and value[key] not in off:
            raise InputError(f"saved configuration: {name}.{key} = {value[key]!r} was "
                             f"removed from the package; only {off[0]!r} (off) can be replayed")
    return {k: v for k, v in value.items() if k not in removed}


def config_from_dict(data: dict) -> PlannerConfig:
    """Inverse of :func:`config_to_dict`; a field of :data:`BEFORE_THEY_WERE` it lacks is set
    to its value there, any other to today's default; a field of :data:`REMOVED` is dropped."""
    parts = {f.name: f.type for f in dataclasses.fields(PlannerConfig)}
    kinds = {name: type(getattr(PlannerConfig(), name)) for name in parts}
    values = {}
    for name, value in data.items():
        if name in REMOVED_PARTS:
            continue
        if name not in parts:
            raise InputError(f"config: {name}: unknown part of a planner configuration; "
                             f"expected one of {', '.join(sorted(parts))}")
        if isinstance(value, dict):
            value = {k: float(v) if isinstance(v, str) else v for k, v in value.items()}
            value = BEFORE_THEY_WERE.get(name, {}) | _without_removed(name, value)
            values[name] = kinds[name](**value)
        else:
            values[name] = value
    return PlannerConfig(**values)
