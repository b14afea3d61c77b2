"""Batched exact evaluation of many z and the sampling planner: the NLP's verifier and fallback."""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.control_law import Trajectory, rollout, wrap, z_from_target
from ..core.costs import CostBreakdown, evaluate
from ..core.solver_config import SolverConfig
from . import exact
from .cache import cache_dir
from .cycle import Cycle


def clip_to_bounds(z, config: PlannerConfig) -> np.ndarray:
    """z clipped into the box of ``config``; works on (4,) and (n, 4)."""
    return np.clip(np.asarray(z, dtype=float), config.z_lower, config.z_upper)


def structured_starts(state: RobotState, goal, config: PlannerConfig,
                      previous_target=None, solver: SolverConfig | None = None) -> dict:
    """The named starts of docs/method.md section 6.3, each a z of shape (4,) inside the box.

    ``warm`` (last plan's target re-expressed in the robot's new frame, when given), ``stop``,
    ``goal`` (target on the goal, facing along the line of sight), soft and hard turns both ways
    (their shapes: ``solver.soft_turn``, ``hard_turn`` and ``turn_distance``).
    """
    solver = SolverConfig() if solver is None else solver
    soft, hard, distance_r = solver.soft_turn, solver.hard_turn, solver.turn_distance
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
"""The first 4096 points of the sequences of seeds 0 and 1, shipped (``tools/make_sobol.py``)."""
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


@dataclass(frozen=True)
class Evaluation:
    """Exact rollouts and costs of a batch of z."""

    z: np.ndarray
    trajectories: Trajectory
    costs: CostBreakdown

    def best(self) -> int | None:
        """Index of the lowest finite exact cost, or None when nothing is finite."""
        total = np.where(np.isfinite(self.costs.total), self.costs.total, np.inf)
        if not np.any(np.isfinite(total)):
            return None
        return int(np.argmin(total))


def evaluate_batch(z, cycle: Cycle, compiled: bool | None = None,
                   pair_budget: int = SolverConfig.pair_budget,
                   parallel_rows: int = SolverConfig.parallel_rows) -> Evaluation:
    """Roll out and cost every row of ``z`` (n, 4) exactly.

    ``cycle`` (:class:`~dsmpepc_nlp.solve.cycle.Cycle`) carries the state, world, goal and
    configuration, prepared once per plan. ``compiled`` (default: when available) runs the
    compiled kernel (:mod:`~dsmpepc_nlp.solve.exact`) on the cycle's arrays; False runs the
    numpy reference in chunks of at most ``pair_budget`` (trajectory, pose, footprint circle,
    obstacle circle) tuples (:attr:`SolverConfig.pair_budget`); the compiled kernel uses every
    core from ``parallel_rows`` rows on (:attr:`SolverConfig.parallel_rows`). Both give the same
    :class:`Evaluation` (to 1e-9, held by tests).
    """
    z = np.atleast_2d(np.asarray(z, dtype=float))
    module = _compiled_for(z, cycle, compiled)
    if module is not None:
        trajectories, costs = exact.evaluate_compiled(z, cycle, module, parallel_rows)
        return Evaluation(z, trajectories, costs)
    return _evaluate_numpy(z, cycle, pair_budget)


def exact_totals(z, cycle: Cycle, parallel_rows: int = SolverConfig.parallel_rows,
                 pair_budget: int = SolverConfig.pair_budget) -> np.ndarray:
    """The exact total cost of every row of ``z`` (n, 4): ``evaluate_batch(...).costs.total``
    to the bit, without the rollouts and the breakdown when the compiled kernel runs
    (:func:`~dsmpepc_nlp.solve.exact.total_costs`)."""
    z = np.atleast_2d(np.asarray(z, dtype=float))
    module = _compiled_for(z, cycle, None)
    if module is not None:
        return exact.total_costs(z, cycle, module, parallel_rows)
    return _evaluate_numpy(z, cycle, pair_budget).costs.total


def _compiled_for(z: np.ndarray, cycle: Cycle, compiled: bool | None):
    """The compiled kernel when it runs ``z`` (2-d, 4 columns, inside the reach the cycle's
    culling rests on) and ``compiled`` is not False, else None (the numpy reference)."""
    module = exact.kernel() if compiled is not False else None
    if module is not None and z.ndim == 2 and z.shape[1:] == (4,) and exact.inside_reach(z, cycle):
        return module
    return None


def _evaluate_numpy(z, cycle: Cycle, pair_budget: int) -> Evaluation:
    """The numpy reference of :func:`evaluate_batch`."""
    state, world, goal, config = cycle.state, cycle.world, cycle.goal, cycle.config
    trajectories = rollout(z, state, config)
    circles = max(1, len(world.stacked_obstacles()[1]))
    per_row = (config.horizon.n_steps + 1) * len(config.robot.footprint) * circles
    chunk = max(1, pair_budget // per_row)
    if len(z) <= chunk:
        return Evaluation(z, trajectories, evaluate(trajectories, world, goal, config))
    parts = [evaluate(trajectories[i:i + chunk], world, goal, config)
             for i in range(0, len(z), chunk)]
    costs = CostBreakdown(
        np.concatenate([p.total for p in parts]),
        {name: np.concatenate([p.terms[name] for p in parts]) for name in parts[0].terms},
        *(np.concatenate([getattr(p, f) for p in parts])
          for f in ("survivability", "min_distance", "ttg", "ttc_terminal")))
    return Evaluation(z, trajectories, costs)


class SamplingPlanner:
    """Exact cost over a fixed low-discrepancy set of z plus the structured starts.

    Parameters
    ----------
    config : PlannerConfig
    solver : SolverConfig
        ``n_samples`` and ``seed`` are read; the sample set is drawn once, here.
    """

    def __init__(self, config: PlannerConfig, solver: SolverConfig | None = None):
        solver = SolverConfig.sampling() if solver is None else solver
        self.config = config
        self.pair_budget, self.parallel_rows = solver.pair_budget, solver.parallel_rows
        self.samples = box_samples(config, solver.n_samples, solver.seed)

    def search(self, cycle: Cycle, starts: dict | None = None) -> Evaluation:
        """Evaluate the sample set and ``starts`` (a dict of named z); see :class:`Evaluation`."""
        extra = np.array(list(starts.values())) if starts else np.zeros((0, 4))
        return evaluate_batch(np.vstack([extra, self.samples]), cycle,
                              pair_budget=self.pair_budget, parallel_rows=self.parallel_rows)
