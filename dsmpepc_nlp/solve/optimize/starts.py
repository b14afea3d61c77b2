"""Where the search over z starts: the box, the named starts of docs/method.md section 6.3, and
low-discrepancy samples of the box (scrambled Sobol points, the defaults shipped with the
package)."""

from __future__ import annotations

import functools
import math
import os
from pathlib import Path

import numpy as np

from ...core.compile_cache import cache_dir
from ...core.config import PlannerConfig, RobotState
from ...core.control_law import wrap, z_from_target
from ...core.solver_config import SolverConfig


def clip_to_bounds(z, config: PlannerConfig) -> np.ndarray:
    """z clipped into the box of ``config``; works on (4,) and (n, 4)."""
    return np.clip(np.asarray(z, dtype=float), config.z_lower, config.z_upper)


def stop_z(config: PlannerConfig) -> np.ndarray:
    """The stop trajectory's z (4,): ``v_max`` = 0 toward a target 1 m straight ahead, in the
    box. The law then brakes within the robot's limits and holds still: the planner's plan
    when nothing finite is found, and the last resort's way to be still (:mod:`.passive`)."""
    return clip_to_bounds(np.array([1.0, 0.0, 0.0, 0.0]), config)


def structured_starts(state: RobotState, goal, config: PlannerConfig,
                      previous_target=None, solver: SolverConfig | None = None) -> dict:
    """The named starts of docs/method.md section 6.3, each a z of shape (4,) inside the box.

    ``warm`` (last plan's target re-expressed in the robot's new frame, when given), ``stop``,
    ``goal`` (target on the goal, facing along the line of sight), soft and hard turns both ways
    (their shapes: ``solver.multistart``'s ``soft_turn``, ``hard_turn`` and ``turn_distance``).
    """
    solver = SolverConfig() if solver is None else solver
    shapes = solver.multistart
    soft, hard, distance_r = shapes.soft_turn, shapes.hard_turn, shapes.turn_distance
    v_limit = config.robot.v_limit
    starts = {}
    if previous_target is not None:
        target, v_max = previous_target
        z = np.array(z_from_target(target, v_max, state.pose), dtype=float)
        if np.all(np.isfinite(z)):
            starts["warm"] = z
    dx, dy = goal[0] - state.x, goal[1] - state.y
    distance = math.hypot(dx, dy)
    los = math.atan2(dy, dx) if distance > 0 else state.phi
    starts["stop"] = np.array([distance_r, 0.0, 0.0, 0.0])
    starts["goal"] = np.array([distance, 0.0, float(wrap(state.phi - los)), v_limit])
    for name, delta in (("soft-left", -soft), ("soft-right", soft),
                        ("hard-left", -hard), ("hard-right", hard)):
        # delta = phi - los: a negative delta puts the target to the robot's left.
        starts[name] = np.array([distance_r, 0.0, delta, v_limit])
    return {name: clip_to_bounds(z, config) for name, z in starts.items()}


SHIPPED_SOBOL = Path(__file__).with_name("sobol4.npy")
"""The first 4096 points of the sequences of seeds 0 and 1, shipped
(``tools/dev/make_sobol.py``)."""
SHIPPED_SOBOL_SCIPY = "1.17.1"
"""The scipy that drew them (another version may scramble differently; the shipped points
stay the package's)."""


@functools.lru_cache(maxsize=16)
def _unit_sobol(count: int, seed: int) -> np.ndarray:
    """``count`` points of the scrambled Sobol sequence of ``seed`` in the unit 4-cube.

    Seeds 0 and 1 up to 4096 points (every default) are read from the package's
    :data:`SHIPPED_SOBOL`: scipy's ``qmc`` module comes with the whole of ``scipy.stats``,
    ~0.35 s of imports that a robot's first plan would pay. Others are drawn once and kept in
    the cache (``sobol`` entries, a few kB each).
    """
    if seed in (0, 1) and count <= 4096:
        try:
            return np.load(SHIPPED_SOBOL)[seed, :count].copy()
        except (OSError, ValueError):
            pass
    path = cache_dir("sobol") / f"sobol4-{count}-{seed}-scipy{_scipy_version()}.npy"
    try:
        unit = np.load(path)
        if unit.shape == (count, 4):
            return unit
    except (OSError, ValueError):
        pass
    from scipy.stats import qmc

    unit = qmc.Sobol(d=4, scramble=True, rng=np.random.default_rng(seed)).random(count)
    try:
        temporary = path.with_name(f"{path.stem}.{os.getpid()}.tmp.npy")
        np.save(temporary, unit)
        os.replace(temporary, path)
    except OSError:
        pass
    return unit


@functools.cache
def _scipy_version() -> str:
    from importlib import metadata

    try:
        return metadata.version("scipy")
    except metadata.PackageNotFoundError:
        return "unknown"


def box_samples(config: PlannerConfig, count: int, seed: int) -> np.ndarray:
    """``count`` z spread over the box by a scrambled Sobol sequence, shape (count, 4).

    The egocentric z needs no re-drawing per cycle: one set serves every plan.
    """
    if count == 0:
        return np.zeros((0, 4))
    unit = _unit_sobol(count, seed)
    lower, upper = np.array(config.z_lower), np.array(config.z_upper)
    return lower + unit * (upper - lower)
