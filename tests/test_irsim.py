"""The IR-SIM adapter (dsmpepc_nlp.irsim): exact rasterisation of IR-SIM's shapes and maps, the
robot read from IR-SIM, a whole headless episode, the ``dsmpepc irsim`` command."""

import inspect
import json
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("irsim")

from dsmpepc_nlp.cli import main  # noqa: E402
from dsmpepc_nlp.core.errors import InputError, MissingExtra  # noqa: E402
from dsmpepc_nlp.irsim import IrsimAdapter, load_env  # noqa: E402
from dsmpepc_nlp.irsim import loading as irsim_loading  # noqa: E402
from dsmpepc_nlp.irsim.inputs import scan_ranges  # noqa: E402
from dsmpepc_nlp.irsim.raster import Lattice, rasterise  # noqa: E402
from dsmpepc_nlp.irsim.runner import run_world  # noqa: E402
from dsmpepc_nlp.sim import metrics as sim_metrics  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "irsim"

ROBOT = """robot:
  - kinematics: {name: 'diff'}
    shape: %(shape)s
    state: [0.5, 0.5, 0]
    goal: [2.5, 0.5, 0]
    vel_min: [-0.2, -1.2]
    vel_max: [0.8, 1.5]
    acce: [1.0, 2.0]
    goal_threshold: 0.2
"""


def _world(tmp_path, obstacles="", shape="{name: 'circle', radius: 0.2}", world="",
           name="world.yaml") -> Path:
    """A small IR-SIM world file: a 4 x 4 m world, one robot, the given obstacle block."""
    text = ("world:\n  height: 4\n  width: 4\n  step_time: 0.1\n" + world
            + ROBOT % {"shape": shape}
            + (f"obstacle:\n{obstacles}" if obstacles else ""))
    path = tmp_path / name
    path.write_text(text)
    return path


def _cells(grid):
    """Set of occupied (ix, iy)."""
    return {(int(ix), int(iy)) for iy, ix in np.argwhere(grid.occupied)}


def _oracle(tmp_path, obstacles, resolution=0.1, **kwargs):
    env = load_env(_world(tmp_path, obstacles, **kwargs))
    try:
        return IrsimAdapter(env, resolution=resolution).static_grid
    finally:
        env.end(ending_time=0.0)


# -- rasterisation -------------------------------------------------------------------------


def test_wall_on_a_cell_edge_is_kept(tmp_path):
    """A wall of no thickness along x = 1.0, exactly on a cell edge: a test of cell centres
    drops it (no centre lies on it); the exact rasteriser marks the cells on both sides."""
    grid = _oracle(tmp_path, "  - shape: {name: 'linestring', vertices: [[1.0, 0.0], "
                             "[1.0, 4.0]]}\n    state: [0, 0, 0]\n")
    cells = _cells(grid)
    assert {ix for ix, _ in cells} == {9, 10}          # [0.9, 1.0] and [1.0, 1.1]
    assert {iy for _, iy in cells} == set(range(40))
    centres = np.array(grid.origin) + (np.array(sorted(cells)) + 0.5) * grid.resolution
    assert not np.any(np.isclose(centres[:, 0], 1.0))  # what a centre test would have seen
    assert grid.distance(np.array([[1.5, 2.0]]))[0] == pytest.approx(0.4)


def test_rectangle_and_polygon_cells_are_exact(tmp_path):
    """A rectangle spanning x 1.1-1.35, y 0.2-0.5 (edges on cell edges do not spill) and a
    triangle (0, 2), (0.4, 2), (0, 2.4): the cells whose square overlaps it with area."""
    obstacles = ("  - number: 2\n    distribution: {name: 'manual'}\n    shape:\n"
                 "      - {name: 'rectangle', length: 0.25, width: 0.3}\n"
                 "      - {name: 'polygon', vertices: [[0, 0], [0.4, 0], [0, 0.4]]}\n"
                 "    state: [[1.225, 0.35, 0], [0.0, 2.0, 0]]\n")
    cells = _cells(_oracle(tmp_path, obstacles))
    rectangle = {(ix, iy) for ix in (11, 12, 13) for iy in (2, 3, 4)}
    triangle = {(ix, 20 + iy) for ix in range(4) for iy in range(4) if ix + iy <= 3}
    assert cells == rectangle | triangle


