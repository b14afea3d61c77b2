"""Sensing profiles (sim/sensing.py) and one robot's simulated senses (sim/senses.py): strict
profile files, the lidar's geometry, the detector's view, the plant, and episodes that plan
from what the robot senses while the truth judges them."""

import dataclasses
import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid
from dsmpepc_nlp.sim.scenario import load_scenario
from dsmpepc_nlp.sim.senses import Senses, circle_ranges
from dsmpepc_nlp.sim.sensing import (
    BUILTIN_PROFILES,
    DetectorSettings,
    LidarSettings,
    PlantSettings,
    SensingProfile,
    load_profile,
)
from dsmpepc_nlp.sim.simulate import simulate

SAMPLER = SolverConfig.sampling(n_samples=64)


def _walled(x_wall=3.0):
    """A 10 x 10 m map with a wall of cells from x = ``x_wall`` on."""
    occupied = np.zeros((100, 100), bool)
    occupied[:, int(x_wall / 0.1):] = True
    return OccupancyGrid(occupied, 0.1, (0.0, 0.0))


# -- profiles ----------------------------------------------------------------------------------


def test_the_builtins_are_what_their_names_say():
    assert BUILTIN_PROFILES["oracle"].is_oracle
    lidar, tracked = BUILTIN_PROFILES["lidar"], BUILTIN_PROFILES["tracked"]
    assert lidar.lidar is not None and lidar.detector is None and lidar.plant is None
    assert tracked.detector is not None and tracked.lidar is None
    realistic = BUILTIN_PROFILES["realistic"]
    assert None not in (realistic.lidar, realistic.detector, realistic.localisation,
                        realistic.plant)
    assert LidarSettings().beams == 720 and LidarSettings().fov == pytest.approx(4.712389)


