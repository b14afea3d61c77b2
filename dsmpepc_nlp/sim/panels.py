"""What the paper's Fig. 2 shows for one planning cycle, computed: the trajectories of each panel.

The figure itself is drawn by :func:`dsmpepc_nlp.viz.plots.cost_panels` from a
:class:`CostPanels`; evaluating samples (running the sampler under MPEPC and DS-MPEPC) happens
here, so the figures stay views of data they are given.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.solver_config import SolverConfig
from ..core.world import World
from ..solve.exact.cycle import Cycle
from ..solve.exact.evaluator import Evaluator
from ..solve.optimize.sampling import SamplingPlanner
from ..solve.optimize.starts import structured_starts


@dataclass(frozen=True)
class CostPanels:
    """One planning cycle and the trajectories each panel shows.

    ``panels`` is a tuple of ``(title, poses)`` with ``poses`` of shape (k, N + 1, 3):
    (a) a spread of sampled trajectories, (b) the lowest MPEPC costs, (c) the lowest times to
    goal, (d) the highest terminal times to collision.
    """

    state: RobotState
    world: World
    goal: np.ndarray
    footprint: np.ndarray
    reach: float
    panels: tuple


def cost_panels(state, world, goal, config: PlannerConfig, *, n_samples: int = 4096,
                n_best: int = 50, seed: int = 0) -> CostPanels:
    """Sample the cycle ``(state, world, goal)`` under MPEPC and DS-MPEPC and pick the panels.

    ``config`` supplies everything but the two switches (anticipatory PC, terminal cost).
    """
    mpepc = dataclasses.replace(config, anticipatory_pc=False, terminal_cost=False)
    ds = dataclasses.replace(config, anticipatory_pc=True, terminal_cost=True)
    solver = SolverConfig.sampling(n_samples=n_samples, seed=seed)
    goal = np.asarray(goal, dtype=float)
    starts = structured_starts(state, goal, config)
    ev_mpepc, ev_ds = (
        SamplingPlanner(c, solver).search(Evaluator(Cycle.prepare(state, world, goal, c), solver),
                                          starts) for c in (mpepc, ds))
    poses = ev_mpepc.trajectories.poses

    def lowest(values):
        return np.argsort(np.where(np.isfinite(values), values, np.inf))[:n_best]

    chosen = (
        ("Sampled trajectories", np.arange(0, len(poses), max(1, len(poses) // 200))),
        ("MPEPC cost: lowest", lowest(ev_mpepc.costs.total)),
        ("Time to goal: lowest", lowest(ev_ds.costs.ttg)),
        ("Terminal TTC: highest",
         np.argsort(-np.nan_to_num(ev_ds.costs.ttc_terminal, posinf=1e9))[:n_best]),
    )
    return CostPanels(state, world, goal, np.asarray(config.robot.footprint, dtype=float),
                      float(config.bounds.r_max),
                      tuple((title, poses[index]) for title, index in chosen))
