"""Tests for the static map, signed distance, navigation function and dynamic obstacles."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from dsmpepc_nlp.core.world import (
    FAR,
    DynamicObstacle,
    NavigationFunction,
    OccupancyGrid,
    World,
)

# ---------------------------------------------------------------------------------------------
# signed distance


def single_cell_grid():
    """41x41 cells of 0.1 m; only cell [20, 20] (x, y in [2.0, 2.1]) is occupied."""
    occ = np.zeros((41, 41), dtype=bool)
    occ[20, 20] = True
    return OccupancyGrid(occ, 0.1)


def wall_grid():
    """40x40 cells of 0.1 m with a full-height wall in column 30 (x in [3.0, 3.1])."""
    occ = np.zeros((40, 40), dtype=bool)
    occ[:, 30] = True
    return OccupancyGrid(occ, 0.1)


def test_single_cell_distance_is_metric_distance_to_cell_boundary():
    grid = single_cell_grid()
    above = grid.distance([2.05, 3.1])  # 1 m above the cell's top edge
    assert abs(above - 1.0) <= 0.05
    corner = np.array([2.1, 2.1]) + np.array([1.0, 1.0]) / math.sqrt(2.0)  # 1 m off the corner
    assert abs(grid.distance(corner) - 1.0) <= 0.05
    assert grid.signed_distance[20, 21] == pytest.approx(0.05)  # free neighbour: half a cell
    assert grid.signed_distance[20, 20] == pytest.approx(-0.05)


def test_distance_is_negative_inside_a_block():
    occ = np.zeros((21, 21), dtype=bool)
    occ[8:13, 8:13] = True
    grid = OccupancyGrid(occ, 0.1, origin=(-1.0, 2.0))
    centre = np.array([-1.0, 2.0]) + 0.1 * np.array([10.5, 10.5])
    assert grid.distance(centre) == pytest.approx(-0.25)  # 2.5 cells to the nearest free edge


def test_empty_grid_is_far_everywhere():
    grid = OccupancyGrid(np.zeros((5, 7)), 0.5)
    assert np.all(grid.signed_distance == FAR)
    assert np.all(grid.distance(np.zeros((3, 4, 2))) >= FAR)


def test_distance_grows_outside_the_grid():
    grid = single_cell_grid()
    xmax = grid.bounds[2]
    points = np.stack([xmax + np.arange(0.0, 5.0), np.full(5, 2.05)], axis=-1)
    d = grid.distance(points)
    assert d.shape == (5,)
    assert np.all(np.diff(d) >= 0.99)  # one more metre away, about one more metre of distance


def test_distance_beyond_the_map_edge():
    occ = np.zeros((10, 10), dtype=bool)
    occ[9, 0] = True  # box x in [0, 1], y in [9, 10]
    grid = OccupancyGrid(occ, 1.0)
    assert grid.distance([0.5, 12.0]) == pytest.approx(2.0)  # exact along the edge normal
    true = math.hypot(5.0 - 1.0, 12.0 - 10.0)
    # obliquely the clamped extension overstates clearance, by at most sqrt(2) and half a cell
    assert true <= grid.distance([5.0, 12.0]) <= math.sqrt(2.0) * true + 0.5


def test_distance_keeps_batch_shape():
    grid = single_cell_grid()
    assert grid.distance(np.ones((2, 3, 2))).shape == (2, 3)


# ---------------------------------------------------------------------------------------------
# ray distance


def test_ray_hits_a_straight_wall_exactly_head_on():
    grid = wall_grid()
    # wall face at x = 3.0; a circle of radius 0.2 touches it when its centre is at x = 2.8
    s = grid.ray_distance([0.55, 2.05], 0.0, 0.2, 5.0)
    assert s == pytest.approx(2.8 - 0.55, abs=1e-6)


def test_ray_oblique_hit_within_a_quarter_cell():
    grid = wall_grid()
    heading = 0.5
    expected = (2.8 - 0.55) / math.cos(heading)
    s = grid.ray_distance([0.55, 1.05], heading, 0.2, 5.0)
    assert expected - 1e-9 <= s <= expected + 0.5 * grid.resolution


def test_ray_away_from_wall_is_inf_and_inside_is_zero():
    grid = wall_grid()
    assert grid.ray_distance([1.55, 2.05], math.pi, 0.2, 5.0) == np.inf
    assert grid.ray_distance([3.05, 2.05], 0.0, 0.2, 5.0) == 0.0  # inside the wall
    assert grid.ray_distance([2.9, 2.05], math.pi, 0.2, 5.0) == 0.0  # within clearance


def test_ray_respects_max_range_and_broadcasts():
    grid = wall_grid()
    assert grid.ray_distance([0.55, 2.05], 0.0, 0.2, 2.0) == np.inf
    assert grid.ray_distance([0.55, 2.05], 0.0, 0.2, 2.25) == pytest.approx(2.25)
    origins = np.broadcast_to([0.55, 2.05], (2, 3, 2))
    clearance = np.array([0.0, 0.1, 0.2])
    s = grid.ray_distance(origins, 0.0, clearance, 5.0)
    assert s.shape == (2, 3)
    np.testing.assert_allclose(s[1], 3.0 - 0.55 - clearance, atol=1e-6)


# ---------------------------------------------------------------------------------------------
# navigation function


def u_maze():
    """10x10 cells of 1 m; a wall in column 5 from row 0 up to row 7 leaves rows 8-9 open."""
    occ = np.zeros((10, 10), dtype=bool)
    occ[0:8, 5] = True
    return OccupancyGrid(occ, 1.0)


def test_navigation_goes_around_the_wall():
    nf = NavigationFunction([8.5, 1.5], u_maze(), margin=0.0)
    start = np.array([2.5, 1.5])
    # by hand: (1,2) -> (8,4): 5 straight + 2 diagonal; step to (8,5) and (8,6): 2; then down to
    # (1,8): 5 straight + 2 diagonal. No diagonal past the wall's top cell.
    expected = 2 * (5 + 2 * math.sqrt(2.0)) + 2
    assert nf.value(start) == pytest.approx(expected, abs=0.5)  # corner cutting gives 16.5
    assert nf.value(start) > 2 * np.linalg.norm(start - nf.goal)
    assert nf.value(nf.goal) == pytest.approx(0.0, abs=1e-9)
    # descent points up, towards the opening, not through the wall
    assert nf.gradient([2.5, 3.5])[1] < 0


def test_inflation_lengthens_the_path():
    grid = u_maze()
    plain = NavigationFunction([8.5, 1.5], grid, margin=0.0)
    inflated = NavigationFunction([8.5, 1.5], grid, inflation_radius=0.6, margin=0.0)
    assert inflated.value([2.5, 1.5]) > plain.value([2.5, 1.5]) + 0.5


def test_navigation_with_goal_inside_obstacle_and_enclosed_cells_is_finite():
    occ = np.zeros((12, 12), dtype=bool)
    occ[0:8, 5] = True
    occ[8:11, 8] = True  # a closed box around cell [9, 9]
    occ[8, 8:11] = True
    occ[10, 8:11] = True
    occ[8:11, 10] = True
    nf = NavigationFunction([5.5, 3.5], OccupancyGrid(occ, 1.0))
    assert np.all(np.isfinite(nf.values))
    assert nf.value([9.5, 9.5]) > nf.value([6.5, 3.5])
    assert np.all(np.isfinite(nf.gradient([[2.5, 1.5], [5.5, 3.5]])))


def test_a_moving_goal_reuses_the_maps_free_cells_and_gets_the_same_values():
    from dsmpepc_nlp.core import navigation

    grid = u_maze()
    goals = ([8.5, 1.5], [8.4, 1.7], [7.9, 2.6])
    values = [NavigationFunction(goal, grid, inflation_radius=0.3).values for goal in goals]
    window = navigation.navigation_window(grid, np.array(goals[0]), 2.0)
    mask, cells = navigation._kept_window(grid, window, 0.3)[:2]
    again = navigation._kept_window(grid, window, 0.3)
    assert again[0] is mask and again[1] is cells               # kept, not recomputed
    assert not mask.flags.writeable and not any(part.flags.writeable for part in cells)
    wider = navigation._kept_window(grid, window, 0.6)[0]      # the radius is in the key
    assert wider.sum() < mask.sum()
    indptr, indices, data = cells      # every free cell's edges, and only theirs
    assert indptr.size == mask.size + 1 and indices.size == data.size == indptr[-1]
    assert np.all(np.diff(indptr)[~mask.ravel()] == 0) and np.all(mask.ravel()[indices])
    for goal, kept in zip(goals, values):    # a fresh map (nothing kept) gives the same values
        fresh = NavigationFunction(goal, u_maze(), inflation_radius=0.3).values
        np.testing.assert_array_equal(kept, fresh)
    assert not np.array_equal(values[0], values[2])


def test_a_moving_goal_reuses_the_fill_of_unreached_cells_only_while_they_are_the_same():
    """A map with a closed room: goals outside it leave the same cells unreached (the walls,
    the room), so the second build fills them from the kept transform; a goal inside the room
    leaves others unreached and the fill is made anew. Every build equals a fresh map's."""
    from dsmpepc_nlp.core import navigation

    def rooms():
        occ = np.zeros((12, 12), dtype=bool)
        occ[0:7, 5] = True
        occ[7, 7:11] = occ[10, 7:11] = occ[7:11, 7] = occ[7:11, 10] = True   # room round 8-9
        return OccupancyGrid(occ, 1.0)

    grid = rooms()
    fills = []
    for goal in ([2.5, 2.5], [2.6, 2.8], [8.5, 8.5], [8.4, 8.6], [3.0, 2.0]):
        values = NavigationFunction(goal, grid).values
        np.testing.assert_array_equal(values, NavigationFunction(goal, rooms()).values)
        window = navigation.navigation_window(grid, np.array(goal), 2.0)
        fills.append(navigation._kept_window(grid, window, 0.0)[2]["last"])
    assert fills[1] is fills[0] and fills[3] is fills[2] and fills[2] is not fills[1]
    assert fills[4] is not fills[3] and np.array_equal(fills[4][0], fills[0][0])
    inside, outside = (10, 10), (4, 4)     # map cells (8, 8), (2, 2); the window's margin is 2
    assert not fills[0][0][inside] and fills[2][0][inside] and not fills[2][0][outside]


