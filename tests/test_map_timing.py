"""``dsmpepc bench --lidar-map``: plans on a lidar map that changes every cycle beside the same
plans on the known map, each pair in turn (bench/map_timing.py)."""

import math

import numpy as np

from dsmpepc_nlp.bench import map_timing
from dsmpepc_nlp.core.grid import OccupancyGrid
from dsmpepc_nlp.core.solver_config import SolverConfig


def test_both_maps_are_planned_every_cycle_and_compared():
    result = map_timing.lidar_map_timing(3, solver=SolverConfig.sampling(n_samples=64))
    assert result["cycles"] == 3
    for name in ("known", "lidar"):
        assert 0.0 < result[f"{name}_median_ms"] <= result[f"{name}_p95_ms"]
    assert math.isfinite(result["ratio_median"]) and result["ratio_median"] > 0.0
    assert result["lidar_cells_changed_median"] > 0        # the map changes every cycle
    assert "ratio lidar / known" in map_timing.format_lidar_table(result)


def test_changed_cells_are_counted_at_the_same_world_position():
    occupied = np.zeros((4, 4), bool)
    occupied[1, 1] = True
    before = OccupancyGrid(occupied, 0.5, (0.0, 0.0))
    assert map_timing._changed(before, before) == 0
    moved = OccupancyGrid(np.roll(occupied, -1, axis=1), 0.5, (0.5, 0.0))   # the same world
    assert map_timing._changed(before, moved) == 4                         # a column came in
