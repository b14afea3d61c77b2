"""tools/dev/coarse_screen.py: a coarser rollout as the screen's ranking, against the exact one."""

import numpy as np
import pytest

from dsmpepc_nlp import PlannerConfig
from dsmpepc_nlp.core.config import RobotState
from dsmpepc_nlp.core.world import DynamicObstacle, World


def test_a_coarse_horizon_covers_the_same_duration(tool):
    coarse = tool("coarse_screen")
    config = PlannerConfig()
    assert coarse.coarse_config(config, 0.5).horizon.n_steps == 10
    assert coarse.coarse_config(config, 0.4).horizon.n_steps == 13
    assert coarse.coarse_config(config, 0.3).horizon.duration >= config.horizon.duration
    assert coarse.coarse_config(config, 0.5).cost == config.cost


def test_the_exact_ranking_loses_nothing_and_a_coarse_one_is_measured(tool):
    coarse = tool("coarse_screen")
    config = PlannerConfig()
    world = World(None).with_obstacles(
        [DynamicObstacle.pedestrian((2.0, 0.3), (-0.5, 0.0), 0.3)])
    cycles = [(RobotState(0.0, 0.0, 0.0, 0.5, 0.0), world, np.array([5.0, 0.0])),
              (RobotState(1.0, -0.5, 0.3, 0.2, 0.1), world, np.array([5.0, 0.0]))]
    found = coarse.measure(cycles, config, [0.5, 1.0], points=128, keep=8)
    assert sorted(found) == [0.2, 0.5, 1.0]
    assert found[0.2]["gaps"] == [0.0, 0.0]               # its own ranking keeps its best
    assert found[1.0]["steps"] == 5 and len(found[1.0]["seconds"]) == 2
    assert all(gap >= 0.0 for row in found.values() for gap in row["gaps"])
    # every point kept: the gap is of exact costs, so nothing is lost whatever the ranking
    one = coarse.measure(cycles[:1], config, [1.0], points=128, keep=128)
    assert one[1.0]["gaps"] == [pytest.approx(0.0)]
    assert "dt 1 s (5 steps)" in coarse.table(found, 0.2, 128, 8)
