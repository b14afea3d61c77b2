"""A grid made from a previous one (``OccupancyGrid.updated_from``) gives the values of a grid
built from scratch: the signed distance to the bit, the navigation function to 1e-9 m, however
it moved (whole cells, either way, or not at all) and whatever changed (cells marked, cleared,
at the edges, everything, nothing) -- and the update path is the one taken, not a fallback.
"""

import gc
import math
import weakref

import numpy as np
import pytest

from dsmpepc_nlp.core import distance_update, navigation, navigation_update
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.grid import FAR, OccupancyGrid
from dsmpepc_nlp.core.world import NavigationFunction, World, warm_up_map_updates

compiled = pytest.mark.skipif(distance_update.kernels() is None
                              or navigation_update.kernels() is None,
                              reason="no compiled kernels (numba missing or DSMPEPC_NO_COMPILE)")
"""The update paths run on compiled kernels only; without them a grid is computed afresh."""


def moved(occ, sx, sy):
    """``occ`` seen from a window moved by ``(sx, sy)`` cells (new cell x is old x + sx)."""
    ny, nx = occ.shape
    out = np.zeros_like(occ)
    ys, xs = np.nonzero(occ)
    keep = (ys - sy >= 0) & (ys - sy < ny) & (xs - sx >= 0) & (xs - sx < nx)
    out[ys[keep] - sy, xs[keep] - sx] = True
    return out


def edited(rng, occ, count):
    """``occ`` with ``count`` random cells flipped (marks and clears)."""
    out = occ.copy()
    ys, xs = rng.integers(0, occ.shape[0], count), rng.integers(0, occ.shape[1], count)
    out[ys, xs] = ~out[ys, xs]
    return out


def fresh(occ, resolution, origin):
    return OccupancyGrid.derived(occ, resolution, origin)


def follow(grid, occ, shift):
    """The grid after ``grid`` moved by ``shift`` cells with occupancy ``occ``."""
    return OccupancyGrid.updated_from(grid, occ, grid.origin + grid.resolution
                                      * np.asarray(shift, dtype=float))


def assert_updated_signed_distance(grid, updated=True):
    """The grid's signed distance equals a fresh grid's to the bit, by the update path unless
    not ``updated`` (the grids share no cell)."""
    table = grid.signed_distance
    expected = fresh(grid.occupied, grid.resolution, grid.origin).signed_distance
    np.testing.assert_array_equal(table, expected)
    assert ("_squares" in grid.__dict__) == updated, "the update declined or was not expected"


@compiled
def test_signed_distance_is_the_same_to_the_bit_over_random_moves_and_edits():
    rng = np.random.default_rng(0)
    for _ in range(60):
        ny, nx = rng.integers(1, 28, 2)
        occ = rng.random((ny, nx)) < rng.choice([0.01, 0.05, 0.2, 0.6, 0.95])
        occ[rng.integers(ny), rng.integers(nx)] = True
        grid = fresh(occ, 0.05, rng.uniform(-5, 5, 2))
        _ = grid.signed_distance
        for _ in range(3):                 # a chain: each update starts from the last
            shift = rng.integers(-4, 5, 2)
            new = edited(rng, moved(grid.occupied, *shift), int(rng.integers(0, 12)))
            if not new.any():
                new[0, 0] = True
            grid = follow(grid, new, shift)
            assert_updated_signed_distance(grid, bool(np.all(np.abs(shift) < grid.shape[::-1])))


@compiled
def test_sparse_and_dense_maps_with_long_shifts_and_no_change():
    """Open space (far distances, rows recomputed whole) and a shift as long as the grid."""
    rng = np.random.default_rng(1)
    occ = np.zeros((60, 70), dtype=bool)
    occ[rng.integers(60, size=5), rng.integers(70, size=5)] = True
    grid = fresh(occ, 0.1, (0.0, 0.0))
    _ = grid.signed_distance
    for shift in ((0, 0), (3, -2), (-4, 4), (30, 0), (0, -45), (69, 59)):
        new = moved(grid.occupied, *shift)
        new[rng.integers(60), rng.integers(70)] = True
        grid = follow(grid, new, shift)
        assert_updated_signed_distance(grid)


