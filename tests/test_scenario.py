"""Scenario files: the built-ins load, and every schema violation names file, field and rule."""

import copy
import dataclasses

import numpy as np
import pytest
import yaml

from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.world import OccupancyGrid
from dsmpepc_nlp.sim.scenario import (
    ScenarioError,
    builtin_names,
    load_scenario,
    parse_scenario,
)
from dsmpepc_nlp.sim.types import FixedGoal, FollowGoal

BUILTINS = ["circle-10", "circle-4", "hall", "l-corridor", "narrow-corridor", "t-corridor"]

VALID = {
    "name": "tiny",
    "duration": 2.0,
    "robots": [{"name": "a", "start": [0.0, 0.0, 0.0], "goal": {"position": [2.0, 0.0]},
                "footprint": [[-0.1, 0.0, 0.2], [0.1, 0.0, 0.2]], "v_limit": 0.8}],
    "parked_robots": [{"pose": [1.0, 1.0, 0.0], "footprint": [[0.0, 0.0, 0.3]]}],
    "pedestrians": [{"radius": 0.25, "waypoints": [[0.0, 3.0, 0.0], [2.0, 3.0, 2.0]]},
                    {"start": [5.0, 5.0], "velocity": [-0.5, 0.0]}],
}


def test_the_builtins_are_the_six_paper_scenarios_and_all_load():
    assert builtin_names() == BUILTINS
    for name in BUILTINS:
        scenario = load_scenario(name)
        assert scenario.name == name
        assert 0 < scenario.duration <= 40


def test_builtin_contents_match_the_paper_descriptions():
    t = load_scenario("t-corridor")
    assert len(t.agents) == 1 and len(t.parked) == 1 and isinstance(t.grid, OccupancyGrid)
    narrow = load_scenario("narrow-corridor")
    assert len(narrow.agents) == 2
    assert all(len(a.robot.footprint) > 1 for a in narrow.agents)  # non-circular
    for n in (4, 10):
        c = load_scenario(f"circle-{n}")
        assert len(c.agents) == n and c.start_noise > 0
        for a in c.agents:  # antipodal goals
            assert np.allclose(a.goal.position, (-a.start.x, -a.start.y), atol=1e-3)
    hall = load_scenario("hall")
    assert len(hall.pedestrians) == 12 and isinstance(hall.agents[0].goal, FollowGoal)
    assert isinstance(load_scenario("l-corridor").agents[0].goal, FollowGoal)


def test_a_user_file_with_a_map_loads(tmp_path):
    # A diagonal wall that keeps clear of the robot's start (0, 0) and goal (2, 0).
    grid = OccupancyGrid(np.eye(10, k=4, dtype=bool), 0.5, (-1.0, -1.0))
    grid.to_yaml(tmp_path / "room.map.yaml")
    doc = dict(VALID, map="room.map.yaml")
    (tmp_path / "mine.yaml").write_text(yaml.safe_dump(doc))
    s = load_scenario(tmp_path / "mine.yaml")
    assert np.array_equal(s.grid.occupied, grid.occupied)
    assert s.map_path.endswith("room.map.yaml")
    a = s.agents[0]
    assert isinstance(a.goal, FixedGoal) and a.goal.tolerance == 0.25
    assert a.robot.v_limit == 0.8 and len(a.robot.footprint) == 2
    assert s.pedestrians[0].radius == 0.25
    assert np.allclose(s.pedestrians[1].position(2.0), (4.0, 5.0))


def mutate(change):
    doc = copy.deepcopy(VALID)
    change(doc)
    return doc


BAD = [
    (lambda d: d.update(colour="red"), "colour", "unknown key"),
    (lambda d: d.pop("duration"), "duration", "missing"),
    (lambda d: d.update(duration="long"), "duration", "not a number"),
    (lambda d: d.update(duration=float("nan")), "duration", "finite"),
    (lambda d: d.update(duration=-1), "duration", "> 0"),
    (lambda d: d.update(robots=[]), "robots", "at least 1"),
    (lambda d: d["robots"][0].update(start=[0, 0]), "robots[0].start", "3 numbers"),
    (lambda d: d["robots"][0].update(start=[0, float("inf"), 0]), "robots[0].start[1]", "finite"),
    (lambda d: d["robots"][0]["goal"].update(follow=0), "robots[0].goal", "exactly one"),
    (lambda d: d["robots"][0].update(goal={"follow": 7}), "robots[0].goal.follow",
     "does not exist"),
    (lambda d: d["robots"][0].update(goal={"position": [1, 1], "distance": 2}),
     "robots[0].goal.distance", "only allowed"),
    (lambda d: d["robots"][0]["footprint"][1].__setitem__(2, -0.2),
     "robots[0].footprint[1][2]", "> 0"),
    (lambda d: d["robots"][0].update(v_limit=True), "robots[0].v_limit", "not a number"),
    (lambda d: d["robots"][0].update(speed=1), "robots[0].speed", "allowed keys"),
    (lambda d: d["robots"].append(dict(d["robots"][0])), "robots[1].name", "unique"),
    (lambda d: d["pedestrians"][0].update(radius=0), "pedestrians[0].radius", "> 0"),
    (lambda d: d["pedestrians"][0]["waypoints"].append([1.0, 0, 0]),
     "pedestrians[0].waypoints[2][0]", "strictly increasing"),
    (lambda d: d["pedestrians"][1].pop("velocity"), "pedestrians[1]", "start' and 'velocity"),
    (lambda d: d["parked_robots"][0].pop("footprint"), "parked_robots[0].footprint", "missing"),
    (lambda d: d.update(map="nowhere.yaml"), "map", "cannot read"),
]


