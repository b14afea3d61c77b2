"""The people tracker (dsmpepc_nlp.perception.tracker): noisy detections in, tracks with
estimated velocities and the planner's DynamicObstacles out."""

import ast
import json
import math
from pathlib import Path

import numpy as np
import pytest

from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.world import DynamicObstacle
from dsmpepc_nlp.perception import Detections, PeopleTracker, Track, TrackerConfig

PERIOD = 0.2
"""Seconds between detection cycles in these tests."""
NOISE = 0.1
"""Standard deviation (m) of the detection noise on each axis."""


def _walk(start, velocity, steps, rng, noise=NOISE):
    """Noisy detections (steps, 2) and true positions of a walker at constant velocity."""
    times = PERIOD * np.arange(steps)
    truth = np.asarray(start, float) + times[:, None] * np.asarray(velocity, float)
    return truth + rng.normal(0.0, noise, truth.shape), truth


def _standing(tracker, position, stamps):
    out = []
    for stamp in stamps:
        out = tracker.update(Detections([position], stamp))
    return out


# ---------------------------------------------------------------------------------------------
# velocity estimation


def test_walker_velocity_converges_and_beats_a_smoothed_finite_difference():
    rng = np.random.default_rng(7)
    velocity = 1.2 * np.array([math.cos(0.6), math.sin(0.6)])
    detections, _ = _walk([-2.0, -1.0], velocity, 21, rng)
    tracker = PeopleTracker()
    smoothed = None
    filter_errors, difference_errors = [], []
    for k, position in enumerate(detections):
        tracks = tracker.update(Detections(position[None], PERIOD * k))
        if k:
            # The naive estimate: successive differences, exponentially smoothed (alpha 0.3).
            difference = (position - detections[k - 1]) / PERIOD
            smoothed = difference if smoothed is None else 0.7 * smoothed + 0.3 * difference
        if k == 15:  # 3 s
            assert len(tracks) == 1
            assert np.linalg.norm(tracks[0].velocity - velocity) < 0.25
        if k >= 5:  # from 1 s on
            filter_errors.append(tracks[0].velocity - velocity)
            difference_errors.append(smoothed - velocity)
    rms_filter = math.sqrt(np.mean(np.sum(np.square(filter_errors), axis=1)))
    rms_difference = math.sqrt(np.mean(np.sum(np.square(difference_errors), axis=1)))
    assert rms_filter < rms_difference
    assert rms_filter < 0.25


def test_crossing_walkers_keep_their_ids():
    """Two walkers cross at right angles, 0.6 m apart at their closest, for several seeds.

    From 2.4 s on (2.3 m apart; the first reaches the crossing at 3.3 s, the second at 4 s)
    each walker's nearest track keeps its id, and there are exactly two tracks.
    """
    for seed in range(5):
        rng = np.random.default_rng(seed)
        first, first_truth = _walk([-4.0, 0.0], [1.2, 0.0], 40, rng)
        # The second reaches the crossing 0.7 s after the first: 0.59 m apart at the closest.
        second, second_truth = _walk([0.0, -4.0 - 1.2 * 0.7], [0.0, 1.2], 40, rng)
        tracker = PeopleTracker()
        before = None
        for k in range(40):
            tracks = tracker.update(Detections(np.stack([first[k], second[k]]), PERIOD * k))
            if k < 12:
                continue
            assert len(tracks) == 2, (seed, k)
            nearest = []
            for truth in (first_truth, second_truth):
                track = min(tracks, key=lambda t, k=k, truth=truth: np.linalg.norm(
                    t.position - truth[k]))
                assert np.linalg.norm(track.position - truth[k]) < 0.4, (seed, k)
                nearest.append(track.id)
            before = before or nearest
            assert nearest == before, (seed, k)


# ---------------------------------------------------------------------------------------------
# track lifetime


def test_a_track_is_reported_after_confirm_hits_and_deleted_after_max_misses():
    tracker = PeopleTracker(TrackerConfig(confirm_hits=3, max_misses=5))
    for k in range(2):
        assert tracker.update(Detections([[1.0, 2.0]], PERIOD * k)) == []
        assert tracker.obstacles() == []
        assert [t.confirmed for t in tracker.tracks] == [False]
    tracks = tracker.update(Detections([[1.0, 2.0]], PERIOD * 2))
    assert len(tracks) == 1 and tracks[0].confirmed and tracks[0].hits == 3
    track_id = tracks[0].id
    for miss in range(1, 5):
        tracks = tracker.update(Detections(np.zeros((0, 2)), PERIOD * (2 + miss)))
        assert [(t.id, t.misses) for t in tracks] == [(track_id, miss)]
        assert len(tracker.obstacles()) == 1
    assert tracker.update(Detections([], PERIOD * 7)) == []
    assert tracker.tracks == [] and tracker.obstacles() == []