def test_navigation_window_is_the_map_plus_margin_whatever_the_goal():
    grid = u_maze()
    inside = NavigationFunction([8.5, 1.5], grid, margin=2.0)
    for goal in ([15.0, 5.0], [1.0e4, 5.0], [-3.0e5, 7.0e5]):
        nf = NavigationFunction(goal, grid, margin=2.0)
        assert nf.working_grid.bounds == inside.working_grid.bounds == (-2.0, -2.0, 12.0, 12.0)


def test_goal_beyond_the_window_is_reached_through_the_facing_border():
    nf = NavigationFunction([15.0, 5.0], u_maze(), margin=2.0)
    # the border column facing the goal holds the straight-line distance from its centres
    np.testing.assert_allclose(nf.value([[11.5, 5.5], [11.5, -1.5]]),
                               np.hypot(3.5, [0.5, 6.5]), atol=1e-9)
    # right of the wall the path runs straight: 8-connected lengths overestimate by < 8 %
    euclid = math.hypot(15.0 - 7.5, 5.0 - 5.5)
    assert euclid <= nf.value([7.5, 5.5]) <= 1.08 * euclid
    # left of the wall it goes round the wall's bottom corners (the margin below the map is free)
    geodesic = math.hypot(2.5, 1.5) + 1.0 + math.hypot(9.0, 5.0)
    assert geodesic <= nf.value([2.5, 1.5]) <= 1.1 * geodesic
    # far goal: every border cell facing it is the same distance up to the goal's offset
    far = NavigationFunction([1.0e4, 5.0], u_maze(), margin=2.0)
    assert far.value([11.5, 5.5]) == pytest.approx(math.hypot(1.0e4 - 11.5, 0.5), abs=1e-6)
    assert far.gradient([8.5, 5.5])[0] == pytest.approx(-1.0, abs=0.05)