@pytest.mark.parametrize("change, field, rule", BAD)
def test_violations_name_the_file_the_field_and_the_rule(tmp_path, change, field, rule):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(mutate(change)))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "bad.yaml" in message and f"{field}:" in message and rule in message, message
    assert isinstance(info.value, InputError) and isinstance(info.value, ValueError)


def test_unknown_names_and_broken_files(tmp_path):
    with pytest.raises(ScenarioError, match="t-corridor"):  # lists the built-ins
        load_scenario("no-such-scenario")
    with pytest.raises(ScenarioError, match="not found"):
        load_scenario(tmp_path / "missing.yaml")
    (tmp_path / "broken.yaml").write_text("name: [unclosed\n")
    with pytest.raises(ScenarioError, match="invalid YAML"):
        load_scenario(tmp_path / "broken.yaml")
    (tmp_path / "list.yaml").write_text("- 1\n- 2\n")
    with pytest.raises(ScenarioError, match="must be a mapping"):
        load_scenario(tmp_path / "list.yaml")


def test_parse_scenario_accepts_a_mapping():
    s = parse_scenario(copy.deepcopy(VALID))
    assert s.agents[0].name == "a" and s.map_path is None and s.grid is None


@pytest.mark.parametrize(("robot", "field"), [
    ({"start": [1.0, 1.0, 0.0], "goal": {"position": [3.5, 1.0]}}, "robots[0].start"),
    ({"start": [3.5, 1.0, 0.0], "goal": {"position": [1.0, 1.0]}}, "robots[0].goal.position"),
])
def test_a_start_or_goal_in_an_obstacle_is_an_error(tmp_path, robot, field):
    occupied = np.zeros((20, 20), bool)
    occupied[:, 8:12] = True                    # a wall at x = 0.8 .. 1.2 m
    OccupancyGrid(occupied, 0.1).to_yaml(tmp_path / "wall.map.yaml")
    doc = {"name": "walled", "duration": 1.0, "map": "wall.map.yaml", "robots": [robot]}
    (tmp_path / "walled.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ScenarioError, match="must be in free space") as error:
        load_scenario(tmp_path / "walled.yaml")
    assert "walled.yaml" in str(error.value) and f"{field}:" in str(error.value)


# ---------------------------------------------------------------------------------------------
# plausible magnitudes, overlapping starts, start noise, messages (issue 14)

HUGE = 1.0e308

IMPLAUSIBLE = [
    (lambda d: d.update(duration=HUGE), "duration", "<= 86400"),
    (lambda d: d.update(start_noise=HUGE), "start_noise", "<= 100"),
    (lambda d: d["robots"][0].update(start=[HUGE, 1.0, 0.0]), "robots[0].start[0]",
     "within [-1e+06, 1e+06]"),
    (lambda d: d["robots"][0]["goal"].update(position=[0.0, -2.0e6]),
     "robots[0].goal.position[1]", "within [-1e+06, 1e+06]"),
    (lambda d: d["robots"][0].update(v_limit=HUGE), "robots[0].v_limit", "<= 100"),
    (lambda d: d["robots"][0]["footprint"][1].__setitem__(2, HUGE),
     "robots[0].footprint[1][2]", "within [-100, 100]"),
    (lambda d: d["pedestrians"][1].update(velocity=[HUGE, 0.0]), "pedestrians[1].velocity[0]",
     "within [-100, 100]"),
    (lambda d: d["pedestrians"][0].update(radius=HUGE), "pedestrians[0].radius", "<= 100"),
    (lambda d: d["pedestrians"][0]["waypoints"].append([1.0e6, 3.0, 3.0]),
     "pedestrians[0].waypoints[2][0]", "within [-86400, 86400]"),
    (lambda d: d["parked_robots"][0].update(pose=[1.0, HUGE, 0.0]), "parked_robots[0].pose[1]",
     "within"),
    (lambda d: d["robots"].append({"name": "twin", "start": [0.0, 0.0, 1.0],
                                   "goal": {"position": [-2.0, 0.0]}}),
     "robots[1].start", "overlaps robots[0] ('a') at t = 0"),
    (lambda d: d["robots"][0].update(start=[1.2, 1.0, 0.0]), "robots[0].start",
     "overlaps parked_robots[0]"),
    (lambda d: d["robots"][0].update(start=[3.0, 0.3, 0.0]), "robots[0].start",
     "overlaps pedestrians[0] at t = 0"),
]


@pytest.mark.parametrize("change, field, rule", IMPLAUSIBLE)
def test_implausible_values_and_colliding_starts_name_the_field(tmp_path, change, field, rule):
    test_violations_name_the_file_the_field_and_the_rule(tmp_path, change, field, rule)


def test_an_empty_file_and_a_folder_say_what_they_are(tmp_path):
    (tmp_path / "empty.yaml").write_text("")
    with pytest.raises(ScenarioError, match="the document: the file is empty; must be a mapping"):
        load_scenario(tmp_path / "empty.yaml")
    (tmp_path / "folder").mkdir()
    with pytest.raises(ScenarioError, match="is a folder"):
        load_scenario(tmp_path / "folder")


def test_a_built_in_name_beside_a_folder_of_that_name_is_the_built_in(tmp_path, monkeypatch):
    """``--out hall`` of one run must not break ``--scenarios hall`` of the next."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "hall").mkdir()
    assert load_scenario("hall").name == "hall"
    (tmp_path / "mine").mkdir()
    with pytest.raises(ScenarioError, match="is a folder"):
        load_scenario("mine")


def walled_scenario(tmp_path, start_noise):
    occupied = np.zeros((40, 40), bool)
    occupied[:, 20:24] = True                   # a wall at x = 1.0 .. 1.2 m
    OccupancyGrid(occupied, 0.05).to_yaml(tmp_path / "wall.map.yaml")
    doc = {"name": "near-wall", "duration": 1.0, "map": "wall.map.yaml", "start_noise": start_noise,
           "robots": [{"start": [0.5, 1.0, 0.0], "goal": {"position": [0.3, 0.3]}},
                      {"start": [0.5, 1.62, 0.0], "goal": {"position": [0.3, 1.9]}}]}
    (tmp_path / "near-wall.yaml").write_text(yaml.safe_dump(doc))
    return load_scenario(tmp_path / "near-wall.yaml")


def test_start_noise_is_applied_before_the_free_space_checks(tmp_path):
    # Each start is 0.2 m from the wall and 0.02 m from the other robot: with 0.3 m of noise
    # most draws collide, and every start handed to the simulator is in free space.
    from dsmpepc_nlp.sim.checks import start_conflict, start_states

    scenario = walled_scenario(tmp_path, 0.3)
    for seed in range(20):
        states = start_states(scenario, np.random.default_rng(seed))
        poses = [tuple(s[:3]) for s in states]
        assert not any(start_conflict(i, poses, scenario.agents, scenario.grid, (), ())
                       for i in range(2))
        assert not np.allclose(states[0][:2], (0.5, 1.0))      # the noise was applied


def test_start_noise_with_no_free_draw_is_an_error(tmp_path):
    from dsmpepc_nlp.sim.checks import start_states

    scenario = walled_scenario(tmp_path, 0.3)
    boxed = np.ones((40, 40), bool)
    boxed[18:22, 8:12] = False                  # only a 0.2 m pocket around the first start
    scenario = dataclasses.replace(scenario, grid=OccupancyGrid(boxed, 0.05))
    with pytest.raises(InputError, match=r"robots\[0\].*no start in free space in 100 draws"):
        start_states(scenario, np.random.default_rng(0))


def test_reading_scenarios_does_not_load_the_simulator():
    """The scenario types live in sim/types.py: loading a file does not import the closed loop
    (the old layout imported simulate.py for the types)."""
    import subprocess
    import sys

    code = ("import sys; from dsmpepc_nlp.sim.scenario import load_scenario; "
            "load_scenario('circle-4'); "
            "print(sorted(m for m in sys.modules if m.startswith('dsmpepc_nlp.s')))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout
    assert "dsmpepc_nlp.sim.types" in loaded
    assert "dsmpepc_nlp.sim.simulate" not in loaded
