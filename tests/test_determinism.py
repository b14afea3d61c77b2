"""Same scenario, configuration and seed give the same episode, bit for bit, on one machine."""

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import OccupancyGrid
from dsmpepc_nlp.sim.simulate import simulate
from dsmpepc_nlp.sim.types import Agent, FixedGoal, ParkedRobot, Pedestrian, Scenario

TIMING = {"plan_time"}
"""Wall times are the only logged quantities allowed to differ between runs."""


def scenario():
    occupied = np.zeros((50, 50), bool)
    occupied[20:30, 30:33] = True
    agents = (Agent("a", RobotState(0.5, 2.5, 0.0), FixedGoal((4.5, 2.0))),
              Agent("b", RobotState(4.5, 0.8, np.pi), FixedGoal((0.5, 1.0))))
    return Scenario("determinism", agents, OccupancyGrid.from_array(occupied, 0.1),
                    (Pedestrian.constant((2.5, 4.5), (0.0, -0.4)),),
                    (ParkedRobot((1.0, 4.0, 0.0), ((0.0, 0.0, 0.25),)),),
                    duration=1.2, start_noise=0.05)


def episode_arrays(solver, seed):
    episode = simulate(scenario(), PlannerConfig(), solver, np.random.default_rng(seed))
    arrays = {name: value for name, value in vars(episode).items()
              if isinstance(value, np.ndarray) and name not in TIMING}
    return arrays, episode.outcomes


@pytest.mark.parametrize("solver", [SolverConfig.sampling(n_samples=256), SolverConfig()],
                         ids=["sampling", "nlp"])
def test_same_seed_same_episode_bit_for_bit(solver):
    (first, outcomes_a), (second, outcomes_b) = episode_arrays(solver, 7), episode_arrays(solver, 7)
    assert outcomes_a == outcomes_b
    assert first.keys() == second.keys() and "states" in first and "z" in first
    for name in first:
        assert np.array_equal(first[name], second[name], equal_nan=True), name


def test_another_seed_perturbs_the_starts():
    first, _ = episode_arrays(SolverConfig.sampling(n_samples=64), 1)
    second, _ = episode_arrays(SolverConfig.sampling(n_samples=64), 2)
    assert not np.array_equal(first["states"][:, 0], second["states"][:, 0])
