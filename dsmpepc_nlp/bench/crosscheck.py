"""Cross-check of the NLP against the exact sampling planner, cycle by cycle, on exact costs."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..core.config import PlannerConfig, RobotState, SolverConfig
from ..core.control_law import arc_step
from ..core.world import DynamicObstacle, OccupancyGrid, World


@dataclass(frozen=True)
class CrosscheckResult:
    """Per-cycle exact costs of the NLP plan and of the best sampled plan.

    Attributes
    ----------
    nlp_cost, sampled_cost : ndarray, (cycles,)
        Exact cost of the NLP's chosen z and of the best of the samples plus structured starts.
    gap : ndarray, (cycles,)
        ``nlp_cost - sampled_cost``; <= 0 when the NLP is as good or better.
    nlp_status : tuple of str
        :attr:`~dsmpepc_nlp.planner.Plan.status` of each NLP plan.
    tol : float
        The tolerance of :attr:`share_within_tol`.
    """

    nlp_cost: np.ndarray
    sampled_cost: np.ndarray
    gap: np.ndarray
    nlp_status: tuple = field(default=())
    tol: float = 0.01

    @property
    def cycles(self) -> int:
        return int(self.gap.size)

    @property
    def share_within_tol(self) -> float:
        """Share of cycles with ``gap <= tol`` (non-finite gaps count as misses)."""
        if self.gap.size == 0:
            return math.nan
        return float(np.mean(np.where(np.isfinite(self.gap), self.gap <= self.tol, False)))

    def to_dict(self) -> dict:
        """Summary: ``cycles``, ``gap_median``, ``gap_p95``, ``share_within_tol``, ``tol``."""
        finite = self.gap[np.isfinite(self.gap)]
        return {
            "cycles": self.cycles,
            "gap_median": float(np.median(finite)) if finite.size else math.nan,
            "gap_p95": float(np.percentile(finite, 95)) if finite.size else math.nan,
            "share_within_tol": self.share_within_tol,
            "tol": self.tol,
        }


def crosscheck(cycles, config: PlannerConfig, solver_config: SolverConfig | None = None,
               n_samples: int = 4096, tol: float = 0.01) -> CrosscheckResult:
    """Plan every cycle with the NLP and with the sampler; compare exact costs.

    Parameters
    ----------
    cycles : iterable of (RobotState, World, array_like (2,))
        ``(state, world, goal)`` per cycle, in order (the NLP keeps its warm start across them).
    config : PlannerConfig
    solver_config : SolverConfig, optional
        The NLP's configuration (IPOPT by default).
    n_samples : int
        Samples of the reference sampling planner (plus its structured starts).
    tol : float
        Gap counted as "as good", in cost units.

    Notes
    -----
    Docking is off for both planners: near the goal it would bypass both solvers.
    """
    from ..solve.planner import Planner

    solver_config = SolverConfig() if solver_config is None else solver_config
    nlp = Planner(config, solver_config)
    sampler = Planner(config, SolverConfig.sampling(n_samples=n_samples,
                                                    seed=solver_config.seed))
    nlp_cost, sampled_cost, statuses = [], [], []
    for state, world, goal in cycles:
        plan = nlp.plan(state, world, goal, dock=False)
        reference = sampler.plan(state, world, goal, dock=False)
        nlp_cost.append(plan.fun)
        sampled_cost.append(reference.fun)
        statuses.append(plan.status)
    nlp_cost, sampled_cost = np.array(nlp_cost, dtype=float), np.array(sampled_cost, dtype=float)
    return CrosscheckResult(nlp_cost, sampled_cost, nlp_cost - sampled_cost, tuple(statuses),
                            tol)


# --- the crowded demonstration scene -------------------------------------------------------


def demo_world(rng: np.random.Generator, n_pedestrians: int = 12) -> tuple:
    """A 16 m x 12 m map with walls and blocks, and pedestrians at constant velocity.

    Returns ``(world, start_state, goal)``.
    """
    resolution = 0.1
    occupied = np.zeros((120, 160), dtype=bool)
    occupied[:2, :] = occupied[-2:, :] = True            # outer walls, y = 0 and y = 12 m
    occupied[:, :2] = occupied[:, -2:] = True            # x = 0 and x = 16 m
    occupied[40:80, 50:54] = True                         # a pillar wall at x = 5 m
    occupied[20:45, 95:120] = True                        # a block
    occupied[85:89, 90:140] = True                        # a wall at y = 8.5 m
    grid = OccupancyGrid(occupied, resolution, (0.0, 0.0))
    pedestrians = []
    while len(pedestrians) < n_pedestrians:
        position = rng.uniform([1.0, 1.0], [15.0, 11.0])
        if grid.distance(position[None])[0] < 0.6 or np.hypot(*(position - [1.5, 6.0])) < 2.0:
            continue
        heading = rng.uniform(-math.pi, math.pi)
        speed = rng.uniform(0.3, 0.9)
        pedestrians.append(DynamicObstacle.pedestrian(
            position, speed * np.array([math.cos(heading), math.sin(heading)]), radius=0.3))
    return World(grid, pedestrians), RobotState(1.5, 6.0, 0.0), np.array([14.5, 6.0])


def _advance(world: World, dt: float, bounds) -> World:
    """Pedestrians moved by velocity * dt, bouncing off the map's outer box."""
    moved = []
    xmin, ymin, xmax, ymax = bounds
    for obstacle in world.obstacles:
        centers = obstacle.centers + dt * obstacle.velocity
        velocity = np.array(obstacle.velocity)
        for axis, (low, high) in enumerate(((xmin + 0.5, xmax - 0.5), (ymin + 0.5, ymax - 0.5))):
            if not low <= centers[0, axis] <= high:
                velocity[axis] = -velocity[axis]
                centers[:, axis] = np.clip(centers[:, axis], low, high)
        moved.append(dataclasses.replace(obstacle, centers=centers, velocity=velocity))
    return world.with_obstacles(moved)


def demo_cycles(config: PlannerConfig, n_cycles: int, seed: int = 0,
                n_samples: int = 1024) -> list:
    """Cycles ``(state, world, goal)`` of the crowded scene (map + 12 pedestrians).

    The robot executes the first control of a sampling plan (``n_samples`` samples) each cycle;
    pedestrians move at constant velocity. Deterministic for a given ``seed``.
    """
    from ..solve.planner import Planner

    rng = np.random.default_rng(seed)
    world, state, goal = demo_world(rng)
    planner = Planner(config, SolverConfig.sampling(n_samples=n_samples, seed=seed))
    dt = config.horizon.dt
    cycles = []
    for _ in range(n_cycles):
        cycles.append((state, world, goal))
        plan = planner.plan(state, world, goal)
        v, omega = plan.control
        x, y, phi = arc_step(state.pose, v, omega, dt)
        state = RobotState(float(x), float(y), float(phi), v, omega)
        world = _advance(world, dt, world.grid.bounds)
    return cycles
