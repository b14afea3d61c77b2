"""Generated scenario families: the geometry asked for is the geometry on the grid; save/load."""

import numpy as np
import pytest

from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.sim import families
from dsmpepc_nlp.sim.scenario import load_scenario


def free_run(grid, x=None, y=None, around=None):
    """Length (m) of the free run of cells through ``around`` along a column (at ``x``) or a
    row (at ``y``), and its two ends."""
    res = grid.resolution
    occ = grid.occupied
    if x is not None:
        line, i = occ[:, int(x / res)], int(around / res)
    else:
        line, i = occ[int(y / res), :], int(around / res)
    assert not line[i], "the probe point is in a wall"
    lo = i
    while lo > 0 and not line[lo - 1]:
        lo -= 1
    hi = i
    while hi < line.size - 1 and not line[hi + 1]:
        hi += 1
    return (hi + 1 - lo) * res, lo * res, (hi + 1) * res


@pytest.mark.parametrize("gap", families.FAMILIES["t-corridor"].values)
@pytest.mark.parametrize("width", families.FAMILIES["t-corridor"].values2)
def test_t_corridor_gap_is_the_asked_width_on_the_grid(gap, width):
    doc, grid = families.generate("t-corridor", gap, width)
    (px, py, _), = [p["pose"] for p in doc["parked_robots"]]
    (r,) = [c[2] for c in doc["parked_robots"][0]["footprint"]]
    _, low, high = free_run(grid, x=px, around=py)
    assert high - (py + r) == pytest.approx(gap, abs=1e-9)
    assert (py - r) - low < 2 * r, "the robot must not fit past the parked robot's other side"
    beyond, lo2, hi2 = free_run(grid, x=px + 2.0, around=low + 0.3)
    assert beyond == pytest.approx(width, abs=1e-9)
    assert lo2 == pytest.approx(low)
    goal = np.array(doc["robots"][0]["goal"]["position"])
    assert lo2 < goal[1] < hi2


@pytest.mark.parametrize("width", families.FAMILIES["narrow-corridor"].values)
def test_narrow_corridor_width_on_the_grid(width):
    doc, grid = families.generate("narrow-corridor", width, 12.6)
    east, west = doc["robots"]
    mid = east["start"][1]
    measured, _, _ = free_run(grid, x=6.0, around=mid)
    assert measured == pytest.approx(width, abs=1e-9)
    length, _, _ = free_run(grid, y=mid, around=6.0)
    assert length == pytest.approx(12.6, abs=1e-9)
    assert len(east["footprint"]) == 2, "non-circular robots"
    assert east["goal"]["position"] == west["start"][:2]


@pytest.mark.parametrize("door", families.FAMILIES["doorway"].values)
def test_doorway_door_width_on_the_grid(door):
    doc, grid = families.generate("doorway", door, 1.5)
    measured, _, _ = free_run(grid, y=4.1, around=4.0)
    assert measured == pytest.approx(door, abs=1e-9)
    start = doc["robots"][0]["start"]
    assert start[0] == pytest.approx(4.0 + 1.5)


def test_every_cell_saves_and_loads_back_the_same(tmp_path):
    for name, x, y in families.cells(families.FAMILIES, quick=True):
        doc, grid = families.generate(name, x, y)
        path = families.save(name, x, y, tmp_path)
        scenario = load_scenario(path)
        assert scenario.name == doc["name"] == path.stem
        assert np.array_equal(scenario.grid.occupied, grid.occupied)
        assert scenario.grid.resolution == grid.resolution
        assert scenario.start_noise == families.START_NOISE
        for agent, robot in zip(scenario.agents, doc["robots"]):
            assert agent.start.pose == pytest.approx(robot["start"])
            assert agent.goal.position == pytest.approx(robot["goal"]["position"])
            assert np.allclose(agent.robot.footprint, robot["footprint"])
        assert len(scenario.parked) == len(doc.get("parked_robots", []))


def test_an_unknown_family_names_the_known_ones():
    with pytest.raises(InputError, match="t-corridor, narrow-corridor, doorway"):
        families.generate("maze", 1.0, 1.0)


def test_cells_cover_the_grid():
    full = families.cells(["t-corridor"])
    f = families.FAMILIES["t-corridor"]
    assert len(full) == len(f.values) * len(f.values2)
    assert len(f.values) >= 8 and min(f.values) == 0.7 and max(f.values) == 2.0
    assert min(families.FAMILIES["narrow-corridor"].values) == 1.0
    assert max(families.FAMILIES["narrow-corridor"].values) == 2.2
