"""Scenario and map files (issue 31): pedestrians and goals against the map, ``1e9`` read as a
number, did-you-mean for unknown keys, no numpy spellings in messages, PNG maps."""

import warnings

import numpy as np
import pytest
import yaml

from dsmpepc_nlp.core.errors import InputError, shown
from dsmpepc_nlp.core.world import OccupancyGrid
from dsmpepc_nlp.sim.scenario import ScenarioError, load_scenario, parse_scenario


def walled(tmp_path, robot=None, pedestrians=(), **extra):
    occupied = np.zeros((20, 20), bool)
    occupied[:, 8:12] = True                    # a wall at x = 0.8 .. 1.2 m, map 2 m x 2 m
    OccupancyGrid(occupied, 0.1).to_yaml(tmp_path / "wall.map.yaml")
    robot = robot or {"start": [0.4, 1.0, 0.0], "goal": {"position": [0.4, 0.5]}}
    doc = {"name": "walled", "duration": 4.0, "map": "wall.map.yaml", "robots": [robot],
           "pedestrians": list(pedestrians), **extra}
    path = tmp_path / "walled.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.mark.parametrize(("pedestrian", "field"), [
    ({"start": [1.0, 0.3], "velocity": [0.0, 0.0]}, "pedestrians[0].start"),
    ({"waypoints": [[0.0, 0.2, 0.2], [2.0, 1.0, 1.8]]}, "pedestrians[0].waypoints[1]"),
])
def test_a_pedestrian_inside_an_obstacle_is_an_error(tmp_path, pedestrian, field):
    with pytest.raises(ScenarioError) as info:
        load_scenario(walled(tmp_path, pedestrians=[pedestrian]))
    text = str(info.value)
    assert "walled.yaml" in text and f"{field}:" in text and "must be in free space" in text


def test_a_pedestrian_walking_through_a_wall_is_warned(tmp_path):
    person = {"start": [0.3, 0.3], "velocity": [0.5, 0.0]}
    with pytest.warns(UserWarning, match=r"pedestrians\[0\]: walks through an obstacle"):
        load_scenario(walled(tmp_path, pedestrians=[person]))


def test_a_goal_outside_the_map_is_warned_not_refused(tmp_path):
    robot = {"start": [0.4, 1.0, 0.0], "goal": {"position": [-5.0, 1.0]}}
    with pytest.warns(UserWarning, match=r"robots\[0\]\.goal\.position: \[-5, 1\] is outside"):
        scenario = load_scenario(walled(tmp_path, robot=robot))
    assert scenario.agents[0].goal.position == (-5.0, 1.0)


def test_a_scenario_inside_the_map_loads_without_warnings(tmp_path):
    person = {"waypoints": [[0.0, 1.6, 0.2], [3.0, 1.6, 1.8]]}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_scenario(walled(tmp_path, pedestrians=[person]))


def test_exponent_numbers_without_a_dot_are_numbers(tmp_path):
    path = tmp_path / "e.yaml"
    path.write_text("name: e\nduration: 2e1\nrobots:\n  - start: [0, 0, 0]\n"
                    "    goal: {position: [1e0, 0], tolerance: 25E-2}\n")
    scenario = load_scenario(path)
    assert scenario.duration == 20.0 and scenario.agents[0].goal.tolerance == 0.25


def test_a_number_written_as_text_says_how_to_write_it():
    doc = {"name": "e", "duration": "1e9", "robots": [
        {"start": [0, 0, 0], "goal": {"position": [1, 0]}}]}
    with pytest.raises(ScenarioError, match=r"duration: '1e9' is not a number \(write it as a "
                       r"YAML number such as 1\.0e\+09\)"):
        parse_scenario(doc, "e.yaml")


def test_unknown_keys_get_a_did_you_mean():
    doc = {"name": "e", "durration": 3.0, "robots": []}
    with pytest.raises(ScenarioError, match="durration: unknown key; did you mean 'duration'"):
        parse_scenario(doc, "e.yaml")