@compiled
def test_edits_at_the_window_edge_and_on_grids_of_another_shape():
    rng = np.random.default_rng(2)
    occ = rng.random((20, 24)) < 0.1
    grid = fresh(occ, 0.05, (1.0, 2.0))
    _ = grid.signed_distance
    for rows, columns in ((0, slice(None)), (-1, slice(None)), (slice(None), 0),
                          (slice(None), -1)):
        new = grid.occupied.copy()
        new[rows, columns] = ~new[rows, columns]
        grid = follow(grid, new, (1, -1))
        assert_updated_signed_distance(grid)
    for shape, shift in (((26, 18), (-3, 2)), ((9, 31), (2, 5)), ((20, 24), (0, 0))):
        new = rng.random(shape) < 0.1
        new[0, 0] = True
        grid = follow(grid, new, shift)
        assert_updated_signed_distance(grid)


@compiled
def test_thick_obstacles_are_measured_inside_by_rows(monkeypatch):
    """Past the walking budget (thick blocks), the distances inside obstacles come by rows."""
    monkeypatch.setattr(distance_update, "FREE_BUDGET", 0)
    module, rows = distance_update.kernels(), []
    by_rows = module.to_free_rows
    monkeypatch.setattr(module, "to_free_rows", lambda *args: rows.append(by_rows(*args)))
    occ = np.zeros((30, 30), dtype=bool)
    occ[5:25, 3:20] = True
    grid = fresh(occ, 0.05, (0.0, 0.0))
    _ = grid.signed_distance
    new = moved(occ, 2, 1)
    new[10:12, 20:26] = True
    new[14, 8] = False
    grid = follow(grid, new, (2, 1))
    assert_updated_signed_distance(grid)
    assert grid.signed_distance.min() < -0.2 and len(rows) == 1


@compiled
def test_empty_grids_and_grids_becoming_empty():
    occ = np.zeros((12, 15), dtype=bool)
    grid = fresh(occ, 0.1, (0.0, 0.0))
    np.testing.assert_array_equal(grid.signed_distance, FAR)
    occ[4, 6] = True
    grid = follow(grid, occ, (1, 0))                  # from empty: updated all the same
    assert_updated_signed_distance(grid)
    grid = follow(grid, moved(occ, -2, 1) | (np.arange(15) == 14), (-2, 1))
    assert_updated_signed_distance(grid)
    grid = follow(grid, np.zeros((12, 15), dtype=bool), (0, 3))   # becomes empty
    np.testing.assert_array_equal(grid.signed_distance, FAR)


@compiled
def test_an_origin_off_the_lattice_or_a_previous_without_distances_is_computed_afresh():
    occ = np.eye(10, dtype=bool)
    grid = fresh(occ, 0.1, (0.0, 0.0))
    _ = grid.signed_distance
    off = OccupancyGrid.updated_from(grid, occ, (0.05, 0.0))      # half a cell
    np.testing.assert_array_equal(off.signed_distance, grid.signed_distance)
    assert "_squares" not in off.__dict__
    unseen = fresh(occ, 0.1, (0.0, 0.0))                            # never computed
    later = follow(unseen, occ, (0, 0))
    np.testing.assert_array_equal(later.signed_distance, grid.signed_distance)
    assert "_squares" not in later.__dict__


def test_without_compiling_an_updated_grid_is_computed_as_any_grid(monkeypatch):
    occ = np.eye(16, dtype=bool)
    grid = fresh(occ, 0.1, (0.0, 0.0))
    _ = grid.signed_distance
    NavigationFunction([0.85, 0.15], grid, 0.1)
    monkeypatch.setenv("DSMPEPC_NO_COMPILE", "1")
    new = follow(grid, moved(occ, 1, 0), (1, 0))
    nav = NavigationFunction([0.85, 0.15], new, 0.1)
    expected = fresh(new.occupied, 0.1, new.origin)
    np.testing.assert_array_equal(new.signed_distance, expected.signed_distance)
    np.testing.assert_array_equal(nav.values, NavigationFunction([0.85, 0.15], expected, 0.1)
                                  .values)
    assert "_squares" not in new.__dict__ and "_paths" not in nav.__dict__