def test_navigation_window_follows_a_robot_that_left_the_map():
    grid = u_maze()
    near = np.array([40.0, 5.0])
    nf = NavigationFunction([1.0e4, 5.0], grid, margin=2.0, near=near, reach=5.0)
    xmin, ymin, xmax, ymax = nf.working_grid.bounds
    assert xmin <= near[0] - 5.0 and xmax >= near[0] + 5.0
    assert ymin <= near[1] - 5.0 and ymax >= near[1] + 5.0
    assert nf.values.size <= 14 * 14 + 3 * 13 * 13  # the map window + 3 robot boxes (13 cells)
    assert nf.gradient(near)[0] == pytest.approx(-1.0, abs=0.05)
    # a robot far away with its goal beside it: the window holds both, value 0 at the goal
    robot = np.array([1.0e6, 1.0e6])
    goal = robot + [1.5, 0.5]  # a cell centre
    close = NavigationFunction(goal, grid, near=robot, reach=5.0)
    assert close.value(goal) == pytest.approx(0.0, abs=1e-9)
    assert close.value(robot) == pytest.approx(math.hypot(1.5, 0.5), rel=0.08)
    assert close.values.size < 1000
    # a goal inside the map window ignores ``near``
    assert NavigationFunction([8.5, 1.5], grid, near=near, reach=5.0).values.shape == (14, 14)