def test_messages_spell_numbers_as_python_does():
    doc = {"name": "e", "duration": 3.0, "robots": [
        {"start": np.array([np.float64(0.0), np.float64(1.0)]), "goal": {"position": [1, 0]}}]}
    with pytest.raises(ScenarioError) as info:
        parse_scenario(doc, "e.yaml")
    assert "np.float64" not in str(info.value) and "array(" not in str(info.value)
    assert "[0.0, 1.0]" in str(info.value)
    assert shown(np.float64(0.5)) == "0.5" and shown((np.int64(2), 1.5)) == "(2, 1.5)"
    assert "shape (100, 100)" in shown(np.zeros((100, 100)))


def test_map_yaml_messages_have_no_numpy_spelling(tmp_path):
    OccupancyGrid(np.zeros((2, 2), bool), 0.1).to_yaml(tmp_path / "m.yaml")
    text = (tmp_path / "m.yaml").read_text().replace("- 0.0\n", "- 0.5\n", 3)
    (tmp_path / "m.yaml").write_text(text.replace("- 0.5\n- 0.5\n- 0.5\n", "- 0.0\n- 0.0\n- 0.5\n"))
    with pytest.raises(InputError, match=r"origin yaw=0\.5: only 0") as info:
        OccupancyGrid.from_yaml(tmp_path / "m.yaml")
    assert "np." not in str(info.value)


def write_png_map(folder, pixels, mode, **fields):
    image = pytest.importorskip("PIL.Image")
    image.fromarray(pixels, mode=mode).save(folder / "m.png")
    meta = {"image": "m.png", "resolution": 0.5, "origin": [0.0, 0.0, 0.0], **fields}
    (folder / "m.yaml").write_text(yaml.safe_dump(meta))
    return folder / "m.yaml"


def test_a_png_map_reads_like_the_same_pgm(tmp_path):
    gray = np.array([[255, 0, 128], [0, 254, 0]], dtype=np.uint8)      # top row first
    grid = OccupancyGrid.from_yaml(write_png_map(tmp_path, gray, "L"))
    np.testing.assert_array_equal(grid.occupied, [[True, False, True], [False, True, False]])
    assert grid.bounds == (0.0, 0.0, 1.5, 1.0)
    (tmp_path / "m.pgm").write_bytes(b"P5\n3 2\n255\n" + gray.tobytes())
    (tmp_path / "p.yaml").write_text((tmp_path / "m.yaml").read_text().replace("m.png", "m.pgm"))
    np.testing.assert_array_equal(OccupancyGrid.from_yaml(tmp_path / "p.yaml").occupied,
                                  grid.occupied)


def test_a_colour_png_averages_its_channels_and_leaves_alpha_out(tmp_path):
    # (255, 255, 255) free; (0, 0, 0) occupied; (255, 0, 0) averages to 85: occupancy 0.67
    rgba = np.array([[[255, 255, 255, 0], [0, 0, 0, 255], [255, 0, 0, 255]]], dtype=np.uint8)
    grid = OccupancyGrid.from_yaml(write_png_map(tmp_path, rgba, "RGBA"))
    np.testing.assert_array_equal(grid.occupied, [[False, True, True]])
    grid = OccupancyGrid.from_yaml(write_png_map(tmp_path, rgba, "RGBA", occupied_thresh=0.7))
    np.testing.assert_array_equal(grid.occupied, [[False, True, False]])


def test_a_misspelt_map_field_is_named_with_a_did_you_mean(tmp_path):
    from dsmpepc_nlp.core.mapfile import read_map, write_map

    occupied = np.zeros((4, 5), dtype=bool)
    occupied[0, 0] = True
    write_map(tmp_path / "m.yaml", occupied, 0.1, (0.0, 0.0))
    text = (tmp_path / "m.yaml").read_text()
    (tmp_path / "typo.yaml").write_text(text.replace("negate:", "negat:"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got, resolution, _ = read_map(tmp_path / "typo.yaml")
    assert resolution == 0.1 and got.shape == occupied.shape
    assert any("'negat'" in str(w.message) and "did you mean 'negate'" in str(w.message)
               for w in caught)
    (tmp_path / "bad.yaml").write_text(text.replace("resolution:", "resolutoin:"))
    with pytest.raises(InputError, match="missing field 'resolution'.*resolutoin"):
        read_map(tmp_path / "bad.yaml")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_map(tmp_path / "m.yaml")          # a correct file: no warning
