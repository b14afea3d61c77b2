"""The rolling local map from lidar scans: marking, clearing, rolling, the prior, decay, and
the exact traversal of each beam (numpy and numba alike)."""

import numpy as np
import pytest

from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.grid import OccupancyGrid
from dsmpepc_nlp.perception import LaserScan, LocalMap, LocalMapConfig, raycast

SENSOR = (0.01, 0.012)
"""Off the lattice's lines, so no beam of a test starts on a cell boundary."""


def _scan(ranges, angles, pose=(*SENSOR, 0.0), stamp=0.0, range_min=0.1, range_max=30.0):
    return LaserScan.from_angles(ranges, angles, range_min, range_max, pose, stamp)


def _at(grid, x, y) -> bool:
    """The grid's value at world (x, y)."""
    ix, iy = np.floor((np.array([x, y]) - grid.origin) / grid.resolution).astype(int)
    return bool(grid.occupied[iy, ix])


def _cell(local_map, x, y):
    ix, iy = np.floor((np.array([x, y]) - local_map.origin) / local_map.config.resolution)
    return int(iy), int(ix)


def test_a_wall_is_marked_where_it_is_and_the_space_before_it_cleared():
    angles = np.linspace(-0.5, 0.5, 101)
    wall_x = 3.025                                  # a column of cell centres
    ranges = (wall_x - SENSOR[0]) / np.cos(angles)
    local_map = LocalMap()
    counts = local_map.update(_scan(ranges, angles))
    grid = local_map.grid()
    marked_x = grid.origin[0] + (np.argwhere(grid.occupied)[:, 1] + 0.5) * grid.resolution
    assert np.allclose(marked_x, wall_x)
    hits_y = SENSOR[1] + (wall_x - SENSOR[0]) * np.tan(angles)
    assert all(_at(grid, wall_x, y) for y in hits_y)
    assert counts["cells_marked"] == np.count_nonzero(grid.occupied) > 50
    in_front = [(x, SENSOR[1]) for x in np.arange(0.0, 2.95, 0.05)]
    assert local_map.is_seen_free(in_front).all()
    assert not any(_at(grid, x, y) for x, y in in_front)
    assert not local_map.known()[_cell(local_map, -2.0, 0.0)]      # behind: never seen


def test_a_beam_with_no_return_clears_to_the_clearing_range_and_marks_nothing():
    local_map = LocalMap(LocalMapConfig(raytrace_max_range=4.0))
    counts = local_map.update(_scan([np.inf], [0.0]))
    assert counts["no_return"] == 1 and counts["cells_marked"] == 0
    assert not local_map.grid().occupied.any()
    y = SENSOR[1]
    assert local_map.is_seen_free([(0.02, y), (3.9, y), (4.2, y), (-1.0, y)]).tolist() == \
        [True, True, False, False]
    assert counts["cells_cleared"] == 81            # x in [0, 4.05): the end at 4.01 included


def test_hits_past_the_ranges_clear_up_to_them_and_mark_nothing():
    local_map = LocalMap(LocalMapConfig(obstacle_max_range=2.0, raytrace_max_range=4.0))
    counts = local_map.update(_scan([3.0, 6.0], [0.0, np.pi / 2]))
    assert counts["beyond_obstacle_range"] == 2 and counts["cells_marked"] == 0
    assert not local_map.grid().occupied.any()
    x, y = SENSOR
    # along +x the beam ends at its hit (3.01): the hit cell is not seen free
    assert local_map.is_seen_free([(2.99, y), (3.01, y)]).tolist() == [True, False]
    # along +y the beam is cut at 4 m (4.012): its last cell is seen free, none past it
    assert local_map.is_seen_free([(x, 4.01), (x, 4.06)]).tolist() == [True, False]


def test_bad_range_values_are_dropped_and_counted_not_raised():
    ranges = [np.nan, -1.0, -np.inf, 0.05, 35.0, np.inf, 2.0]
    angles = np.linspace(0.0, np.pi, len(ranges))
    valid, counts = _scan(ranges, angles).validity()
    assert valid.tolist() == [False, False, False, False, False, True, True]
    local_map = LocalMap()
    counts = local_map.update(_scan(ranges, angles))
    assert (counts["not_a_number"], counts["below_range_min"], counts["above_range_max"],
            counts["no_return"], counts["hits"], counts["used"]) == (1, 3, 1, 1, 1, 2)
    assert counts["cells_marked"] == 1
    # a dropped beam clears nothing: beam 0 (NaN) points along +x, beam 4 (35 m) at 120 deg
    assert not local_map.is_seen_free([(1.0, SENSOR[1])])[0]
    assert not local_map.is_seen_free([(SENSOR[0] - 0.5, SENSOR[1] + 0.866)])[0]