@compiled
def test_warm_up_loads_the_kernels_or_says_it_cannot(monkeypatch):
    assert warm_up_map_updates()
    monkeypatch.setenv("DSMPEPC_NO_COMPILE", "1")
    assert not warm_up_map_updates()


def test_only_the_immediate_previous_grid_is_held():
    occ = np.eye(8, dtype=bool)
    first = fresh(occ, 0.1, (0.0, 0.0))
    second = follow(first, occ, (0, 0))
    third = follow(second, occ, (1, 1))
    assert third.previous is second and second.previous is None
    assert second.is_update and third.is_update and not first.is_update
    gone = weakref.ref(first)
    del first
    gc.collect()
    assert gone() is None


def test_updated_from_checks_its_arguments():
    grid = fresh(np.eye(4, dtype=bool), 0.1, (0.0, 0.0))
    with pytest.raises(InputError, match="previous"):
        OccupancyGrid.updated_from(np.eye(4), np.eye(4), (0.0, 0.0))
    with pytest.raises(InputError, match="shape"):
        OccupancyGrid.updated_from(grid, np.zeros(4), (0.0, 0.0))
    with pytest.raises(InputError, match="0/1"):
        OccupancyGrid.updated_from(grid, np.full((4, 4), 2), (0.0, 0.0))
    same = OccupancyGrid.updated_from(grid, np.eye(4))
    assert same.resolution == 0.1 and np.array_equal(same.origin, grid.origin)


@compiled
@pytest.mark.parametrize("radius", [0.0, 0.1, 0.27, 0.45])
def test_free_cells_from_the_grid_match_those_of_the_crop(radius):
    rng = np.random.default_rng(3)
    module = distance_update.kernels()
    for _ in range(12):
        ny, nx = rng.integers(1, 25, 2)
        grid = fresh(rng.random((ny, nx)) < 0.2, 0.05, (0.0, 0.0))
        k = math.ceil(radius / 0.05) + 1
        margin = int(rng.integers(k, k + 4))
        window = (-margin, -margin - 1, nx + margin + 2, ny + margin)
        expected = navigation._free_cells(grid, window, radius)
        np.testing.assert_array_equal(
            navigation_update.free_mask(grid, window, radius, module), expected)
    assert navigation_update.free_mask(grid, (0, 0, nx, ny), radius, module) is None


@compiled
def test_the_nearest_reached_cell_is_chosen_as_scipy_chooses():
    from scipy import ndimage

    module = navigation_update.kernels()
    rng = np.random.default_rng(4)
    for trial in range(40):
        ny, nx = rng.integers(2, 40, 2)
        reached = rng.random((ny, nx)) < rng.choice([0.01, 0.1, 0.5])
        if trial % 4 == 0:              # a lattice of reached cells: ties everywhere
            reached[:] = False
            reached[::int(rng.integers(2, 6)), ::int(rng.integers(2, 6))] = True
        reached[rng.integers(ny), rng.integers(nx)] = True
        values = np.where(reached, 1.0, np.inf)
        dy, dx = np.zeros((ny, nx), np.int32), np.zeros((ny, nx), np.int32)
        assert module.nearest_reached(values, dy, dx, 10**9)
        _, (rows, columns) = ndimage.distance_transform_edt(~reached, return_indices=True)
        ys, xs = np.nonzero(~reached)
        np.testing.assert_array_equal(ys + dy[~reached], rows[~reached])
        np.testing.assert_array_equal(xs + dx[~reached], columns[~reached])


class Repairs:
    """Counts the navigation functions built from a previous one's paths."""

    def __init__(self, monkeypatch):
        self.made = self.declined = 0
        original = navigation_update._repaired

        def counted(*args):
            paths = original(*args)
            self.made += paths is not None
            self.declined += paths is None
            return paths

        monkeypatch.setattr(navigation_update, "_repaired", counted)


