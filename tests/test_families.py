"""Generated scenario families: the geometry asked for is the geometry on the grid; save/load."""

import json

import numpy as np
import pytest

from dsmpepc_nlp import cli
from dsmpepc_nlp.bench import claims
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.geometry import footprint_points
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


@pytest.mark.parametrize("door", [0.35, 0.75, 1.05])
def test_a_door_of_odd_cells_is_still_exact(door):
    _, grid = families.generate("doorway", door, 0.0)
    assert free_run(grid, y=4.1, around=4.0)[0] == pytest.approx(door, abs=1e-9)


def test_cells_cover_the_grid():
    full = families.cells(["t-corridor"])
    f = families.FAMILIES["t-corridor"]
    assert len(full) == len(f.values) * len(f.values2)
    assert len(f.values) >= 8 and min(f.values) == 0.7 and max(f.values) == 2.0
    assert min(families.FAMILIES["narrow-corridor"].values) == 1.0
    assert max(families.FAMILIES["narrow-corridor"].values) == 2.2


# ---------------------------------------------------------------------------------------------
# the claim map (dsmpepc claims): tiny runs, the command's options, the verdicts


def rates(success, deadlock=0.0, collision=0.0):
    return {"success_rate": success, "deadlock_rate": deadlock, "collision_rate": collision,
            "timeout_rate": 1.0 - success - deadlock - collision}


@pytest.mark.parametrize("ds, mp, expected", [
    (rates(1.0), rates(0.0, deadlock=1.0), "claim"),
    (rates(0.8), rates(0.2, deadlock=0.2, collision=0.6), "ds-mpepc"),
    (rates(1.0), rates(0.6, deadlock=0.4), "both pass"),
    (rates(0.4, deadlock=0.6), rates(0.0, deadlock=1.0), "both fail"),
    (rates(0.0, deadlock=1.0), rates(1.0), "mpepc"),
    (rates(float("nan")), rates(1.0), None),
])
def test_verdict_of_a_cell(ds, mp, expected):
    assert claims.verdict(ds, mp) == expected


def test_example_prefers_a_ds_success_beside_an_mpepc_deadlock():
    def row(scenario, solver, seed, variant, outcomes):
        return {"scenario": scenario, "solver": solver, "seed": seed, "variant": variant,
                "outcomes": outcomes, "status": "ok"}
    rows = [row("a", "sampling", 0, "mpepc", "success"), row("a", "sampling", 0, "ds-mpepc",
                                                              "deadlock"),
            row("b", "nlp", 1, "mpepc", "deadlock"), row("b", "nlp", 1, "ds-mpepc", "success"),
            row("c", "sampling", 0, "mpepc", "timeout"), row("c", "sampling", 0, "ds-mpepc",
                                                             "timeout")]
    assert claims.pick_example(rows) == ("b", "nlp", 1)
    assert claims.pick_example(rows[:2]) == ("a", "sampling", 0)
    assert claims.pick_example(rows[4:]) is None


CLAIMS_ARGS = ["claims", "--families", "doorway", "--axis", "0.8,1.6", "--axis2", "1.5",
               "--seeds", "0", "--solvers", "sampling", "--variants", "mpepc", "ds-mpepc",
               "--samples", "8", "--duration", "0.3", "--workers", "1", "--json"]