def test_bad_fields_raise_naming_the_field():
    with pytest.raises(InputError, match=r"angles has shape \(2,\): scan of the wrong length"):
        _scan([1.0, 2.0, 3.0], [0.0, 0.1])
    with pytest.raises(InputError, match=r"^pose=\(nan, 0\.0, 0\.0\): expected 3 finite"):
        _scan([1.0], [0.0], pose=(np.nan, 0.0, 0.0))
    with pytest.raises(InputError, match=r"^stamp=inf: expected a finite number"):
        _scan([1.0], [0.0], stamp=np.inf)
    with pytest.raises(InputError, match=r"^range_max=0\.1: expected a number > range_min"):
        _scan([1.0], [0.0], range_min=0.1, range_max=0.1)
    with pytest.raises(InputError, match=r"^range_min=-1\.0"):
        LaserScan([1.0], 0.0, 0.1, -1.0, 5.0)
    with pytest.raises(InputError, match=r"^unknown='maybe': expected one of 'free', 'occ"):
        LocalMapConfig(unknown="maybe")
    with pytest.raises(InputError, match=r"^decay=0\.0"):
        LocalMapConfig(decay=0.0)


def test_a_stamp_earlier_than_the_previous_update_raises():
    local_map = LocalMap()
    local_map.update(_scan([2.0], [0.0], stamp=1.0))
    local_map.update(_scan([2.0], [0.0], stamp=1.0))           # the same stamp is fine
    with pytest.raises(InputError, match=r"^stamp=0\.5: expected >= 1\.0"):
        local_map.update(_scan([2.0], [0.0], stamp=0.5))


def test_the_window_rolls_with_the_sensor_and_forgets_what_scrolls_out():
    local_map = LocalMap()
    local_map.update(_scan([9.0, 8.0], [0.0, np.pi]))          # marks at x = 9.01 and -7.99
    y = SENSOR[1]
    assert _at(local_map.grid(), 9.01, y) and _at(local_map.grid(), -7.99, y)
    nothing = [np.nan]                                          # dropped: the scan only rolls
    local_map.update(_scan(nothing, [0.0], pose=(15.01, y, 0.0), stamp=1.0))
    grid = local_map.grid()
    assert grid.shape == (400, 400)
    assert np.allclose(grid.origin, [5.0, -10.0])
    assert _at(grid, 9.01, y) and np.count_nonzero(grid.occupied) == 1
    local_map.update(_scan(nothing, [0.0], pose=(*SENSOR, 0.0), stamp=2.0))
    grid = local_map.grid()
    assert _at(grid, 9.01, y) and not _at(grid, -7.99, y)      # scrolled out: forgotten
    assert not local_map.known()[_cell(local_map, -7.99, y)]
    assert np.count_nonzero(grid.occupied) == 1


def test_a_later_scan_clears_the_mark_of_an_obstacle_that_moved():
    local_map = LocalMap()
    local_map.update(_scan([3.0], [0.0]))
    first = local_map.grid()
    assert _at(first, 3.01, SENSOR[1])
    assert local_map.is_seen_free([(2.99, SENSOR[1]), (3.01, SENSOR[1])]).tolist() == \
        [True, False]                                   # the hit cell is not seen free
    local_map.update(_scan([5.0], [0.0], stamp=0.1))
    changed = local_map.changed_cells()
    grid = local_map.grid()
    assert not _at(grid, 3.01, SENSOR[1]) and _at(grid, 5.01, SENSOR[1])
    assert sorted(map(tuple, np.argwhere(changed))) == sorted(
        [_cell(local_map, 3.01, SENSOR[1]), _cell(local_map, 5.01, SENSOR[1])])


def test_one_beams_clearing_never_erases_another_beams_mark_of_the_same_scan():
    short, long_ = ([2.0], [0.0]), ([5.0], [0.001])    # the long beam passes the short's hit
    for order in (0, 1):
        pair = (short, long_) if order == 0 else (long_, short)
        ranges = [r for beam in pair for r in beam[0]]
        angles = [a for beam in pair for a in beam[1]]
        local_map = LocalMap()
        counts = local_map.update(_scan(ranges, angles))
        assert _at(local_map.grid(), 2.01, SENSOR[1])
        assert not local_map.is_seen_free([(2.01, SENSOR[1])])[0]
        assert counts["cells_cleared"] == np.count_nonzero(local_map.seen_free())
    local_map.update(_scan(*long_, stamp=1.0))          # the long beam alone clears that cell
    assert not _at(local_map.grid(), 2.01, SENSOR[1])


