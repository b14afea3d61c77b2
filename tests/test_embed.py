"""The embedding API's documented layout is the packed one (issue 31). Iterates over
PARAMETER_NAMES and parameter_shapes, so a new block is checked without editing this file."""

import numpy as np
import pytest

from dsmpepc_nlp import embed
from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World

CONFIG = PlannerConfig()
SIZES = embed.GraphSizes(max_objects=2, table_cells=16)


def room():
    occupied = np.zeros((30, 40), dtype=bool)
    occupied[10:20, 25:28] = True
    return World(OccupancyGrid(occupied, 0.1, (-1.0, -1.5)),
                 [DynamicObstacle.pedestrian([1.0, 0.5], [0.0, -0.4])])


def packed(world):
    cycle = embed.Cycle.prepare(RobotState(0.0, 0.0, 0.0, v=0.3), world, (2.0, 0.0), CONFIG)
    return embed.pack_parameters(cycle, SIZES)


def test_every_block_is_documented_with_its_packed_shape():
    params = packed(room())
    shapes = embed.parameter_shapes(CONFIG, SIZES)
    assert list(params) == list(embed.PARAMETER_NAMES) == list(shapes)
    for name in embed.PARAMETER_NAMES:
        rows, cols = shapes[name]
        assert np.asarray(params[name]).size == rows * cols, name
        assert embed.describe(name) and name in embed.PARAMETER_DOCS, name
        words = embed.PARAMETER_DOCS[name]
        if words.startswith("("):          # a stated shape agrees with the packed one
            stated = words[:words.index(")") + 1]
            assert stated in (f"({rows}, {cols})", f"({rows},)",
                              "(table_cells**2, 1)", "(max_objects * circles_per_object, 3)",
                              "(max_objects, 2)", "(pose_objects * circles_per_object, 3)",
                              "(pose_objects, 2)", "(n_steps + 1, pose_objects)", "(5,)",
                              "(n_settings, 1)"), name
    assert shapes["settings"] == (len(embed.settings_names(CONFIG)), 1)


@pytest.mark.parametrize(("with_map", "flag"), [(True, 0.0), (False, 1.0)])
def test_the_goal_flag_is_one_for_the_euclidean_progress(with_map, flag):
    world = room() if with_map else World()
    assert packed(world)["goal"][2] == flag


def test_tables_are_flattened_x_fastest_from_the_frames_corner():
    world = room()
    params = packed(world)
    x0, y0, res, columns, rows = params["map_frame"]
    sdf = world.grid.signed_distance
    cells = SIZES.table_cells
    u0 = int(round((x0 - world.grid.origin[0]) / res))
    v0 = int(round((y0 - world.grid.origin[1]) / res))
    for iy, ix in ((0, 0), (0, 5), (3, 0), (int(rows) - 1, int(columns) - 1)):
        assert params["map_table"][iy * cells + ix] == sdf[v0 + iy, u0 + ix]


def test_the_flat_vector_is_the_blocks_column_major_in_order():
    params = packed(room())
    flat = embed.flatten_parameters(params)
    start = 0
    for name in embed.PARAMETER_NAMES:
        block = np.asarray(params[name], dtype=float)
        np.testing.assert_array_equal(flat[start:start + block.size],
                                      block.reshape(-1, order="F"))
        start += block.size
    assert start == flat.size