def test_a_profile_file_is_read_strictly(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text("base: lidar\nlidar: {beams: 360, range_max: 8.0}\nplant: true\n")
    profile = load_profile(path)
    assert profile.name == "mine" and profile.lidar.beams == 360
    assert profile.lidar.range_max == 8.0 and profile.lidar.fov == LidarSettings().fov
    assert profile.plant == PlantSettings() and profile.detector is None
    path.write_text("lidar: {beems: 360}\n")
    with pytest.raises(InputError, match=r"mine.yaml: lidar: beems: unknown key; did you mean "
                                         r"'beams'\?"):
        load_profile(path)
    path.write_text("lidar: {range_max: -1.0}\n")
    with pytest.raises(InputError, match=r"mine.yaml: lidar: .*range_max"):
        load_profile(path)
    path.write_text("detectr: true\n")
    with pytest.raises(InputError, match="did you mean 'detector'"):
        load_profile(path)
    with pytest.raises(InputError, match="did you mean 'lidar'"):
        load_profile("lidr")
    with pytest.raises(InputError, match="file not found"):
        load_profile(tmp_path / "absent.yaml")


def test_settings_are_validated():
    with pytest.raises(InputError, match="beams"):
        LidarSettings(beams=1)
    with pytest.raises(InputError, match="range_min"):
        LidarSettings(range_min=5.0, range_max=4.0)
    with pytest.raises(InputError, match="mark_beyond"):      # at profile load, not in a run
        LidarSettings(mark_beyond=0.06, resolution=0.05)
    with pytest.raises(InputError, match="miss_rate"):
        DetectorSettings(miss_rate=1.5)
    with pytest.raises(InputError, match="delay"):
        PlantSettings(delay=-1)


# -- the senses --------------------------------------------------------------------------------


def test_circle_ranges_agree_with_marching_along_the_ray():
    rng = np.random.default_rng(1)
    centres, radii = rng.uniform(-3, 3, (6, 2)), rng.uniform(0.1, 0.5, 6)
    origin, headings = np.array([0.2, -0.1]), np.linspace(-math.pi, math.pi, 90)
    got = circle_ranges(origin, headings, centres, radii)
    steps = np.arange(0.0, 10.0, 1e-3)
    for heading, value in zip(headings, got):
        points = origin + steps[:, None] * [math.cos(heading), math.sin(heading)]
        inside = np.any(np.linalg.norm(points[:, None] - centres[None], axis=-1) <= radii, 1)
        expected = steps[np.argmax(inside)] if inside.any() else np.inf
        assert value == pytest.approx(expected, abs=2e-3)


def _senses(profile, grid=None, seed=0):
    return Senses(profile, PlannerConfig(), grid, np.random.default_rng(seed))


def test_the_lidar_maps_the_wall_and_leaves_a_person_to_the_planner():
    profile = SensingProfile("lidar", lidar=LidarSettings(range_noise=0.0, mount_x=0.0))
    senses = _senses(profile, _walled())
    state = np.array([1.0, 5.0, 0.0, 0.0, 0.0])
    people = (np.array([[2.0, 5.0]]), np.array([[0.0, 0.0]]), np.array([0.3]))
    _, offsets, ranges = senses.scan_ranges(state, *people[::2], [])
    ahead = int(np.argmin(np.abs(offsets)))
    assert ranges[ahead] == pytest.approx(0.7, abs=1e-4)          # the person's near side
    believed, world = senses.perceive(0.0, state, people, [])
    grid = world.grid
    rows = np.arange(2.0, 4.0, 0.05) + 0.025              # the wall's face, below the person
    assert grid is not None
    assert np.mean(grid.distance(np.c_[np.full_like(rows, 3.025), rows]) <= 0.0) >= 0.9
    assert np.all(grid.distance(np.c_[np.full_like(rows, 2.975), rows]) > 0.0)  # not before it
    assert grid.distance([[2.0, 5.0]])[0] > 0.3          # the person is no mark of the map
    assert len(world.obstacles) == 1 and believed.x == 1.0
    assert senses.counts["returns_on_objects"] > 0


def test_the_detector_sees_what_is_in_view_and_not_hidden():
    profile = SensingProfile("tracked", detector=DetectorSettings(
        position_noise=0.0, miss_rate=0.0, false_rate=0.0, range=6.0, fov=math.pi))
    senses = _senses(profile, _walled(4.0))
    state = np.array([1.0, 5.0, 0.0, 0.0, 0.0])
    positions = np.array([[2.5, 5.0],     # seen
                          [3.5, 5.0],     # behind the first one
                          [4.5, 6.0],     # behind the wall
                          [0.0, 5.0],     # behind the robot, out of view
                          [2.0, 9.9]])    # 4.9 m away, 78 degrees off: seen
    radii = np.full(5, 0.3)
    found, _ = senses.detect(state, positions, radii)
    assert sorted(map(tuple, np.round(found, 6))) == [(2.0, 9.9), (2.5, 5.0)]


def test_tracked_people_arrive_after_confirmation_with_their_velocity():
    profile = SensingProfile("tracked", detector=DetectorSettings(
        position_noise=0.0, miss_rate=0.0, false_rate=0.0, latency=0.0))
    senses = _senses(profile)
    state = np.array([0.0, 0.0, 0.0, 0.0, 0.0])
    seen = []
    for k in range(6):
        t = 0.2 * k
        people = (np.array([[3.0 - 0.5 * t, 1.0]]), np.array([[-0.5, 0.0]]), np.array([0.3]))
        _, world = senses.perceive(t, state, people, [])
        seen.append(len(world.obstacles))
    assert seen[:2] == [0, 0] and seen[-1] == 1
    assert world.obstacles[0].velocity[0] == pytest.approx(-0.5, abs=0.1)


def test_the_plant_runs_late_within_the_limits():
    senses = _senses(SensingProfile("plant", plant=PlantSettings(delay=1, noise=0.0)))
    state = np.array([0.0, 0.0, 0.0, 0.2, 0.0])
    assert senses.execute((1.0, 1.0), state) == (0.2, 0.0)       # the last command runs on
    v, omega = senses.execute((0.0, 0.0), state)                  # the first one, now
    robot = PlannerConfig().robot
    assert v == pytest.approx(0.2 + robot.accel_limit * 0.2)
    assert omega == pytest.approx(robot.alpha_limit * 0.2)
    assert _senses(BUILTIN_PROFILES["oracle"]).execute((0.3, -0.1), state) == (0.3, -0.1)


def test_localisation_error_moves_the_believed_world_rigidly():
    profile = dataclasses.replace(BUILTIN_PROFILES["realistic"], lidar=None, detector=None)
    senses = _senses(profile, seed=4)
    state = np.array([1.0, 2.0, 0.3, 0.0, 0.0])
    other = DynamicObstacle.pedestrian((3.0, 2.0), (0.0, 0.0))
    believed, world = senses.perceive(0.0, state, (np.zeros((0, 2)), np.zeros((0, 2)),
                                                   np.zeros(0)), [other])
    assert (believed.x, believed.y) != (1.0, 2.0)
    true_gap = np.hypot(*(other.centers[0] - state[:2]))
    seen_gap = np.hypot(*(world.obstacles[0].centers[0] - [believed.x, believed.y]))
    assert seen_gap == pytest.approx(true_gap, abs=1e-12)


# -- episodes ----------------------------------------------------------------------------------


def _short(name="hall", duration=3.0):
    return dataclasses.replace(load_scenario(name), duration=duration)


def test_oracle_is_the_simulator_as_before():
    scenario = _short()
    plain = simulate(scenario, PlannerConfig(), SAMPLER, np.random.default_rng(2))
    oracle = simulate(scenario, PlannerConfig(), SAMPLER, np.random.default_rng(2),
                      sensing="oracle")
    assert np.array_equal(plain.states, oracle.states)
    assert oracle.believed_states is None and "sensing" not in oracle.meta


@pytest.mark.parametrize("profile", ["lidar", "tracked", "realistic"])
def test_a_sensed_episode_plans_on_belief_and_logs_it(profile, tmp_path):
    scenario = _short()
    episode = simulate(scenario, PlannerConfig(), SAMPLER, np.random.default_rng(2),
                       sensing=profile)
    again = simulate(scenario, PlannerConfig(), SAMPLER, np.random.default_rng(2),
                     sensing=profile)
    assert np.array_equal(episode.states, again.states)           # every draw is seeded
    assert np.all(np.isfinite(episode.states))
    assert episode.meta["sensing"]["name"] == profile
    believed = episode.believed_states
    active = episode.active[0]
    assert believed.shape == (1, episode.n_cycles, 5) and np.all(np.isfinite(believed[0,
                                                                                       active]))
    if profile == "realistic":
        assert not np.allclose(believed[0, active, :2], episode.states[0, :-1][active, :2])
    loaded = type(episode).load(episode.save(tmp_path / "e.npz"))
    assert np.array_equal(loaded.believed_states, believed, equal_nan=True)


@pytest.mark.parametrize("profile", ["lidar", "tracked"])
def test_the_people_the_robot_planned_with_are_logged_and_drawn(profile, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from dsmpepc_nlp.viz.plots import episode_figure

    episode = simulate(_short(duration=4.0), PlannerConfig(), SAMPLER,
                       np.random.default_rng(2), sensing=profile)
    people = episode.believed_people
    assert people.ndim == 4 and people.shape[:2] == (1, episode.n_cycles)
    assert people.shape[3] == 5 and people.shape[2] >= 1
    rows = [(k, row) for k in range(episode.n_cycles) for row in people[0, k]
            if np.isfinite(row[0])]
    assert rows, "the walker was never planned with"
    for k, (x, y, vx, vy, radius) in rows:
        gaps = np.hypot(*(episode.ped_positions[k] - [x, y]).T)
        j = int(np.argmin(gaps))
        if profile == "lidar":          # the truth, placed by an exact pose
            assert gaps[j] < 1e-9 and radius == episode.ped_radii[j]
            assert np.allclose([vx, vy], episode.ped_velocities[k, j])
        else:                           # a track: near the walker, drawn at least as wide
            assert gaps[j] < 0.6 and radius >= episode.ped_radii[j] - 1e-9
    loaded = type(episode).load(episode.save(tmp_path / "e.npz"))
    assert np.array_equal(loaded.believed_people, people, equal_nan=True)
    figure = episode_figure(loaded, cycle=rows[-1][0])
    dashed = [p for p in figure.axes[0].patches
              if p.get_linestyle() == "--" and p.get_edgecolor()[:3] == matplotlib.colors
              .to_rgb("darkorange")]
    assert len(dashed) == np.sum(np.isfinite(people[0, rows[-1][0], :, 0]))


def test_a_collision_with_what_the_robot_never_perceived_is_named():
    lidar = SensingProfile("lidar", lidar=LidarSettings(range_noise=0.0))
    senses = _senses(lidar, _walled(1.2))
    state = np.array([1.0, 5.0, 0.0, 0.0, 0.0])
    centres, radii = np.array([[1.0, 5.0]]), np.array([0.3])
    nobody = (np.zeros((0, 2)), np.zeros(0))
    assert senses.perceived(state, centres, radii, *nobody) == {"touched": ["map"],
                                                                "believed": False}
    senses.perceive(0.0, state, (np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0)), [])
    assert senses.perceived(state, centres, radii, *nobody)["believed"]     # now it saw it
    tracked = _senses(SensingProfile("tracked", detector=DetectorSettings()))
    person = (np.array([[1.3, 5.0]]), np.array([0.3]))
    assert tracked.perceived(state, centres, radii, *person) == {"touched": ["person"],
                                                                 "believed": False}
    told = _senses(lidar)                     # people are told under the lidar profile
    assert told.perceived(state, centres, radii, *person)["believed"]


def test_the_failure_classifier_reads_what_the_robot_believed():
    from dsmpepc_nlp.bench import failures

    scenario = dataclasses.replace(load_scenario("hall"), duration=0.6)
    episode = simulate(scenario, PlannerConfig(), SAMPLER, np.random.default_rng(2),
                       sensing="tracked")
    episode.outcomes[0] = "collision"
    episode.meta["perception"] = [{"touched": ["person"], "believed": False}]
    found = failures.classify(episode, 0)
    assert found.name == "not-perceived" and found.evidence["perceived_touched"] == "person"
    episode.meta["perception"] = [{"touched": ["person"], "believed": True}]
    assert failures.classify(episode, 0).name != "not-perceived"


def test_a_profile_sets_the_trackers_settings(tmp_path):
    path = tmp_path / "quick.yaml"
    path.write_text("base: tracked\ntracker: {confirm_hits: 4}\n")
    profile = load_profile(path)
    assert profile.tracker.confirm_hits == 4 and profile.detector == DetectorSettings()
    assert BUILTIN_PROFILES["tracked"].tracker.confirm_hits == 2
    assert _senses(profile).tracker.config.confirm_hits == 4
    path.write_text("base: tracked\ntracker: {confirm_hit: 2}\n")
    with pytest.raises(InputError, match="did you mean 'confirm_hits'"):
        load_profile(path)