def test_navigation_without_grid_is_euclidean():
    nf = NavigationFunction([1.0, -2.0])
    points = np.array([[4.0, 2.0], [1.0, -2.0]])
    np.testing.assert_allclose(nf.value(points), [5.0, 0.0])
    np.testing.assert_allclose(nf.gradient(points), [[0.6, 0.8], [0.0, 0.0]])
    assert nf.values is None


# ---------------------------------------------------------------------------------------------
# map files


def write_map(folder, pgm_bytes, **fields):
    (folder / "m.pgm").write_bytes(pgm_bytes)
    meta = {"image": "m.pgm", "resolution": 0.5, "origin": [1.0, -2.0, 0.0]} | fields
    lines = [
        f"{key}: {value!r}" if isinstance(value, str) else f"{key}: {value}"
        for key, value in meta.items()
    ]
    path = folder / "m.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


PGM = b"P5\n# a comment\n3 2\n255\n" + bytes([255, 0, 128, 0, 0, 0])  # top row first


def test_round_trip_through_yaml(tmp_path):
    rng = np.random.default_rng(3)
    grid = OccupancyGrid(rng.random((7, 5)) < 0.3, 0.05, origin=(-1.25, 3.5))
    grid.to_yaml(tmp_path / "map.yaml")
    back = OccupancyGrid.from_yaml(tmp_path / "map.yaml")
    np.testing.assert_array_equal(back.occupied, grid.occupied)
    assert back.resolution == grid.resolution
    np.testing.assert_array_equal(back.origin, grid.origin)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.pgm", "map.yaml"]


def test_hand_written_pgm_flips_rows_and_honours_negate(tmp_path):
    plain = OccupancyGrid.from_yaml(write_map(tmp_path, PGM))
    # negate 0: black (0) is occupied; 128 is unknown, counted free; the top image row is max y
    np.testing.assert_array_equal(plain.occupied, [[True, True, True], [False, True, False]])
    assert plain.bounds == (1.0, -2.0, 2.5, -1.0)

    negated = OccupancyGrid.from_yaml(write_map(tmp_path, PGM, negate=1, occupied_thresh=0.4))
    # negate 1: occupancy = p / 255; 128 -> 0.502 > 0.4 is occupied now
    np.testing.assert_array_equal(negated.occupied, [[False, False, False], [True, False, True]])


def test_ascii_pgm(tmp_path):
    pgm = b"P2\n3 2\n# comment\n15\n15 0 15\n0 15 15\n"
    grid = OccupancyGrid.from_yaml(write_map(tmp_path, pgm, mode="scale"))
    np.testing.assert_array_equal(grid.occupied, [[True, False, False], [False, True, False]])


@pytest.mark.parametrize(
    ("pgm", "fields", "match"),
    [
        (PGM[:-2], {}, "truncated"),
        (b"\x89PNG\r\n\x1a\n" + bytes(20), {}, "not a PGM"),
        (PGM, {"image": "missing.pgm"}, "missing.pgm"),
        (PGM, {"origin": [0.0, 0.0, 0.5]}, "yaw"),
        (PGM, {"negate": 2}, "negate"),
        (PGM, {"mode": "raw"}, "mode"),
    ],
)
def test_bad_map_files_raise(tmp_path, pgm, fields, match):
    with pytest.raises(ValueError, match=match):
        OccupancyGrid.from_yaml(write_map(tmp_path, pgm, **fields))


