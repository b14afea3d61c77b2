"""ETH/UCY pedestrian recordings as crowd-crossing scenarios, and the crowd benchmark.

File format (the FORMAT.md beside the ETH/UCY data): tab-separated ``frame ped_id x y``, all
written as floats, metres, one annotation step every 10 frames = 0.4 s.

A scenario is a time window of a recording. The pedestrians whose tracks overlap the window are
replayed from their timestamped waypoints (linear interpolation, they do not react). Before a
track starts and after it ends the pedestrian is parked far away (``OFFSTAGE``); the jump there
happens within ``JUMP`` seconds placed half a cycle away from every simulation time, so no cycle
ever sees it. The robot crosses from a start to a goal drawn, seeded, from the positions the
pedestrians walked in the window (where the crowd is dense), ``min_distance`` to
``max_distance`` apart, the start at least ``start_clearance`` (gap) from every pedestrian over
the first second.

eth (``biwi_eth``): its median walking speed at 0.4 s per step is 2.45 m/s, twice any other
scene (FORMAT.md). We rescale time: eth steps are taken as 0.8 s, which gives 1.23 m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.config import PlannerConfig, RobotConfig, RobotState
from ..core.errors import InputError
from ..core.solver_config import SolverConfig
from ..sim.simulate import simulate
from ..sim.types import Agent, FixedGoal, Pedestrian, Scenario
from .crowd_rows import (
    OFFSTAGE,
    contact_age,
    footprint_core,
    goal_covered,
    measured_row,
    run_variants,
)
from .cv import CROWD_BASELINES, ConstantVelocityPlanner
from .orca import check_variants, simulate_orca
from .params import config_meta, planner_config, robot_with, solver_of
from .results import ResultTable

FRAMES_PER_STEP = 10
"""Frame ids advance by this much per annotation step."""
STEP_TIME = 0.4
"""Seconds per annotation step (2.5 Hz)."""
STEP_TIME_OVERRIDES = {"biwi_eth": 0.8}
"""Recordings whose step is rescaled (FORMAT.md's caveat on eth's speed), s."""
JUMP = 0.01
"""Time taken by the jump between the stage and ``OFFSTAGE``, s."""
PEDESTRIAN_RADIUS = 0.3
"""Pedestrian body radius, m (CrowdNav's)."""
DEFAULT_DURATION = 30.0
"""Episode length, s."""
SCENES = ("eth", "hotel", "univ", "zara1", "zara2")
"""Scene folders of the standard split."""


@dataclass(frozen=True)
class Recording:
    """One annotated recording: rows sorted by frame.

    ``frame`` (n,) int, ``ped`` (n,) int, ``xy`` (n, 2) m; ``step_time`` s per 10 frames.
    """

    name: str
    frame: np.ndarray
    ped: np.ndarray
    xy: np.ndarray
    step_time: float = STEP_TIME

    def time(self, frame) -> np.ndarray:
        """Seconds since frame 0."""
        return np.asarray(frame, dtype=float) / FRAMES_PER_STEP * self.step_time

    @property
    def span(self) -> tuple:
        """(first, last) annotated time, s."""
        return float(self.time(self.frame.min())), float(self.time(self.frame.max()))

    def median_speed(self) -> float:
        """Median step displacement over the step time, m/s."""
        speeds = []
        for pid in np.unique(self.ped):
            sel = self.ped == pid
            if sel.sum() > 1:
                speeds.append(np.linalg.norm(np.diff(self.xy[sel], axis=0), axis=1))
        return float(np.median(np.concatenate(speeds)) / self.step_time) if speeds else 0.0


def load_recording(path, step_time: float | None = None) -> Recording:
    """Read one ETH/UCY text file; ValueError naming the file and line on bad content."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"ETH/UCY file {str(path)!r}: does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"ETH/UCY file {str(path)!r}: cannot read ({exc})") from None
    rows = []
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        parts = line.split("\t") if "\t" in line else line.split()
        try:
            values = [float(p) for p in parts]
        except ValueError:
            values = []
        if len(values) != 4 or not all(math.isfinite(v) for v in values):
            raise InputError(f"ETH/UCY file {str(path)!r}, line {number}: {line.strip()!r}: "
                             "expected 4 tab-separated numbers 'frame ped_id x y'")
        rows.append(values)
    if not rows:
        raise InputError(f"ETH/UCY file {str(path)!r}: no rows")
    data = np.array(rows)
    order = np.lexsort((data[:, 1], data[:, 0]))
    data = data[order]
    frame, ped = data[:, 0].astype(np.int64), data[:, 1].astype(np.int64)
    if np.any((np.diff(frame) == 0) & (np.diff(ped) == 0)):
        raise InputError(f"ETH/UCY file {str(path)!r}: duplicate (frame, ped_id) rows")
    if step_time is None:
        step_time = STEP_TIME_OVERRIDES.get(path.stem.removesuffix("_train")
                                            .removesuffix("_val"), STEP_TIME)
    return Recording(path.stem, frame, ped, data[:, 2:4].copy(), float(step_time))


def scene_files(data_dir, scene: str) -> list:
    """Recordings of ``scene`` (``data_dir/scene/test/*.txt``) or ``scene`` itself as a file."""
    candidate = Path(scene)
    if candidate.suffix == ".txt" and candidate.is_file():
        return [candidate]
    folder = Path(data_dir) / scene / "test"
    files = sorted(folder.glob("*.txt"))
    if not files:
        raise InputError(f"scene {scene!r}: no recordings in {str(folder)!r} "
                         f"(scenes: {', '.join(SCENES)}, or a .txt file)")
    return files


def _tracks(recording: Recording, t0: float, t1: float, offset: float) -> list:
    """Pedestrians overlapping [t0, t1] as Pedestrian objects, times relative to t0 + offset."""
    times = recording.time(recording.frame)
    out = []
    for pid in np.unique(recording.ped):
        sel = recording.ped == pid
        t, xy = times[sel], recording.xy[sel]
        if t[-1] < t0 or t[0] > t1:
            continue
        rel = np.round(t - t0 + offset, 9)
        waypoints_t, waypoints_xy = [rel], [xy]
        if rel[0] > 0:
            waypoints_t.insert(0, [rel[0] - JUMP])
            waypoints_xy.insert(0, [OFFSTAGE])
        waypoints_t.append([rel[-1] + JUMP])
        waypoints_xy.append([OFFSTAGE])
        tt = np.concatenate(waypoints_t)
        pp = np.concatenate(waypoints_xy)
        if tt.size == 2 and rel.size == 1 and rel[0] <= 0:  # a single point, gone already
            continue
        out.append(Pedestrian(tt, pp, radius=PEDESTRIAN_RADIUS))
    return out


def _occupied(peds, point, start: float, end: float, dt: float, distance: float) -> bool:
    """Whether a pedestrian comes nearer than ``distance`` (centre to centre) to ``point`` at
    the simulation's times ``start, start + dt, ... <= end``, s."""
    near = _positions(peds, np.arange(max(start, 0.0), end + 1e-9, dt))
    return bool(near.size) and float(np.min(np.linalg.norm(near - point, axis=-1))) < distance


def _positions(peds, times) -> np.ndarray:
    """Every pedestrian's position at each of ``times``, m, shape (len(times), len(peds), 2)."""
    return np.array([[p.position(t) for p in peds] for t in times]).reshape(len(times), -1, 2)


def goal_free_at(peds, start, goal, tolerance: float, core: float, v_limit: float,
                 duration: float, dt: float) -> float | None:
    """The first simulation time (s) at which a robot could stand at ``goal``, or None.

    A robot arrives no sooner than ``(|goal - start| - tolerance) / v_limit`` (straight at its
    speed limit; the replays have no map), and only at a time when some point within
    ``tolerance`` of the goal is clear of every pedestrian's body by the footprint's ``core``
    (:func:`~dsmpepc_nlp.bench.crowd_rows.footprint_core`; the test is
    :func:`~dsmpepc_nlp.bench.crowd_rows.goal_covered`, the classifier's ``goal-occupied``
    one). None when no such time comes by ``duration`` (the goal covered from the earliest
    arrival to the end, or that arrival later than the end): no planner can win the run.
    """
    earliest = max(0.0, (float(np.hypot(goal[0] - start[0], goal[1] - start[1])) - tolerance)
                   / v_limit)
    times = np.arange(0.0, duration + 1e-9, dt)
    times = times[times >= earliest - 1e-9]
    if not peds:
        return float(times[0]) if times.size else None
    radii = np.array([p.radius for p in peds])
    d = np.linalg.norm(_positions(peds, times) - np.asarray(goal, dtype=float), axis=-1)
    free = ~goal_covered(d, radii, tolerance, core)
    return float(times[np.argmax(free)]) if free.any() else None


def crossing_scenario(recording: Recording, rng: np.random.Generator, *,
                      duration=DEFAULT_DURATION, robot=None, dt=0.2, min_distance=4.0,
                      max_distance=8.0, start_clearance=0.5, goal_tolerance=0.3,
                      min_pedestrians=3, tries=200, name=None, goal_clear=False):
    """A seeded window of ``recording`` with a robot crossing where pedestrians walk.

    Parameters
    ----------
    recording : Recording
    rng : numpy.random.Generator
        Draws the window start, the start and the goal.
    duration : float
        Window and episode length, s.
    robot : RobotConfig, optional
        The robot (default ``RobotConfig()``); its bounding radius sets the start clearance.
    dt : float
        Simulation step, s: the window starts on the annotation grid and pedestrian times are
        shifted by ``dt / 2``, so that no cycle falls on a jump to or from ``OFFSTAGE`` (the
        step, 0.4 or 0.8 s, is a multiple of ``dt``).
    min_distance, max_distance : float
        Start-goal distance range, m.
    start_clearance : float
        Smallest gap between the robot at its start and any pedestrian over the first second, m.
    goal_tolerance : float
        Success radius, m.
    min_pedestrians : int
        Windows with fewer distinct pedestrians are redrawn.
    goal_clear : bool
        Also keep the goal ``start_clearance`` from every pedestrian over the window's last
        second (as the start over its first). Off by default: the goal is a position a
        pedestrian took, and where people stand (a group talking) it can be one that someone
        occupies until the window ends, which no robot can reach ('goal-occupied' in
        ``dsmpepc failures``). The draws that pass the test are the same with it and without.

    Returns
    -------
    Scenario, and a dict describing the draw (window start, start, goal, pedestrians, and
    :func:`goal_free_at`: None where no planner can arrive).
    """
    robot = robot or RobotConfig()
    first, last = recording.span
    if last - first < duration:
        raise InputError(f"recording {recording.name!r}: spans {last - first:.1f} s, shorter "
                         f"than the {duration} s window")
    times = recording.time(recording.frame)
    radius = robot.bounding_radius
    for _ in range(tries):
        # On the annotation grid, so every waypoint time is a multiple of the step plus dt / 2
        # and no simulation time falls inside a jump to or from OFFSTAGE.
        t0 = first + recording.step_time * float(
            rng.integers(int((last - duration - first) / recording.step_time) + 1))
        inside = (times >= t0) & (times <= t0 + duration)
        if len(np.unique(recording.ped[inside])) < min_pedestrians:
            continue
        walked = recording.xy[inside]
        start_xy = walked[rng.integers(len(walked))]
        gaps = np.linalg.norm(walked - start_xy, axis=1)
        ok = (gaps >= min_distance) & (gaps <= max_distance)
        if not ok.any():
            continue
        goal_xy = walked[rng.choice(np.flatnonzero(ok))]
        start_xy = start_xy + rng.normal(0.0, 0.1, 2)
        peds = _tracks(recording, t0, t0 + duration, dt / 2)
        clear = radius + PEDESTRIAN_RADIUS + start_clearance
        if _occupied(peds, start_xy, 0.0, 1.0, dt, clear):              # the first second
            continue
        if goal_clear and _occupied(peds, goal_xy, duration - 1.0, duration, dt, clear):
            continue
        heading = math.atan2(goal_xy[1] - start_xy[1], goal_xy[0] - start_xy[0])
        agent = Agent("robot", RobotState(float(start_xy[0]), float(start_xy[1]), heading),
                      FixedGoal((float(goal_xy[0]), float(goal_xy[1])), goal_tolerance),
                      robot=robot)
        scenario = Scenario(name=name or f"{recording.name}@{t0:.1f}s", agents=(agent,),
                            pedestrians=tuple(peds), duration=float(duration),
                            description=f"ETH/UCY {recording.name} from {t0:.2f} s")
        draw = {"recording": recording.name, "window_start": t0,
                "start": [float(v) for v in start_xy], "goal": [float(v) for v in goal_xy],
                "pedestrians": len(peds),
                "goal_free_at": goal_free_at(peds, start_xy, goal_xy, goal_tolerance,
                                             footprint_core(robot.footprint), robot.v_limit,
                                             duration, dt)}
        return scenario, draw
    raise InputError(f"recording {recording.name!r}: no valid crossing in {tries} draws "
                     f"(need {min_pedestrians} pedestrians and a clear start)")


# ---------------------------------------------------------------------------------------------
# benchmark


@dataclass(frozen=True)
class CrowdSettings:
    """What a crowd benchmark depends on besides variant and episode (stored with results)."""

    data: str
    scene: str
    solver: str = "nlp"
    n_samples: int | None = None
    duration: float = DEFAULT_DURATION
    v_limit: float = 1.0
    preset: str = "product"
    """The planners' configuration: ``product`` or ``paper`` (``orca`` and ``cv`` ignore it)."""
    overrides: tuple = ()
    """``(name, value)`` pairs replacing fields of the preset (``--set``)."""
    goal_clear: bool = False
    """Redraw a goal a pedestrian occupies over the window's last second (``--goal-clear``;
    :func:`crossing_scenario`)."""
    sensing: str = "oracle"
    """``--sensing``: a profile's name or file (:mod:`dsmpepc_nlp.sim.sensing`)."""
    time_budget: float | str | None = "auto"
    """Each plan's time budget (``--time-budget``; ``SolverConfig.time_budget``)."""

    def meta(self) -> dict:
        meta = {"benchmark": "crowd", "scene": self.scene, "solver": self.solver,
                "n_samples": self.n_samples, "duration": self.duration,
                "v_limit": self.v_limit,
                **config_meta(self.preset, self.overrides, self.sensing, self.time_budget)}
        return dict(meta, goal_clear=True) if self.goal_clear else meta


def episode_scenario(settings: CrowdSettings, episode: int, seed: int):
    """Scenario number ``episode`` of the seeded set (the same for every variant)."""
    files = scene_files(settings.data, settings.scene)
    rng = np.random.default_rng([seed, episode])
    recording = load_recording(files[int(rng.integers(len(files)))])
    return crossing_scenario(recording, rng, duration=settings.duration,
                             robot=robot_with(RobotConfig(v_limit=settings.v_limit),
                                              settings.overrides),
                             name=f"{settings.scene}-{seed}-{episode}",
                             goal_clear=settings.goal_clear)


def simulate_episode(settings: CrowdSettings, variant: str, episode: int, seed: int,
                     **kwargs) -> tuple:
    """Run crossing ``episode`` with ``variant`` (``orca``, ``cv`` included): ``(Episode,
    draw)``, the draw being what :func:`crossing_scenario` drew (start, goal, window).
    ``kwargs`` go to the simulator."""
    scenario, draw = episode_scenario(settings, episode, seed)
    rng = np.random.default_rng([seed, episode])
    kwargs.setdefault("sensing", settings.sensing)
    if variant == "orca":
        return simulate_orca(scenario, PlannerConfig(), rng, **kwargs), draw
    if variant == "cv":
        return simulate(scenario, PlannerConfig(), SolverConfig.sampling(n_samples=1), rng,
                        planner_factory=ConstantVelocityPlanner, **kwargs), draw
    return simulate(scenario, planner_config(settings, variant),
                    solver_of(settings), rng, **kwargs), draw


def run_episode(settings: CrowdSettings, variant: str, episode: int, seed: int,
                out_dir=None) -> dict:
    """One crossing with one planner variant (``orca``, ``cv`` included); the result row."""
    row = {"episode": int(episode), "seed": int(seed), "variant": variant}

    def run():
        log, draw = simulate_episode(settings, variant, episode, seed, record_trajectories=False)
        row.update(draw)
        return log

    return measured_row(row, run, lambda episode: {"contact_age": contact_age(episode)},
                        keep=(out_dir, f"crowd-{settings.scene}-{variant}-{seed}-{episode}"))


def run_benchmark(settings: CrowdSettings, variants, episodes: int, seed: int, out_dir, *,
                  workers=None, scheduler=None, resume=False, overwrite=False,
                  progress=True) -> dict:
    """Every (variant, episode) into ``out_dir/crowd.{json,csv}``; the summary.

    The summary has the first variant's figures at the top level (``episodes``,
    ``success_rate``, ``collision_rate``, ...) and every variant under ``variants``.
    ``progress``: where the status line and bar go (True: stderr, a stream, or None: nowhere).
    """
    check_variants(variants, CROWD_BASELINES)
    scene_files(settings.data, settings.scene)  # fail early on a bad scene
    table = ResultTable(out_dir, "crowd", ("variant", "episode", "seed"), settings.meta(),
                        resume=resume, overwrite=overwrite)
    per_variant = run_variants(run_episode, settings, variants, episodes, seed, table,
                               label="crowd", workers=workers, scheduler=scheduler,
                               progress=progress)
    summary = dict(per_variant[variants[0]])
    summary.update(scene=settings.scene, seed=seed, variants=per_variant,
                   out=str(Path(out_dir) / "crowd.csv"))
    return summary