def test_unknown_cells_read_as_the_policy_says():
    for policy in ("free", "occupied"):
        local_map = LocalMap(LocalMapConfig(unknown=policy))
        local_map.update(_scan([3.0], [0.0]))
        grid = local_map.grid()
        assert _at(grid, -2.0, 0.0) == (policy == "occupied")    # never seen
        assert not _at(grid, 1.5, SENSOR[1])                     # seen free
        assert _at(grid, 3.01, SENSOR[1])                        # marked


def test_the_prior_is_merged_under_the_observations():
    occupied = np.zeros((100, 100), dtype=bool)                 # [-5, 5]^2 at 0.1 m
    occupied[45:55, 70:72] = True                               # x in [2.0, 2.2), y in [-0.5, 0.5)
    occupied[90, 10] = True                                     # x in [-4.0, -3.9)
    prior = OccupancyGrid(occupied, 0.1, (-5.0, -5.0))
    local_map = LocalMap(LocalMapConfig(unknown="occupied"), prior)
    local_map.update(_scan([4.0], [0.0]))                       # through the prior's block
    grid = local_map.grid()
    y = SENSOR[1]
    assert _at(grid, 2.01, y) and _at(grid, 2.19, y)            # prior occupied stays occupied
    assert local_map.known()[_cell(local_map, 2.01, y)]         # though the lidar saw it free
    assert not _at(grid, 2.21, y) and not _at(grid, 1.0, y)     # seen free, prior free
    assert _at(grid, 4.01, y)                                   # the hit
    assert _at(grid, -3.95, 4.05) and not _at(grid, -3.85, 4.05)
    assert not _at(grid, -2.0, 3.0)                             # never seen, in the prior: free
    assert _at(grid, -8.0, 8.0)                                 # never seen, outside: unknown


def test_a_finer_priors_thin_wall_is_kept():
    occupied = np.zeros((50, 50), dtype=bool)                   # [0, 1)^2 at 0.02 m
    occupied[:, 25] = True                                      # x in [0.50, 0.52)
    local_map = LocalMap(prior=OccupancyGrid(occupied, 0.02, (0.0, 0.0)))
    grid = local_map.grid()
    assert _at(grid, 0.51, 0.5) and not _at(grid, 0.56, 0.5) and not _at(grid, 0.49, 0.5)


def test_decay_forgets_marks_not_seen_again():
    local_map = LocalMap(LocalMapConfig(decay=1.0))
    local_map.update(_scan([3.0, 3.0], [0.0, np.pi / 2], stamp=0.0))
    local_map.update(_scan([3.0], [np.pi / 2], stamp=1.0))      # only the second seen again
    assert _at(local_map.grid(), 3.01, SENSOR[1])
    counts = local_map.update(_scan([np.nan], [0.0], stamp=1.8))
    grid = local_map.grid()
    assert counts["cells_forgotten"] == 1
    assert not _at(grid, 3.01, SENSOR[1]) and _at(grid, SENSOR[0], 3.012)
    assert not local_map.known()[_cell(local_map, 3.01, SENSOR[1])]
    assert local_map.is_seen_free([(2.9, SENSOR[1])])[0]        # seen free stays


def test_grid_is_an_occupancy_grid_on_the_lattice_and_cached():
    local_map = LocalMap()
    scan = _scan([3.0], [0.0], pose=(1.234, -0.51, 0.3))
    local_map.update(scan)
    grid = local_map.grid()
    assert isinstance(grid, OccupancyGrid) and grid.resolution == 0.05
    assert np.allclose(grid.origin, [(24 - 200) * 0.05, (-11 - 200) * 0.05])
    assert local_map.grid() is grid
    local_map.update(scan)                                      # nothing changes
    assert local_map.grid() is grid and not local_map.changed_cells().any()
    moved = _scan([3.0], [0.0], pose=(1.29, -0.51, 0.3))        # one cell along x
    local_map.update(moved)
    changed = local_map.changed_cells()
    assert changed[:, -1].all()                                 # the column scrolled in
    assert local_map.grid() is not grid


