"""An IR-SIM run as the product's :class:`~dsmpepc_nlp.sim.episode.Episode`, so that what reads
our simulator's episodes (``dsmpepc failures``, its classes and figures) reads IR-SIM's.

The episode is taken at the planning instants: state k is the robot at the IR-SIM step it
planned its k-th plan at, and the last state is the one IR-SIM judged (so the last interval is
shorter when the run ended within a period). Every moving object's covering circles are the
episode's "pedestrians" (their true centres and IR-SIM's own velocities); the map is the exact
oracle map, whatever the robot sensed. What IR-SIM's runs do not have (costs, survivability,
NLP iterations, the chosen trajectories) is NaN or zero; ``meta["simulator"]`` says
``ir-sim``.
"""

from __future__ import annotations

import numpy as np

from ..core.terms import TERM_NAMES
from ..sim.episode import Episode, config_to_dict
from ..solve.plan import STATUSES


def _instants(log) -> list:
    """Indices of the logged steps the episode keeps: every plan's, then the last."""
    kept = list(log.plan_steps)
    last = len(log.times) - 1
    if not kept or kept[-1] != last:
        kept.append(last)
    return kept


def episode_of(log, config, meta: dict) -> Episode:
    """The :class:`Episode` of a finished :class:`~.record.EpisodeLog` run with the planner
    configuration ``config``; ``meta`` adds to (or replaces) the metadata (scenario, variant,
    solver, sensing, ...)."""
    kept = _instants(log)
    n_plans = len(kept) - 1
    adapter = log.adapter
    states = log.array()[kept]
    circles = np.asarray(log.circles, dtype=float)[kept].reshape(len(kept), -1, 2)
    velocities = np.asarray(log.circle_velocities, dtype=float)[kept].reshape(len(kept), -1, 2)
    grid = adapter.static_grid
    nan = np.full((1, n_plans), np.nan)
    status = np.array([[STATUSES.index(s) if s in STATUSES else -1
                        for s in log.statuses[:n_plans]]], dtype=int)
    episode = Episode(
        times=np.asarray(log.times, dtype=float)[kept], states=states[None],
        active=np.ones((1, n_plans), dtype=bool),
        goals=np.tile(adapter.goal, (1, len(kept), 1)),
        z=np.full((1, n_plans, 4), np.nan), cost_total=nan.copy(),
        cost_terms=np.full((1, n_plans, len(TERM_NAMES)), np.nan),
        survivability=nan.copy(), ttg=nan.copy(), ttc_terminal=nan.copy(), status=status,
        nit=np.zeros((1, n_plans), dtype=int),
        plan_time=np.asarray(log.plan_times[:n_plans], dtype=float)[None],
        n_starts=np.zeros((1, n_plans), dtype=int), plan_poses=None,
        ped_positions=circles, ped_velocities=velocities,
        ped_radii=np.asarray(log.circle_radii, dtype=float),
        grid_occupied=np.array(grid.occupied), grid_resolution=float(grid.resolution),
        grid_origin=np.array(grid.origin, dtype=float),
        outcomes=[log.outcome], outcome_times=[float(log.outcome_time)],
        meta={"scenario": "", "map_path": None, "dt": log.steps_per_plan * adapter.step_time,
              "duration": float(log.outcome_time), "variant": config.variant_name,
              "solver": "", "n_samples": None, "robots": [adapter.robot.name],
              "footprints": [np.asarray(adapter.robot_config.footprint).tolist()],
              "goal_kinds": ["fixed"], "goal_tolerances": [adapter.goal_tolerance],
              "follow": [None], "parked": [], "config": config_to_dict(config),
              "simulator": "ir-sim", **meta})
    episode.out_of_time = np.asarray(log.cuts[:n_plans], dtype=bool)[None]   # (1, K)
    return episode