def assert_navigation_matches(nav, grid, goal, radius, **window):
    expected = NavigationFunction(goal, fresh(grid.occupied, grid.resolution, grid.origin),
                                  radius, **window)
    assert nav.working_grid.bounds == expected.working_grid.bounds
    np.testing.assert_allclose(nav.values, expected.values, rtol=0.0, atol=1e-9)


@compiled
def test_navigation_updates_match_a_fresh_build(monkeypatch):
    repairs = Repairs(monkeypatch)
    rng = np.random.default_rng(5)
    for _ in range(25):
        ny, nx = rng.integers(4, 30, 2)
        grid = fresh(rng.random((ny, nx)) < rng.choice([0.03, 0.1, 0.3]), 0.1, (0.3, -0.7))
        _ = grid.signed_distance
        radius = float(rng.choice([0.0, 0.1, 0.25]))
        goal = grid.origin + rng.uniform(0.1, 0.9, 2) * [nx * 0.1, ny * 0.1]
        NavigationFunction(goal, grid, radius)
        for _ in range(3):
            shift = rng.integers(-3, 4, 2)
            grid = follow(grid, edited(rng, moved(grid.occupied, *shift), 6), shift)
            nav = NavigationFunction(goal, grid, radius)
            assert_navigation_matches(nav, grid, goal, radius)
    assert repairs.made >= 30


@compiled
def test_a_blocked_corridor_reroutes_and_a_reopened_one_shortens_the_paths(monkeypatch):
    repairs = Repairs(monkeypatch)
    occ = np.zeros((30, 40), dtype=bool)
    occ[:, 20] = True
    occ[12:15, 20] = False                       # a door in a wall
    goal = [3.5, 1.5]
    grid = follow(fresh(occ, 0.1, (0.0, 0.0)), occ, (0, 0))
    before = NavigationFunction(goal, grid, 0.0).value([0.5, 1.5])
    shut = occ.copy()
    shut[12:15, 20] = True
    shut[25:28, 20] = False                      # the door moves
    grid = follow(grid, moved(shut, 1, 0), (1, 0))
    nav = NavigationFunction(goal, grid, 0.0)
    assert_navigation_matches(nav, grid, goal, 0.0)
    assert nav.value([0.5, 1.5]) > before + 0.3
    grid = follow(grid, moved(occ, 1, 0), (0, 0))   # the door is back
    nav = NavigationFunction(goal, grid, 0.0)
    assert_navigation_matches(nav, grid, goal, 0.0)
    assert nav.value([0.5, 1.5]) == pytest.approx(before, abs=1e-9)
    assert repairs.made == 2


@compiled
def test_a_far_goal_or_another_goal_builds_the_paths_anew(monkeypatch):
    """A goal beyond the window is reached through its border, which moved with it: the
    previous paths do not apply. A goal no previous function had has none to start from."""
    repairs = Repairs(monkeypatch)
    rng = np.random.default_rng(6)
    occ = rng.random((25, 25)) < 0.1
    grid = follow(fresh(occ, 0.1, (0.0, 0.0)), occ, (0, 0))
    far, near = [40.0, 1.0], [1.25, 1.25]
    NavigationFunction(far, grid, 0.1)
    NavigationFunction(near, grid, 0.1)
    grid = follow(grid, edited(rng, moved(occ, 2, 0), 5), (2, 0))
    for goal in (far, near, [2.05, 1.25]):
        nav = NavigationFunction(goal, grid, 0.1)
        assert_navigation_matches(nav, grid, goal, 0.1)
        assert "_paths" in nav.__dict__
    assert (repairs.made, repairs.declined) == (1, 1)


@compiled
def test_a_world_per_cycle_finds_the_previous_grids_navigation(monkeypatch):
    repairs = Repairs(monkeypatch)
    rng = np.random.default_rng(7)
    occ = rng.random((40, 40)) < 0.05
    grid = fresh(occ, 0.05, (-1.0, -1.0))
    goal, robot = np.array([0.6, 0.4]), np.array([0.0, 0.0])
    for cycle in range(4):
        nav = World(grid).navigation(goal, 0.1, near=robot, reach=1.0)
        if cycle:
            assert_navigation_matches(nav, grid, goal, 0.1, margin=2.0, near=robot, reach=1.0)
        grid = follow(grid, edited(rng, moved(grid.occupied, 1, 0), 4), (1, 0))
        robot = robot + [0.05, 0.0]
    assert repairs.made == 2      # the first update has only a fresh grid's function before it