def _window_beams(rng, n, count):
    """Random beams from a sensor in the window's middle (some on cell lines, some along the
    axes or the diagonals), cut to the window, and their hit cells."""
    u0, v0 = rng.uniform(n / 2 - 1, n / 2 + 1, 2)
    u0 = float(np.floor(u0)) if rng.random() < 0.3 else u0
    angles = rng.uniform(-np.pi, np.pi, count)
    angles[: count // 4] = np.round(angles[: count // 4] / (np.pi / 4)) * (np.pi / 4)
    length = rng.uniform(0.0, 1.5 * n, count)
    du, dv = np.cos(angles) * length, np.sin(angles) * length
    t = raycast.window_fraction(u0, v0, du, dv, n)
    u1, v1 = u0 + t * du, v0 + t * dv
    return u0, v0, u1, v1, raycast.cell_index(u1, v1, n)


def _touches(ix, iy, u0, v0, u1, v1):
    """Whether the segment meets the closed square of cell (ix, iy) (Liang-Barsky)."""
    low, high = 0.0, 1.0
    for p, q in ((-(u1 - u0), u0 - ix), (u1 - u0, ix + 1 - u0),
                 (-(v1 - v0), v0 - iy), (v1 - v0, iy + 1 - v0)):
        if p == 0.0:
            if q < -1e-9:
                return False
        elif p < 0.0:
            low = max(low, q / p)
        else:
            high = min(high, q / p)
    return low <= high + 1e-9


def test_each_beam_sets_exactly_the_cells_it_passes_through():
    rng = np.random.default_rng(3)
    n = 24
    for _ in range(4):
        u0, v0, u1, v1, exclude = _window_beams(rng, n, 16)
        for b in range(u1.size):
            mask = np.zeros(n * n, dtype=bool)
            raycast.traverse_numpy(u0, v0, u1[b:b + 1], v1[b:b + 1], exclude[b:b + 1], n, mask)
            cells = {(i % n, i // n) for i in np.flatnonzero(mask)}
            s = np.linspace(0.0, 1.0, 20001)[:-1]
            ix = np.floor(u0 + s * (u1[b] - u0)).astype(int)
            iy = np.floor(v0 + s * (v1[b] - v0)).astype(int)
            sampled = {(i, j) for i, j in zip(ix, iy) if j * n + i != exclude[b]}
            assert sampled <= cells                             # none skipped
            assert all(_touches(i, j, u0, v0, u1[b], v1[b]) for i, j in cells)


def test_the_numpy_and_compiled_traversals_agree(monkeypatch):
    pytest.importorskip("numba")
    if raycast._compiled_kernel() is None:
        pytest.skip("numba kernel unavailable")
    rng = np.random.default_rng(7)
    n = 400
    for _ in range(5):
        u0, v0, u1, v1, exclude = _window_beams(rng, n, 720)
        by_numpy, by_numba = np.zeros(n * n, dtype=bool), np.zeros(n * n, dtype=bool)
        raycast.traverse_numpy(u0, v0, u1, v1, exclude, n, by_numpy)
        raycast._compiled_kernel()(u0, v0, u1, v1, exclude, n, by_numba)
        assert np.array_equal(by_numpy, by_numba) and by_numpy.sum() > 1000
    angles = np.linspace(-0.75 * np.pi, 0.75 * np.pi, 720)
    scans = [_scan(rng.uniform(0.5, 12.0, 720), angles, pose=(0.3 * i, 0.1 * i, 0.05 * i),
                   stamp=float(i)) for i in range(3)]
    results = []
    for off in ("1", "0"):
        monkeypatch.setenv("DSMPEPC_NO_COMPILE", off)
        local_map = LocalMap()
        counts = [local_map.update(scan) for scan in scans]
        results.append((counts, local_map.grid().occupied, local_map.seen_free()))
    assert results[0][0] == results[1][0]
    assert np.array_equal(results[0][1], results[1][1])
    assert np.array_equal(results[0][2], results[1][2])


def test_returns_on_a_face_along_a_cell_edge_mark_the_cells_behind_it():
    """A wall whose face runs along a cell edge (x = 2.0), seen with 1 mm of range noise: the
    return's own cell is the free one before the face for about half the beams; marked a
    centimetre beyond the return, every mark lies behind the face."""
    angles = np.linspace(-0.6, 0.6, 241)
    ranges = 2.0 / np.cos(angles) + np.random.default_rng(3).normal(0.0, 0.001, angles.size)
    scan = LaserScan.from_angles(ranges, angles, 0.1, 30.0, (0.0, 0.0, 0.0), 0.0)
    before = {}
    for beyond in (0.0, 0.01):
        local_map = LocalMap(LocalMapConfig(size=8.0, mark_beyond=beyond))
        local_map.update(scan)
        grid = local_map.grid()
        rows, columns = np.nonzero(grid.occupied)
        x_centres = grid.origin[0] + (columns + 0.5) * grid.resolution
        before[beyond] = int(np.sum(x_centres < 2.0))
        assert np.all(np.abs(x_centres - 2.0) < grid.resolution)        # the face's two columns
    assert before[0.0] > 10 and before[0.01] == 0


def test_marking_beyond_a_return_is_checked():
    with pytest.raises(InputError, match="mark_beyond"):
        LocalMapConfig(mark_beyond=0.2)          # more than a cell
    with pytest.raises(InputError, match="mark_beyond"):
        LocalMapConfig(mark_beyond=-0.01)