def test_a_tentative_track_dies_at_its_first_miss():
    tracker = PeopleTracker()
    _standing(tracker, [0.0, 0.0], [0.0, 0.2])
    assert len(tracker.tracks) == 1
    tracker.update(Detections([], 0.4))
    assert tracker.tracks == []


def test_a_track_unseen_for_max_unseen_time_is_deleted_whatever_its_misses():
    tracker = PeopleTracker(TrackerConfig(max_misses=5, max_unseen_time=1.5))
    _standing(tracker, [0.0, 0.0], [0.0, 0.2, 0.4])
    assert tracker.update(Detections([], 1.8)) != []  # 1.4 s unseen
    assert tracker.update(Detections([], 2.0)) == []  # 1.6 s unseen, 2 misses


def test_isolated_false_detections_never_become_confirmed_tracks():
    rng = np.random.default_rng(0)
    tracker = PeopleTracker()
    born = set()
    for k in range(100):
        false = rng.uniform(-15.0, 15.0, (5, 2))
        assert tracker.update(Detections(false, PERIOD * k)) == []
        assert tracker.obstacles() == []
        born |= {t.id for t in tracker.tracks}
    assert len(born) > 400  # they were all seen, as tentative tracks


def test_a_walker_among_false_detections_keeps_one_track():
    rng = np.random.default_rng(3)
    walker, truth = _walk([-3.0, 0.0], [1.0, 0.5], 30, rng)
    tracker = PeopleTracker()
    ids = set()
    for k in range(30):
        false = rng.uniform(-15.0, 15.0, (5, 2))
        tracks = tracker.update(Detections(np.vstack([walker[k], false]), PERIOD * k))
        ids |= {t.id for t in tracks}
    assert len(ids) == 1 and len(tracks) == 1
    assert np.linalg.norm(tracks[0].position - truth[-1]) < 0.2
    assert np.linalg.norm(tracks[0].velocity - [1.0, 0.5]) < 0.4


# ---------------------------------------------------------------------------------------------
# bad input


def test_rows_with_bad_numbers_are_dropped_and_counted():
    detections = Detections([[0.0, 0.0], [np.nan, 1.0], [np.inf, 0.0], [2.0, 2.0], [1.0, 1e9]],
                            1.0, radii=[0.3, 0.3, 0.3, -1.0, 0.3], ids=[1, 2, 3, 4, 5])
    assert detections.dropped == 4
    assert detections.positions.tolist() == [[0.0, 0.0]]
    assert detections.radii.tolist() == [0.3] and detections.ids.tolist() == [1]
    tracker = PeopleTracker()
    tracker.update(detections)
    tracker.update(Detections([[5.0, 5.0], [0.0, np.nan]], 1.2))
    assert tracker.dropped == 5
    assert [t.id for t in tracker.tracks] == [2]  # unlabelled: a fresh id; 1 missed, deleted


@pytest.mark.parametrize("empty", [[], np.zeros((0, 2))])
def test_no_detections_is_allowed(empty):
    detections = Detections(empty, 0.0)
    assert len(detections) == 0 and detections.positions.shape == (0, 2)
    assert PeopleTracker().update(detections) == []


@pytest.mark.parametrize("kwargs, field", [
    ({"positions": [1.0, 2.0], "stamp": 0.0}, "positions"),
    ({"positions": [[1.0, 2.0, 3.0]], "stamp": 0.0}, "positions"),
    ({"positions": [["a", "b"]], "stamp": 0.0}, "positions"),
    ({"positions": [[1.0, 2.0]], "stamp": 0.0, "radii": [0.3, 0.3]}, "radii"),
    ({"positions": [[1.0, 2.0]], "stamp": 0.0, "ids": [1, 2]}, "ids"),
    ({"positions": [[1.0, 2.0]], "stamp": 0.0, "ids": [1.5]}, "ids"),
    ({"positions": [[1.0, 2.0], [3.0, 4.0]], "stamp": 0.0, "ids": [7, 7]}, "ids"),
    ({"positions": [[1.0, 2.0]], "stamp": math.nan}, "stamp"),
    ({"positions": [[1.0, 2.0]], "stamp": math.inf}, "stamp"),
    ({"positions": [[1.0, 2.0]], "stamp": "now"}, "stamp"),
])
def test_bad_fields_raise_input_errors_naming_them(kwargs, field):
    with pytest.raises(InputError, match=rf"^{field}=.*expected"):
        Detections(**kwargs)