@compiled
def test_grids_updated_from_an_empty_one_match_fresh_grids_to_the_bit():
    """A local map's first grid is an update of an empty window (cheaper than a transform)."""
    rng = np.random.default_rng(21)
    for _ in range(40):
        shape = tuple(rng.integers(1, 40, 2))
        occ = rng.random(shape) < rng.choice([0.002, 0.02, 0.2, 0.7])
        occ.flat[rng.integers(occ.size)] = True
        empty = fresh(np.zeros(shape, dtype=bool), 0.1, (0.0, 0.0))
        _ = empty.signed_distance
        shift = [int(rng.integers(-n + 1, n)) for n in shape[::-1]]     # some cells shared
        assert_updated_signed_distance(follow(empty, occ, shift))


def test_a_local_maps_first_grid_is_an_update_with_fresh_values():
    from dsmpepc_nlp.perception import LaserScan, LocalMap, LocalMapConfig

    local_map = LocalMap(LocalMapConfig(size=6.0))
    angles = np.linspace(-2.3, 2.3, 360)
    ranges = np.where(np.abs(angles) < 0.4, 1.5 / np.cos(angles), np.inf)   # a wall ahead
    local_map.update(LaserScan.from_angles(ranges, angles, 0.1, 30.0, (0.0, 0.0, 0.0), 0.0))
    grid = local_map.grid()
    assert grid.is_update and grid.occupied.any()
    expected = fresh(grid.occupied, grid.resolution, grid.origin)
    np.testing.assert_array_equal(grid.signed_distance, expected.signed_distance)
    nav = NavigationFunction([2.5, 0.5], grid, 0.2)
    np.testing.assert_allclose(nav.values, NavigationFunction([2.5, 0.5], expected, 0.2).values,
                               rtol=0, atol=1e-9)


@compiled
def test_a_local_map_sequence_gives_fresh_values():
    """End to end: a rolling lidar map's grids, each updated from the last."""
    from dsmpepc_nlp.perception import LaserScan, LocalMap, LocalMapConfig

    rng = np.random.default_rng(8)
    centres, radii = rng.uniform(-4, 8, (40, 2)), rng.uniform(0.1, 0.3, 40)
    keep = np.abs(centres[:, 1]) > radii + 0.6
    centres, radii = centres[keep], radii[keep]
    local_map = LocalMap(LocalMapConfig(size=6.0))
    angles = np.linspace(-2.3, 2.3, 360)
    grid = None
    for i in range(6):
        pose = np.array([0.13 * i, 0.02 * i, 0.1 * i])
        heading = pose[2] + angles
        rel = centres[None] - pose[:2]
        along = rel[..., 0] * np.cos(heading)[:, None] + rel[..., 1] * np.sin(heading)[:, None]
        across2 = (rel ** 2).sum(-1) - along ** 2
        with np.errstate(invalid="ignore"):
            entry = along - np.sqrt(radii ** 2 - across2)
        ranges = np.where((across2 <= radii ** 2) & (entry > 0), entry, np.inf).min(1)
        local_map.update(LaserScan.from_angles(ranges, angles, 0.1, 30.0, pose, 0.1 * i))
        served = local_map.grid()
        grid = (served if grid is None
                else OccupancyGrid.updated_from(grid, served.occupied, served.origin))
        _ = grid.signed_distance                     # as a plan reads it
        nav = NavigationFunction([2.5, 0.0], grid, 0.2, near=pose[:2], reach=2.0)
        if i:
            assert_updated_signed_distance(grid)
            assert "_paths" in nav.__dict__
        assert_navigation_matches(nav, grid, [2.5, 0.0], 0.2, near=pose[:2], reach=2.0)