def test_disc_cells_are_exact():
    """A disc of radius 0.1 at (0.5, 0.5) on 0.1 m cells: the 4 cells around its centre; at
    (0.55, 0.55) the 3 x 3 block (its rim reaches 0.45 and 0.65)."""
    lattice = Lattice.covering((0, 0, 1, 1), (0, 0), 0.1)
    assert _cells(rasterise(lattice, discs=[((0.5, 0.5), 0.1)])) == \
        {(4, 4), (4, 5), (5, 4), (5, 5)}
    assert _cells(rasterise(lattice, discs=[((0.55, 0.55), 0.1)])) == \
        {(ix, iy) for ix in (4, 5, 6) for iy in (4, 5, 6)}


def test_png_map_is_transposed_and_read_beside_the_world_file(tmp_path, monkeypatch):
    """An obstacle map image given relative to the world file, read from another folder: IR-SIM
    indexes its grid [x, y] with y up (the image's top row is the world's top); its cells here
    are 0.2 x 0.4 m, not square, and land exactly on a 0.1 m grid."""
    import matplotlib.pyplot as plt

    image = np.ones((10, 20))                    # rows: y from the top; columns: x
    image[0, 0] = 0.0                            # black: the top-left cell
    image[9, 19] = 0.0                           # the bottom-right cell
    (tmp_path / "maps").mkdir()
    plt.imsave(tmp_path / "maps" / "room.png", image, cmap="gray", vmin=0, vmax=1)
    path = _world(tmp_path, world="  obstacle_map: 'maps/room.png'\n")
    monkeypatch.chdir(Path(__file__).parent)
    env = load_env(path)
    try:
        grid = IrsimAdapter(env, resolution=0.1).static_grid
    finally:
        env.end(ending_time=0.0)
    top_left = {(ix, iy) for ix in (0, 1) for iy in (36, 37, 38, 39)}
    bottom_right = {(ix, iy) for ix in (38, 39) for iy in (0, 1, 2, 3)}
    assert _cells(grid) == top_left | bottom_right


# -- the robot and the inputs --------------------------------------------------------------


def test_footprint_and_limits_from_the_irsim_robot(tmp_path):
    env = load_env(_world(tmp_path))
    adapter = IrsimAdapter(env)
    robot = adapter.robot_config
    assert robot.footprint == ((0.0, 0.0, 0.2),)     # not IR-SIM's 0.20000000000000004
    assert (robot.v_limit, robot.omega_limit, robot.reverse_limit) == (0.8, 1.2, 0.2)
    assert (robot.accel_limit, robot.alpha_limit) == (1.0, 2.0)
    assert adapter.goal.tolist() == [2.5, 0.5] and adapter.goal_tolerance == 0.2
    assert adapter.action((0.5, -0.25)).tolist() == [[0.5], [-0.25]]
    env.end(ending_time=0.0)

    path = _world(tmp_path)
    path.write_text(path.read_text().replace("    acce: [1.0, 2.0]\n", ""))
    env = load_env(path)                             # IR-SIM's default acce: no limit
    assert IrsimAdapter(env).robot_config.accel_limit == math.inf
    env.end(ending_time=0.0)

    env = load_env(_world(tmp_path, shape="{name: 'rectangle', length: 0.5, width: 0.36}"))
    circles = np.array(IrsimAdapter(env).robot_config.footprint)
    env.end(ending_time=0.0)
    assert len(circles) == 3
    corners = np.array([[sx * 0.25, sy * 0.18] for sx in (-1, 1) for sy in (-1, 1)])
    edge = np.linspace(-0.25, 0.25, 51)
    boundary = np.concatenate([corners, np.column_stack([edge, np.full(51, 0.18)]),
                               np.column_stack([edge, np.full(51, -0.18)])])
    gaps = np.linalg.norm(boundary[:, None] - circles[None, :, :2], axis=-1) - circles[:, 2]
    assert np.all(gaps.min(axis=1) <= 1e-9)          # every boundary point is covered


