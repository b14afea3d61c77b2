"""The signed distance is the exact distance to the boundary of occupied cells (issue 15).

Hand-worked cases in cells (resolution 1): the nearest point of a unit square to a cell centre
offset by (dx, dy) cells is at hypot(max(|dx| - 1/2, 0), max(|dy| - 1/2, 0)).
"""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from dsmpepc_nlp.core.world import OccupancyGrid

HALF_DIAGONAL = math.sqrt(2.0) / 2.0


def table(occupied, resolution=1.0):
    return OccupancyGrid(np.array(occupied, dtype=bool), resolution).signed_distance


def test_single_cell_axis_and_diagonal_neighbours():
    occ = np.zeros((7, 7), dtype=bool)
    occ[3, 3] = True
    sd = table(occ, 0.1)
    assert sd[3, 4] == pytest.approx(0.05)                       # axis neighbour: half a cell
    assert sd[4, 4] == pytest.approx(0.1 * HALF_DIAGONAL)        # diagonal: 0.707, not 0.914
    assert sd[3, 5] == pytest.approx(0.15)                       # two cells along an axis
    assert sd[4, 5] == pytest.approx(0.1 * math.hypot(0.5, 1.5))  # knight's move
    assert sd[5, 5] == pytest.approx(0.1 * math.hypot(1.5, 1.5))
    assert sd[3, 3] == pytest.approx(-0.05)                      # inside: half a cell to free


def test_wall_end():
    occ = np.zeros((12, 16), dtype=bool)
    occ[5, :10] = True                     # a wall along row 5 ending at column 9
    sd = table(occ)
    assert sd[5, 10] == pytest.approx(0.5)                     # in line with the end
    assert sd[5, 11] == pytest.approx(1.5)
    assert sd[6, 10] == pytest.approx(HALF_DIAGONAL)           # diagonal off the end
    assert sd[7, 12] == pytest.approx(math.hypot(2.5, 1.5))    # 2.915; the old table said 3.106
    assert sd[8, 4] == pytest.approx(2.5)                      # beside the wall: perpendicular
    assert sd[5, 9] == pytest.approx(-0.5)


def test_corner():
    occ = np.zeros((12, 12), dtype=bool)
    occ[5, 5:] = True                      # an L: row 5 from column 5, column 5 from row 5
    occ[5:, 5] = True
    sd = table(occ)
    assert sd[4, 4] == pytest.approx(HALF_DIAGONAL)            # outside the corner, diagonal
    assert sd[3, 3] == pytest.approx(math.hypot(1.5, 1.5))
    assert sd[6, 6] == pytest.approx(0.5)                      # inside the L, in the angle
    assert sd[7, 7] == pytest.approx(1.5)
    assert sd[5, 5] == pytest.approx(-0.5)


def test_thick_block_inside_is_minus_distance_to_free_squares():
    occ = np.zeros((9, 9), dtype=bool)
    occ[2:7, 2:7] = True
    sd = table(occ)
    assert sd[4, 4] == pytest.approx(-2.5)
    assert sd[3, 3] == pytest.approx(-1.5)                    # 1.5 to the free row and column
    assert sd[2, 2] == pytest.approx(-0.5)
    assert sd[1, 1] == pytest.approx(HALF_DIAGONAL)


def test_one_cell_corridor():
    occ = np.ones((3, 9), dtype=bool)
    occ[1, :] = False                      # a corridor one cell wide through a solid block
    sd = table(occ, 0.05)
    np.testing.assert_allclose(sd[1], 0.025)                   # half a cell to either wall
    np.testing.assert_allclose(sd[[0, 2]], -0.025)             # walls one cell thick


def test_grid_edge_counts_as_free():
    sd = table(np.ones((3, 3), dtype=bool))
    assert sd[1, 1] == pytest.approx(-1.5)
    assert sd[0, 0] == pytest.approx(-0.5)


def brute_force(occupied):
    """The definition: min over squares of the other kind (outside the grid is free)."""
    ny, nx = occupied.shape
    padded = np.pad(occupied, 1, constant_values=False)
    iy, ix = np.nonzero(np.ones_like(padded))
    out = np.zeros(occupied.shape)
    for y in range(ny):
        for x in range(nx):
            other = padded[iy, ix] != occupied[y, x]
            dx = np.maximum(np.abs(ix[other] - 1 - x) - 0.5, 0.0)
            dy = np.maximum(np.abs(iy[other] - 1 - y) - 0.5, 0.0)
            d = np.min(np.hypot(dx, dy))
            out[y, x] = -d if occupied[y, x] else d
    return out


@given(occupied=arrays(bool, st.tuples(st.integers(1, 9), st.integers(1, 9))))
def test_matches_the_definition_on_random_grids(occupied):
    if not occupied.any():
        return
    np.testing.assert_allclose(table(occupied), brute_force(occupied), atol=1e-12)
