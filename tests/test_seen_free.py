"""No reverse into space the sensors have never seen free: the grid a lidar builds knows which
cells a beam has crossed (perception.SensedGrid), and the stall ladder's reverses and its last
resort keep to them; a map given in advance changes nothing."""

import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.grid import OccupancyGrid
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.perception import LaserScan, LocalMap, LocalMapConfig, SensedGrid
from dsmpepc_nlp.solve.behaviours import ways as moves
from dsmpepc_nlp.solve.planner import Planner

STATE = RobotState(2.0, 2.0, 0.0)


def _grid(seen_behind: bool) -> SensedGrid:
    """An empty 6 x 4 m map seen free everywhere, or everywhere but behind x = 1.95 m."""
    occupied = np.zeros((40, 60), bool)
    seen = np.ones_like(occupied)
    if not seen_behind:
        seen[:, :int(1.95 / 0.1)] = False
    return SensedGrid.build(occupied, 0.1, (0.0, 0.0), seen)


def _walked_into(grid, person_x):
    """A person walking at the robot: the back-up rung (person at 3.3 m) or the last resort
    (3.1 m) reverses when it may."""
    world = World(grid, [DynamicObstacle.pedestrian((person_x, 2.0), (-0.5, 0.0), 0.3)])
    return Planner(PlannerConfig(), SolverConfig.sampling(n_samples=256)).plan(
        STATE, world, (6.0, 2.0), dock=False)


@pytest.mark.parametrize("person_x, status", [(3.1, "clearing"), (3.3, "backing-up")])
def test_a_reverse_only_into_space_seen_free(person_x, status):
    plain = OccupancyGrid(np.zeros((40, 60), bool), 0.1, (0.0, 0.0))
    assert _walked_into(plain, person_x).status == status             # a map given: reverses
    seen = _walked_into(_grid(seen_behind=True), person_x)
    assert seen.status == status and seen.control[0] < 0.0, seen.message
    blind = _walked_into(_grid(seen_behind=False), person_x)
    assert np.all(blind.trajectory.v >= 0.0), blind.message
    assert "backing up" not in blind.message


def test_reverses_seen_reads_the_rear_of_every_circle():
    config = PlannerConfig()
    every = moves.back_up_trajectories(STATE, config)
    assert moves.reverses_seen(every, World(_grid(True)), config).all()
    assert not moves.reverses_seen(every, World(_grid(False)), config).any()
    assert moves.reverses_seen(every, World(), config).all()             # no map: no question
    ways = moves.Ways(STATE, config, World(_grid(False)))
    assert len(ways.reverses) == 0 and len(ways.reverse_rows) == 0


def test_the_local_map_hands_out_what_its_beams_crossed():
    local_map = LocalMap(LocalMapConfig(size=6.0, resolution=0.05))
    angles = np.linspace(-1.0, 1.0, 181)
    scan = LaserScan.from_angles(np.full(181, 2.0), angles, 0.1, 10.0, pose=(0.0, 0.0, 0.0),
                                 stamp=0.0)
    local_map.update(scan)
    grid = local_map.grid()
    assert isinstance(grid, SensedGrid)
    assert grid.is_seen_free([[1.0, 0.0]])[0] and not grid.is_seen_free([[-1.0, 0.0]])[0]
    assert not grid.is_seen_free([[50.0, 0.0]])[0]                        # outside: never seen
    # Beams with no return cross what was handed out as free already: the same grid (its
    # signed distance kept), its mask grown.
    behind = np.array([[math.cos(2.5), math.sin(2.5)]])
    assert not grid.is_seen_free(behind)[0]
    wider = LaserScan.from_angles(np.full(3, np.inf), [2.0, 2.5, 3.0], 0.1, 10.0,
                                  pose=(0.0, 0.0, 0.0), stamp=0.1)
    local_map.update(wider)
    assert local_map.grid() is grid and grid.is_seen_free(behind)[0]