def test_what_the_adapter_cannot_map_is_named(tmp_path):
    env = load_env(_world(tmp_path, "  - kinematics: {name: 'omni'}\n"
                                    "    shape: {name: 'linestring', vertices: [[0, 0], [1, 0]]}\n"
                                    "    state: [2, 2, 0]\n    name: 'sliding_wall'\n"))
    with pytest.raises(InputError, match="sliding_wall"):
        IrsimAdapter(env)
    env.end(ending_time=0.0)
    env = load_env(_world(tmp_path))
    with pytest.raises(InputError, match="robot_0.*no lidar"):
        IrsimAdapter(env, "lidar")
    env.end(ending_time=0.0)


def test_walkers_measured_and_tracked():
    """The corridor's walkers: oracle velocities are their position change over the last
    period (measured, noise and all); tracked people appear once the tracker has confirmed
    them (3 updates)."""
    env = load_env(EXAMPLES / "corridor.yaml", seed=0)
    oracle, tracked = IrsimAdapter(env), IrsimAdapter(env, "tracked", seed=0)
    counts, speeds = [], []
    for _ in range(3):
        before = np.array([o.centers[0] for o in oracle.moving_obstacles()])
        for _ in range(2):
            env.step(oracle.action((0.0, 0.0)))
        after = oracle.moving_obstacles()
        now = np.array([o.centers[0] for o in after])
        assert np.allclose([o.velocity for o in after], (now - before) / 0.2)
        speeds.append(np.linalg.norm((now - before) / 0.2, axis=1))
        counts.append(len(tracked.observe()[1].obstacles))
    env.end(ending_time=0.0)
    assert np.max(speeds) > 0.1
    assert counts[0] == 0 and counts[-1] == 3


def test_scan_misses_and_blind_returns():
    scan = {"ranges": np.array([10.0, 2.0, 0.1]), "valid": np.array([False, True, False]),
            "range_min": 0.1, "range_max": 10.0}
    ranges = scan_ranges(scan)
    assert ranges[0] == math.inf and ranges[1] == 2.0 and math.isnan(ranges[2])


def test_missing_world_and_missing_irsim(tmp_path, monkeypatch, capsys):
    missing = tmp_path / "nowhere.yaml"
    with pytest.raises(InputError, match="nowhere.yaml"):
        load_env(missing)
    assert main(["irsim", str(missing), "--solver", "sampling"]) == 2
    assert "nowhere.yaml" in capsys.readouterr().err
    no_image = _world(tmp_path, world="  obstacle_map: 'maps/none.png'\n", name="holes.yaml")
    with pytest.raises(InputError, match="holes.yaml.*none.png"):
        load_env(no_image)
    monkeypatch.setitem(sys.modules, "irsim", None)
    with pytest.raises(MissingExtra, match=r"dsmpepc_nlp\[irsim\]"):
        irsim_loading.require_irsim()


# -- whole runs ----------------------------------------------------------------------------


def test_example_world_arrives_headless(tmp_path):
    """The doorway example, sampling planner, the truth: IR-SIM says the robot arrived."""
    summary = run_world(EXAMPLES / "doorway.yaml", solver="sampling", out=tmp_path)
    metrics = summary["metrics"][0]
    assert summary["outcomes"] == ["success"] and metrics["outcome"] == "success"
    assert metrics["min_static_clearance"] > 0 and metrics["cycles"] > 10
    assert Path(summary["files"]["episode"]).is_file()