def test_claims_command_writes_tables_figure_scenarios_and_resumes(tmp_path, capsys):
    out = tmp_path / "map"
    assert cli.main([*CLAIMS_ARGS, "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["runs"] == 4 and summary["failed"] == 0
    rows = json.loads((out / "claims.json").read_text())["rows"]
    assert {(r["x"], r["variant"]) for r in rows} == {
        (x, v) for x in (0.8, 1.6) for v in ("mpepc", "ds-mpepc")}
    assert all(r["outcomes"] == "timeout" for r in rows), "0.3 s cannot reach the goal"
    cells = json.loads((out / "claims_cells.json").read_text())["cells"]
    assert len(cells) == 4 and {c["verdict"] for c in cells} == {"both fail"}
    assert summary["verdicts"] == {"sampling": {"doorway": {"both fail": 2}}}
    assert (out / "claims.csv").exists() and (out / "claims_cells.csv").exists()
    assert (out / "claims_sampling.png").exists() and "example" not in summary
    scenario = load_scenario(out / "scenarios" / "doorway-door0.80-offset1.50.yaml")
    assert scenario.start_noise == families.START_NOISE
    assert cli.main([*CLAIMS_ARGS, "--out", str(out)]) == 2  # a table is there
    assert "--resume" in capsys.readouterr().err
    assert cli.main([*CLAIMS_ARGS, "--out", str(out), "--resume"]) == 0
    assert "4 already done, 0 to run" in capsys.readouterr().err


def test_claims_cells_and_settings(tmp_path, capsys):
    """``--cells`` runs exactly the cells named; ``--set`` runs every setting of the grid,
    keyed apart in the table, with a verdict per cell and setting and a settings figure."""
    out = tmp_path / "map"
    argv = [*CLAIMS_ARGS, "--out", str(out), "--cells", "doorway:0.8:1.5,t-corridor:1.0:1.8",
            "--set", "s_ttc=0.25,1", "--set", "sigma_dynamic_growth=0"]
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["runs"] == 2 * 2 * 2 and summary["failed"] == 0
    rows = json.loads((out / "claims.json").read_text())["rows"]
    assert {r["scenario"] for r in rows} == {"doorway-door0.80-offset1.50",
                                             "t-corridor-gap1.00-width1.80"}
    assert {r["params"] for r in rows} == {'{"s_ttc": 0.25, "sigma_dynamic_growth": 0.0}',
                                           '{"s_ttc": 1.0, "sigma_dynamic_growth": 0.0}'}
    cells = json.loads((out / "claims_cells.json").read_text())["cells"]
    assert len(cells) == 2 * 2 * 2 and all(c["verdict"] == "both fail" for c in cells)
    assert summary["verdicts"]["sampling"] == {"doorway": {"both fail": 2},
                                               "t-corridor": {"both fail": 2}}
    assert (out / "claims_sampling_settings.png").exists()
    assert cli.main([*argv, "--resume"]) == 0
    assert "8 already done, 0 to run" in capsys.readouterr().err


@pytest.mark.parametrize("change, problem", [
    (["--cells", "doorway:0.8"], "FAMILY:X:Y"),
    (["--cells", "maze:1:1"], "maze"),
    (["--cells", "doorway:0.05:1.5"], "door = 0.05"),
    (["--set", "s_ttc=-1"], "s_ttc"),
    (["--set", "sigma_static_from_map=2"], "0 (off) or 1"),
    (["--set", "nonsense=1"], "nonsense"),
    (["--axis", "0"], "--axis"),
    (["--axis", "a,b"], "--axis"),
    (["--families", "maze"], "maze"),
    (["--seeds", "x"], "--seeds"),
    (["--variants", "orca"], "--variants"),
    (["--duration", "-1"], "--duration"),
    (["--axis", "0.05"], "door = 0.05"),
    (["--axis", "0.83"], "multiple of 0.05"),
    (["--axis2", "4"], "offset = 4.0"),
])
def test_claims_command_rejects_bad_options(tmp_path, capsys, change, problem):
    argv = [*CLAIMS_ARGS, "--out", str(tmp_path / "o")]
    for i, token in enumerate(argv):
        if token == change[0]:
            argv[i + 1:i + 2] = change[1:]
            break
    else:
        argv += change
    assert cli.main(argv) == 2
    assert problem in capsys.readouterr().err
    assert not (tmp_path / "o" / "claims.json").exists()


@pytest.mark.parametrize("name, x, y", families.cells(families.FAMILIES))
def test_the_body_fits_at_every_start_and_goal(name, x, y):
    """The footprint, headed as at the start, is clear of the walls at the start and the goal."""
    doc, grid = families.generate(name, x, y)
    for robot in doc["robots"]:
        circles = np.array(robot["footprint"], dtype=float)
        heading = robot["start"][2]
        for point in (robot["start"][:2], robot["goal"]["position"]):
            centres = footprint_points(np.array([*point, heading]), circles[:, :2])
            assert np.min(grid.distance(centres) - circles[:, 2]) > 0.05, (robot["name"], point)