@pytest.mark.parametrize("kwargs, field", [
    ({"measurement_std": 0.0}, "measurement_std"),
    ({"acceleration_density": -1.0}, "acceleration_density"),
    ({"gate": math.nan}, "gate"),
    ({"confirm_hits": 0}, "confirm_hits"),
    ({"max_misses": 2.5}, "max_misses"),
    ({"default_radius": -0.3}, "default_radius"),
    ({"max_speed": math.inf}, "max_speed"),
])
def test_bad_settings_raise_input_errors_naming_them(kwargs, field):
    with pytest.raises(InputError, match=rf"TrackerConfig\.{field} = "):
        TrackerConfig(**kwargs)


def test_every_setting_says_where_its_default_comes_from():
    source = Path(__file__).resolve().parents[1] / "dsmpepc_nlp/perception/detections.py"
    tree = ast.parse(source.read_text())
    config = next(node for node in tree.body
                  if isinstance(node, ast.ClassDef) and node.name == "TrackerConfig")
    body = config.body
    documented = {node.target.id: body[i + 1].value.value for i, node in enumerate(body[:-1])
                  if isinstance(node, ast.AnnAssign) and isinstance(body[i + 1], ast.Expr)}
    fields = {node.target.id for node in body if isinstance(node, ast.AnnAssign)}
    assert fields == set(documented)
    for name, text in documented.items():
        assert "our choice" in text.lower() or any(ch.isdigit() for ch in text), name


def test_a_backward_stamp_raises_and_an_equal_stamp_does_not_predict():
    tracker = PeopleTracker()
    rng = np.random.default_rng(1)
    walker, _ = _walk([0.0, 0.0], [1.2, 0.0], 10, rng)
    for k in range(10):
        tracker.update(Detections(walker[k][None], PERIOD * k))
    before = tracker.tracks[0]
    with pytest.raises(InputError, match=r"^stamp=1\.0: .*no earlier than"):
        tracker.update(Detections([], 1.0))
    after = tracker.update(Detections([], before.stamp))[0]
    assert np.array_equal(after.mean, before.mean) and after.misses == 1
    with pytest.raises(InputError, match="detections="):
        tracker.update([[0.0, 0.0]])
    tracker.reset()
    assert tracker.tracks == [] and tracker.stamp is None
    tracker.update(Detections([], 0.0))  # earlier than before the reset: allowed


def test_the_detectors_ids_are_honoured():
    tracker = PeopleTracker()
    for k in range(3):
        tracker.update(Detections([[0.0, 0.0], [1.0, 0.0]], PERIOD * k, ids=[7, 42]))
    assert [t.id for t in tracker.tracks] == [7, 42]
    # The detector swaps who is where: the tracker follows the ids, not the gate.
    tracks = tracker.update(Detections([[1.0, 0.0], [0.0, 0.0]], 0.6, ids=[7, 42]))
    by_id = {t.id: t for t in tracks}
    assert by_id[7].position[0] > by_id[42].position[0]
    assert by_id[7].hits == 4 and by_id[7].misses == 0
    tracker.update(Detections([[5.0, 5.0]], 0.8))  # unlabelled: a fresh id above the detector's
    assert max(t.id for t in tracker.tracks) == 43


# ---------------------------------------------------------------------------------------------
# what the planner reads


def _tracked_walker(seed=2, velocity=(1.0, -0.5), radii=None):
    rng = np.random.default_rng(seed)
    walker, _ = _walk([0.0, 0.0], velocity, 15, rng)
    tracker = PeopleTracker()
    for k in range(15):
        tracker.update(Detections(walker[k][None], PERIOD * k,
                                  radii=None if radii is None else [radii[k % len(radii)]]))
    return tracker


def test_obstacles_carry_the_estimated_velocity():
    tracker = _tracked_walker()
    (track,) = tracker.tracks
    (obstacle,) = tracker.obstacles()
    assert isinstance(obstacle, DynamicObstacle) and obstacle.kind == "pedestrian"
    assert np.allclose(obstacle.velocity, track.velocity)
    assert np.linalg.norm(obstacle.velocity - [1.0, -0.5]) < 0.4
    assert np.allclose(obstacle.centers[0], track.position)
    # the default radius, grown by TrackerConfig.inflate standard deviations of the position
    assert obstacle.radii.tolist() == pytest.approx([0.3 + 2.0 * track.position_std])