def test_missing_resolution_names_field_and_file(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text("image: m.pgm\norigin: [0.0, 0.0, 0.0]\n")
    with pytest.raises(ValueError, match=r"m\.yaml.*resolution"):
        OccupancyGrid.from_yaml(path)


def test_grid_validation():
    with pytest.raises(ValueError, match="resolution"):
        OccupancyGrid(np.zeros((2, 2)), 0.0)
    with pytest.raises(ValueError, match="occupied"):
        OccupancyGrid(np.full((2, 2), 2), 0.1)
    with pytest.raises(ValueError, match="occupied"):
        OccupancyGrid(np.zeros(4), 0.1)
    grid = OccupancyGrid(np.zeros((2, 2)), 0.1)
    with pytest.raises(ValueError, match="read-only"):
        grid.occupied[0, 0] = True


# ---------------------------------------------------------------------------------------------
# dynamic obstacles and world


def test_pedestrian_prediction_is_constant_velocity():
    person = DynamicObstacle.pedestrian([1.0, 2.0], [0.5, -1.0])
    centres = person.predict(np.array([0.0, 2.0]))
    assert centres.shape == (2, 1, 2)
    np.testing.assert_allclose(centres[:, 0], [[1.0, 2.0], [2.0, 0.0]])
    assert person.radii.tolist() == [0.3] and person.kind == "pedestrian"


def test_robot_footprint_is_rotated_into_the_world():
    other = DynamicObstacle.robot(
        [1.0, 2.0, math.pi / 2], [0.0, 1.0], [(0.5, 0.0, 0.3), (-0.5, 0.1, 0.2)]
    )
    np.testing.assert_allclose(other.centers, [[1.0, 2.5], [0.9, 1.5]], atol=1e-12)
    np.testing.assert_allclose(other.radii, [0.3, 0.2])
    assert other.kind == "robot"
    assert other.predict(np.array([1.0, 2.0, 3.0])).shape == (3, 2, 2)


@pytest.mark.parametrize("radius", [0.0, -0.1, np.nan])
def test_invalid_radius_raises(radius):
    with pytest.raises(ValueError, match="radii"):
        DynamicObstacle.pedestrian([0.0, 0.0], [0.0, 0.0], radius=radius)


def test_invalid_kind_raises():
    with pytest.raises(ValueError, match="kind"):
        DynamicObstacle(np.zeros((1, 2)), np.ones(1), np.zeros(2), kind="cyclist")


def test_world_stacks_obstacles_and_shares_navigation_cache():
    empty = World()
    centers, radii, velocities, owner = empty.stacked_obstacles()
    assert centers.shape == (0, 2) and radii.shape == (0,)
    assert velocities.shape == (0, 2) and owner.shape == (0,)
    assert np.all(empty.static_distance(np.zeros((4, 2))) == FAR)
    assert np.all(empty.static_ray_distance(np.zeros((4, 2)), 0.0, 0.1, 3.0) == np.inf)

    world = World(u_maze())
    person = DynamicObstacle.pedestrian([1.0, 2.0], [0.5, 0.0])
    other = DynamicObstacle.robot([4.0, 4.0, 0.0], [0.0, -1.0], [(0.3, 0, 0.2), (-0.3, 0, 0.2)])
    moved = world.with_obstacles([person, other])
    centers, radii, velocities, owner = moved.stacked_obstacles()
    assert owner.tolist() == [0, 1, 1]
    np.testing.assert_allclose(velocities, [[0.5, 0.0], [0.0, -1.0], [0.0, -1.0]])
    np.testing.assert_allclose(radii, [0.3, 0.2, 0.2])
    assert moved.grid is world.grid
    nav = world.navigation([8.5, 1.5], 0.2)
    assert moved.navigation([8.5, 1.5 + 1e-12], 0.2) is nav
    assert moved.navigation([8.5, 1.5], 0.4) is not nav


# ---------------------------------------------------------------------------------------------
# properties


@settings(max_examples=100)
@given(
    occupied=arrays(bool, st.tuples(st.integers(1, 8), st.integers(1, 8))),
    resolution=st.floats(0.05, 2.0),
    cells=arrays(float, (2, 2), elements=st.floats(0.5, 8.5)),
    far=arrays(float, (2, 2), elements=st.floats(-20.0, 20.0)),
)
def test_distance_is_lipschitz(occupied, resolution, cells, far):
    grid = OccupancyGrid(occupied, resolution, origin=(-1.0, -2.0))
    # inside the cell-centre box: 1-Lipschitz up to a cell
    ny, nx = occupied.shape
    p, q = grid.origin + resolution * np.minimum(cells, [nx - 0.5, ny - 0.5])
    gap = abs(grid.distance(p) - grid.distance(q))
    assert gap <= np.linalg.norm(p - q) + resolution + 1e-9
    # anywhere, with the clamped extension beyond the edge: sqrt(2)-Lipschitz up to a cell
    p, q = far * resolution
    gap = abs(grid.distance(p) - grid.distance(q))
    assert gap <= math.sqrt(2.0) * np.linalg.norm(p - q) + resolution + 1e-9