def test_cli_json_has_the_run_keys(tmp_path, capsys):
    """``dsmpepc irsim --json``: the top-level keys of ``dsmpepc run --json`` and every metric
    key of the simulator's, with the robot sensing through IR-SIM's lidar."""
    lidar = ("    sensors:\n      - {name: 'lidar2d', range_min: 0.1, range_max: 5, "
             "angle_range: 4.712, number: 180}\n")
    path = _world(tmp_path, "  - shape: {name: 'circle', radius: 0.3}\n"
                            "    state: [1.5, 1.6, 0]\n")
    path.write_text(path.read_text().replace("    goal_threshold: 0.2\n",
                                             "    goal_threshold: 0.2\n" + lidar))
    status = main(["irsim", str(path), "--solver", "sampling", "--sensing", "lidar", "--json",
                   "--out", str(tmp_path / "out"), "--max-time", "15"])
    assert status == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary) == {"scenario", "variant", "solver", "seed", "sensing", "outcomes",
                            "metrics", "wall_time", "files"}
    assert summary["sensing"] == "lidar" and summary["outcomes"] == ["success"]
    keys = set(re.findall(r'"(\w+)":', inspect.getsource(sim_metrics.robot_metrics)))
    assert keys and keys <= set(summary["metrics"][0])


# -- benchmark irsim, irsim-export barn ----------------------------------------------------