def test_obstacles_are_predicted_to_now():
    tracker = _tracked_walker()
    (track,) = tracker.tracks
    (ahead,) = tracker.obstacles(now=track.stamp + 1.5)
    assert np.allclose(ahead.centers[0], track.position + 1.5 * track.velocity)
    (behind,) = tracker.obstacles(now=track.stamp - 0.5)
    assert np.allclose(behind.centers[0], track.position - 0.5 * track.velocity)
    with pytest.raises(InputError, match="^now="):
        tracker.obstacles(now=math.nan)


def test_a_reported_speed_is_clipped():
    tracker = PeopleTracker(TrackerConfig(max_speed=2.5))
    for k in range(10):  # 10 m/s: only a detector's ids would keep this together
        tracker.update(Detections([[2.0 * k, 0.0]], PERIOD * k, ids=[1]))
    (track,) = tracker.tracks
    assert track.velocity[0] > 5.0
    (obstacle,) = tracker.obstacles()
    assert np.linalg.norm(obstacle.velocity) == pytest.approx(2.5)
    assert obstacle.velocity[1] == pytest.approx(0.0, abs=1e-9)


def test_the_radius_is_the_median_of_the_detected_radii():
    tracker = _tracked_walker(radii=[0.25, 0.26, 0.8, 0.24, 0.25])  # 0.8: two people merged
    assert tracker.tracks[0].radius == pytest.approx(0.25)
    grown = TrackerConfig().inflate * tracker.tracks[0].position_std
    assert tracker.obstacles()[0].radii.tolist() == pytest.approx([0.25 + grown])


def test_tracks_are_read_only_and_a_young_track_is_less_certain():
    tracker = PeopleTracker()
    young = _standing(tracker, [0.0, 0.0], [0.0, 0.2, 0.4])[0]
    old = _standing(tracker, [0.0, 0.0], PERIOD * np.arange(3, 20))[0]
    assert isinstance(old, Track) and old.age == pytest.approx(3.8)
    assert young.position_std > old.position_std > 0.0
    with pytest.raises(ValueError):
        old.mean[0] = 1.0
    assert tracker.tracks[0].mean[0] == old.mean[0]


def test_inflate_grows_each_radius_by_its_tracks_position_std():
    plain, inflated = PeopleTracker(TrackerConfig(inflate=0.0)), PeopleTracker()   # (2.0)
    assert inflated.config.inflate == 2.0
    for tracker in (plain, inflated):
        _standing(tracker, [0.0, 0.0], [0.0, 0.2, 0.4])        # young: its std is large
    track = inflated.tracks[0]
    assert track.position_std > 0.05
    assert inflated.obstacles()[0].radii[0] == pytest.approx(
        plain.obstacles()[0].radii[0] + 2.0 * track.position_std)
    for tracker in (plain, inflated):                           # older: a smaller margin
        _standing(tracker, [0.0, 0.0], PERIOD * np.arange(3, 20))
    grown = inflated.obstacles()[0].radii[0] - plain.obstacles()[0].radii[0]
    assert grown == pytest.approx(2.0 * inflated.tracks[0].position_std)
    assert 0.0 < grown < 2.0 * track.position_std


def test_perception_imports_nothing_outside_the_core():
    package = Path(__file__).resolve().parents[1] / "dsmpepc_nlp" / "perception"
    for path in sorted(package.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 2:
                assert (node.module or "").split(".")[0] == "core", (path.name, node.module)
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                name = node.module or ""
                assert not name.startswith("dsmpepc_nlp") or name.startswith(
                    ("dsmpepc_nlp.core", "dsmpepc_nlp.perception")), (path.name, name)
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    assert not alias.name.startswith("dsmpepc_nlp") or alias.name.startswith(
                        ("dsmpepc_nlp.core", "dsmpepc_nlp.perception")), (path.name, alias.name)
            assert not (isinstance(node, ast.ImportFrom) and node.level > 2), path.name


def test_the_benchmark_tool_runs(capsys):
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "tools" / "dev" / "bench_tracker.py"
    spec = importlib.util.spec_from_file_location("bench_tracker", path)
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    tool.main(["--cycles", "20", "--people", "4", "--json"])
    result = json.loads(capsys.readouterr().out)
    assert result["cycles"] == 20 and result["median_ms"] > 0.0
    assert result["confirmed_at_end"] == 4


def test_a_planner_imports_no_scipy_optimize():
    """The tracker's assignment (scipy.optimize, ~0.4 s of imports) waits until a tracker
    assigns, so a fresh process's first plan does not pay for it."""
    import subprocess
    import sys

    code = ("import sys; import dsmpepc_nlp; from dsmpepc_nlp import Planner; "
            "print('scipy.optimize' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout.strip() == "False"
