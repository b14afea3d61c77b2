"""Run an IR-SIM world to its end with the planner driving its robot, under IR-SIM's own
judgement: the robot's ``arrive`` flag (success) and ``collision`` flag (collision), checked
after every IR-SIM step, and ``env.done()``; a time limit (timeout) ends the rest.

The time limit is the world file's ``custom: {max_time: SECONDS}`` (IR-SIM hands the ``custom``
block over untouched), else :data:`DEFAULT_MAX_TIME`; ``max_time`` overrides both.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from ..core.config import PlannerConfig
from ..core.errors import InputError, positive_number
from ..core.jsonio import json_clean
from ..core.progress import EpisodeProgress
from ..core.solver_config import SolverConfig
from ..solve.planner import Planner
from .adapter import IrsimAdapter
from .episode import episode_of
from .loading import load_env, quiet
from .record import EpisodeLog

DEFAULT_MAX_TIME = 60.0
"""Simulated seconds before a run that has neither arrived nor collided times out (our
choice, when the world file has no ``custom.max_time``)."""


def time_limit(env, max_time=None) -> float:
    """``max_time``, else the world's ``custom.max_time``, else :data:`DEFAULT_MAX_TIME`, s."""
    if max_time is not None:
        return positive_number("max_time", max_time)
    custom = env.config.get("custom") or {}
    if isinstance(custom, dict) and "max_time" in custom:
        return positive_number("custom.max_time", custom["max_time"])
    return DEFAULT_MAX_TIME


def judge(env, robot, t: float, limit: float):
    """The outcome after a step, or None while the run goes on."""
    if robot.arrive:
        return "success"
    if robot.collision:
        return "collision"
    if env.done():                 # IR-SIM stops a robot only on a collision
        return "collision"
    if t >= limit - 1e-9:
        return "timeout"
    return None


def drive(env, adapter, planner, log: EpisodeLog, limit: float, *, frames=False,
          progress=None) -> None:
    """Plan and step until the outcome; ``log`` gets every step and plan, and the outcome."""
    steps = log.steps_per_plan
    n_cycles = max(1, int(math.ceil(limit / (steps * adapter.step_time) - 1e-9)))
    for cycle in range(n_cycles + 1):
        state, world = adapter.observe()
        plan = planner.plan(state, world, adapter.goal, goal_tolerance=adapter.goal_tolerance)
        log.planned(plan)
        action, outcome = adapter.action(plan), None
        for _ in range(steps):
            env.step(action)
            log.record()
            outcome = judge(env, adapter.robot, float(env.time), limit)
            if outcome is not None:
                break
        if frames:
            quiet(env.render)
        if progress is not None:
            progress(cycle, float(env.time), n_cycles, 0 if outcome else 1)
        if outcome is not None:
            log.finish(outcome, float(env.time))
            return
    log.finish("timeout", float(env.time))


def run_world(path, *, sensing: str = "oracle", variant: str = "ds-mpepc",
              solver: str = "sampling", seed: int = 0, out=None, gif: bool = False,
              max_time=None, resolution: float | None = None, save: bool = True,
              episode: bool = False, progress: bool = True, time_budget="auto") -> dict:
    """Run the IR-SIM world file ``path`` once; return the summary ``dsmpepc run --json``
    prints: scenario, variant, solver, seed, sensing, outcomes, metrics, wall_time, files.

    ``seed`` seeds IR-SIM's generator (its random placements, motion and sensor noise) and the
    detection noise of ``tracked``. With ``save`` the log goes to ``out/STEM.npz``; with ``gif``
    IR-SIM's animation (a frame a plan) to ``out/STEM.gif``. With ``episode`` the summary also
    holds ``_episode``, the run as the product's Episode (:func:`~.episode.episode_of`), and
    ``_custom``, the world file's ``custom`` block; ``progress`` False keeps the progress line
    off stderr (a benchmark shows its own bar). ``time_budget``: each plan's
    (``SolverConfig.time_budget``).
    """
    path = Path(path)
    out = Path(out if out is not None else "out")
    config = PlannerConfig.variant(variant)
    solver_config = SolverConfig.named(solver).replace(time_budget=time_budget)
    stem = f"{path.stem}-{variant}-{solver}-{sensing}-seed{seed}"
    env = load_env(path, seed=seed, frames=gif, out=out)
    if gif or save:
        out.mkdir(parents=True, exist_ok=True)
    try:
        options = {} if resolution is None else {"resolution": resolution}
        adapter = IrsimAdapter(env, sensing, seed=seed, **options)
        config = adapter.planner_config(config)
        planner = Planner(config, solver_config)
        log = EpisodeLog(adapter, adapter.steps_for(config))
        limit = time_limit(env, max_time)
        shown = EpisodeProgress(f"{path.stem} {variant} {solver} {sensing}") if progress \
            else None
        started = time.perf_counter()
        # Compile ahead, as the simulator does: no cycle plans on a fallback while it compiles.
        planner.prepare(max_objects=len(adapter.moving_objects()))
        drive(env, adapter, planner, log, limit, frames=gif, progress=shown)
        wall = time.perf_counter() - started
        if shown is not None:
            shown.done(log.outcome)
        files = {"episode": log.save(out / f"{stem}.npz")} if save else {}
        goal = adapter.goal
        extra = {} if not episode else {
            "_episode": episode_of(log, config, {
                "scenario": path.stem, "solver": solver, "seed": seed, "duration": limit,
                "irsim_sensing": sensing}),
            "_custom": _custom(env)}
    finally:
        quiet(_end, env, gif, stem)
    if gif:
        animation = out / f"{stem}.gif"
        if not animation.is_file():
            raise InputError(f"{path}: IR-SIM wrote no animation to {animation}")
        files["animation"] = str(animation)
    return {"scenario": path.stem, "variant": variant, "solver": solver, "seed": seed,
            "sensing": sensing, "outcomes": [log.outcome],
            "metrics": json_clean([log.metrics(goal)]), "wall_time": wall, "files": files,
            **extra}


def _custom(env) -> dict:
    """The world file's ``custom`` block (IR-SIM hands it over untouched), {} without one."""
    custom = env.config.get("custom")
    return dict(custom) if isinstance(custom, dict) else {}


def _end(env, gif: bool, stem: str) -> None:
    """Close the environment (its log sinks, its figure); write the animation with ``gif``."""
    if gif:
        env.end(ending_time=0.0, ani_name=stem, suffix=".gif")
    else:
        env.end(ending_time=0.0)
