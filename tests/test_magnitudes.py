"""Plausible magnitudes (issue 14): finite is not enough; 1e308 is refused naming the field."""

import dataclasses

import numpy as np
import pytest
import yaml

from dsmpepc_nlp.core.config import RobotConfig
from dsmpepc_nlp.core.errors import InputError, finite_vector, number_in
from dsmpepc_nlp.core.world import OccupancyGrid

HUGE = 1.0e308
PGM = b"P5\n2 2\n255\n" + bytes([255, 0, 255, 255])


def map_file(folder, **fields):
    (folder / "m.pgm").write_bytes(PGM)
    meta = {"image": "m.pgm", "resolution": 0.5, "origin": [1.0, -2.0, 0.0]} | fields
    (folder / "m.yaml").write_text(yaml.safe_dump(meta))
    return folder / "m.yaml"


@pytest.mark.parametrize(("fields", "message"), [
    ({"resolution": HUGE}, "resolution=1e+308: expected a number in [0.0001, 100]"),
    ({"resolution": 1e-9}, "resolution=1e-09: expected a number in [0.0001, 100]"),
    ({"origin": [HUGE, 0.0, 0.0]}, "origin=[1e+308, 0.0, 0.0]: expected 3 numbers in "
                                   "[-1e+06, 1e+06]"),
    ({"origin": ["zero", 0.0, 0.0]}, "origin=['zero', 0.0, 0.0]: expected 3 finite numbers"),
])
def test_map_file_fields_out_of_range_name_the_file_and_field(tmp_path, fields, message):
    with pytest.raises(InputError) as info:
        OccupancyGrid.from_yaml(map_file(tmp_path, **fields))
    assert "m.yaml" in str(info.value) and message in str(info.value), str(info.value)


def test_a_map_in_range_still_loads(tmp_path):
    grid = OccupancyGrid.from_yaml(map_file(tmp_path, resolution=100.0, origin=[-1e6, 1e6, 0]))
    assert grid.resolution == 100.0 and grid.occupied.sum() == 1


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"resolution": HUGE}, "resolution"),
    ({"origin": (0.0, -HUGE)}, "origin"),
])
def test_grid_constructor_refuses_implausible_geometry(kwargs, field):
    with pytest.raises(InputError, match=field):
        OccupancyGrid(np.zeros((2, 2), bool), **({"resolution": 0.1} | kwargs))


@pytest.mark.parametrize(("changes", "field"), [
    ({"v_limit": HUGE}, "v_limit"),
    ({"footprint": ((0.0, 0.0, HUGE),)}, "footprint"),
    ({"footprint": ((HUGE, 0.0, 0.3),)}, "footprint"),
])
def test_robot_config_refuses_implausible_speeds_and_sizes(changes, field):
    with pytest.raises(InputError, match=f"RobotConfig.{field}"):
        dataclasses.replace(RobotConfig(), **changes)


def test_the_helpers_name_the_value_and_the_range():
    with pytest.raises(InputError, match=r"speed='fast': expected a number in \[0, 100\]"):
        number_in("speed", "fast", 0.0, 100.0)
    with pytest.raises(InputError, match="expected 2 finite numbers"):
        finite_vector("p", ["a", 1], 2)
    assert number_in("speed", 100, 0.0, 100.0) == 100.0


@pytest.mark.parametrize(("field", "value"), [
    ("duration", 1.0e308),                      # was an OverflowError traceback in the CLI
    ("start_noise", 1.0e308),
])
def test_the_command_line_exits_2_naming_the_field(tmp_path, capsys, field, value):
    from dsmpepc_nlp.cli import main

    doc = {"name": "tiny", "duration": 2.0, field: value,
           "robots": [{"start": [0.0, 0.0, 0.0], "goal": {"position": [2.0, 0.0]}}]}
    path = tmp_path / "huge.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert main(["run", str(path), "--solver", "sampling", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "huge.yaml" in err and f"{field}:" in err and err.count("\n") == 1, err