def test_benchmark_irsim_rows_and_failures(tmp_path, capsys):
    """``benchmark irsim``: one row per (world, seed) in irsim.csv/json under IR-SIM's
    judgement; a run cut short (--max-time 1) keeps its episode, which ``dsmpepc failures``
    classifies as it does our simulator's."""
    world = _world(tmp_path, "  - shape: {name: 'circle', radius: 0.3}\n"
                             "    state: [1.5, 1.6, 0]\n", name="little.yaml")
    common = ["benchmark", "irsim", "--worlds", str(tmp_path), "--seeds", "0",
              "--solver", "sampling", "--workers", "1", "--json"]
    assert main(common + ["--out", str(tmp_path / "ok")]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["runs"] == 1 and summary["success_rate"] == 1.0
    rows = json.loads((tmp_path / "ok" / "irsim.json").read_text())["rows"]
    assert [(r["scenario"], r["seed"], r["outcome"]) for r in rows] == [("little", 0, "success")]
    assert rows[0]["path_length"] > 1.5 and rows[0]["episode_file"] is None
    assert (tmp_path / "ok" / "irsim.csv").read_text().startswith("scenario,seed,variant")

    assert main(common + ["--out", str(tmp_path / "cut"), "--max-time", "1"]) == 0
    assert json.loads(capsys.readouterr().out)["timeout_rate"] == 1.0
    row = json.loads((tmp_path / "cut" / "irsim.json").read_text())["rows"][0]
    assert row["outcome"] == "timeout" and row["world_file"] == str(world)
    assert (tmp_path / "cut" / row["episode_file"]).is_file()
    assert main(["failures", str(tmp_path / "cut"), "--figures", "0", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["unsuccessful_runs"] == 1 and report["unclassified"] == 0
    assert sum(report["counts"].values()) == 1


def _barn_folder(tmp_path, index=7):
    """A BARN-format folder with one world: the side walls (rows 0 and 29) and three cylinders,
    a reference path along row 14."""
    grid = np.zeros((30, 30), dtype=np.int64)
    grid[[0, 29], :] = 1
    grid[14, 10] = grid[5, 20] = grid[20, 3] = 1
    for name in ("grid_files", "path_files"):
        (tmp_path / "barn" / name).mkdir(parents=True)
    np.save(tmp_path / "barn" / "grid_files" / f"grid_{index}.npy", grid)
    path = np.array([[14, 0]] + [[14, c] for c in range(30)], dtype=np.int64)
    np.save(tmp_path / "barn" / "path_files" / f"path_{index}.npy", path)
    return tmp_path / "barn", grid


def test_export_barn_is_our_barn_world(tmp_path, capsys):
    """``irsim-export barn``: the exported world is our BARN run of that world: the Jackal's
    three circles and limits, the start, the goal within 1 m, the UST-10 lidar, 100 s; with
    ``--cylinders box`` the adapter's exact map is our simulator's BARN map cell for cell."""
    from dsmpepc_nlp.bench import barn

    data, grid = _barn_folder(tmp_path)
    out = tmp_path / "worlds"
    for cylinders in ("circle", "box"):
        assert main(["irsim-export", "barn", "--data", str(data), "--worlds", "7", "--out",
                     str(out / cylinders), "--cylinders", cylinders, "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["files"] == [str(out / cylinders /
                                                                    "barn-7.yaml")]
    env = load_env(out / "box" / "barn-7.yaml")
    try:
        adapter = IrsimAdapter(env, "lidar")
        jackal = barn.jackal_robot()
        robot = adapter.robot_config
        assert np.allclose(robot.footprint, jackal.footprint, atol=1e-6)
        assert (robot.v_limit, robot.omega_limit, robot.accel_limit, robot.alpha_limit,
                robot.reverse_limit) == (jackal.v_limit, jackal.omega_limit,
                                         jackal.accel_limit, jackal.alpha_limit,
                                         jackal.reverse_limit)
        assert adapter.goal.tolist() == list(barn.GOAL) and adapter.goal_tolerance == 1.0
        state = adapter.state()
        assert (state.x, state.y, state.phi) == pytest.approx(barn.START, abs=1e-6)
        lidar = adapter.robot.lidar
        assert (lidar.number, lidar.range_min, lidar.range_max) == (720, 0.1, 30.0)
        assert lidar.angle_range == pytest.approx(math.radians(270), abs=1e-6)
        assert len(env.obstacle_list) == int(grid.sum()) + 96
        ours = barn.rasterise(barn.cylinder_centres(grid))
        theirs = adapter.static_grid
        assert theirs.occupied.shape == ours.occupied.shape
        assert np.allclose(theirs.origin, ours.origin)
        assert np.array_equal(theirs.occupied, ours.occupied)
        assert env.config["custom"] == {"max_time": 100.0, "barn_world": 7,
                                        "reference_path_length": pytest.approx(
                                            barn.reference_path_length(
                                                np.load(data / "path_files" / "path_7.npy")),
                                            abs=1e-6)}
    finally:
        env.end(ending_time=0.0)


def test_export_barn_writes_nothing_on_error(tmp_path, capsys):
    """A missing BARN file among the worlds, or a world file already there: an InputError
    (exit 2) naming it, and no file written or replaced."""
    data, _ = _barn_folder(tmp_path)
    out = tmp_path / "worlds"
    assert main(["irsim-export", "barn", "--data", str(data), "--worlds", "7,8", "--out",
                 str(out)]) == 2
    assert "grid_8.npy" in capsys.readouterr().err
    assert not out.exists()
    assert main(["irsim-export", "barn", "--data", str(data), "--worlds", "7", "--out",
                 str(out)]) == 0
    before = (out / "barn-7.yaml").read_text()
    assert main(["irsim-export", "barn", "--data", str(data), "--worlds", "7", "--out",
                 str(out), "--cylinders", "box"]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "barn-7.yaml").read_text() == before
    assert [p.name for p in out.iterdir()] == ["barn-7.yaml"]


def test_t_corridor_example_is_the_builtin_scenario():
    """examples/irsim/t-corridor.yaml: the built-in scenario's map cell for cell, and its parked
    robot given to the planner as a robot standing still, as the simulator gives it."""
    from dsmpepc_nlp.sim.scenario import load_scenario

    scenario = load_scenario("t-corridor")
    env = load_env(EXAMPLES / "t-corridor.yaml")
    try:
        adapter = IrsimAdapter(env)
        grid = adapter.static_grid
        assert np.allclose(grid.origin, scenario.grid.origin)
        assert np.array_equal(grid.occupied, scenario.grid.occupied)
        (parked,) = adapter.moving_obstacles()
        assert parked.kind == "robot" and np.allclose(parked.velocity, 0.0)
        assert np.allclose(parked.centers, [scenario.parked[0].pose[:2]])
        assert adapter.goal.tolist() == list(scenario.agents[0].goal.position)
    finally:
        env.end(ending_time=0.0)
