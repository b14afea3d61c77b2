"""BARN: geometry, files, score, runner, resume and the command line on tiny worlds."""

import json
import math

import numpy as np
import pytest

from dsmpepc_nlp import cli
from dsmpepc_nlp.bench import barn, params


def write_world(folder, index, extra=((10, 5),), with_metrics=True):
    grid = np.zeros((30, 30), dtype=np.int64)
    grid[0, :] = grid[29, :] = 1
    for r, c in extra:
        grid[r, c] = 1
    for sub in ("grid_files", "path_files", "metrics_files"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    np.save(folder / "grid_files" / f"grid_{index}.npy", grid)
    path = np.array([[14, 0], [14, 0]] + [[14, c] for c in range(1, 30)], dtype=np.int64)
    np.save(folder / "path_files" / f"path_{index}.npy", path)
    if with_metrics:
        np.save(folder / "metrics_files" / f"metrics_{index}.npy", np.arange(5.0))
    return grid, path


def test_cell_maps_to_cylinder_centre_and_is_drawn_there(tmp_path):
    write_world(tmp_path, 0)
    assert np.allclose(barn.cell_to_world(10, 5), (-4.425 + 1.5, 5.175 + 0.75))
    world = barn.load_world(tmp_path, 0)
    centre = barn.cell_to_world(10, 5)
    d = world.occupancy.distance(np.array([centre, centre + (0, 0.3), centre + (0.3, 0)]))
    assert d[0] < 0
    assert d[1] == pytest.approx(0.3 - 0.075, abs=0.03)
    assert d[2] == pytest.approx(0.3 - 0.075, abs=0.03)
    # a free cell of the grid is free
    assert world.occupancy.distance(barn.cell_to_world(14, 15)) > 0.5


def test_containment_box_and_start_and_open_world():
    centres = barn.containment_centres()
    assert centres.shape == (96, 2)
    assert np.isclose(centres[:, 1].min(), 0.075)
    assert np.allclose(sorted(set(np.round(centres[:, 0], 3)))[:2], [-4.425, -4.275])
    grid = np.zeros((30, 30), dtype=int)
    occ = barn.rasterise(barn.cylinder_centres(grid))
    walls = np.array([[-2.25, 0.075], [-4.425, 2.0], [-0.075, 4.0], [-0.075, 0.225]])
    assert np.all(occ.distance(walls) < 0)
    robot = barn.jackal_robot()
    assert occ.distance(barn.START[:2]) > robot.bounding_radius
    assert occ.distance(barn.GOAL) > 3.0  # open beyond the field


def test_jackal_footprint_covers_the_rectangle():
    robot = barn.jackal_robot()
    xs, ys = np.meshgrid(np.linspace(-0.254, 0.254, 41), np.linspace(-0.215, 0.215, 31))
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1)
    circles = np.array(robot.footprint)
    covered = np.any(np.linalg.norm(pts[:, None] - circles[None, :, :2], axis=-1)
                     <= circles[None, :, 2] + 1e-9, axis=1)
    assert covered.all() and robot.v_limit == 1.0


def test_reference_path_length_and_score_by_hand(tmp_path):
    _, path = write_world(tmp_path, 3)
    # scorer mapping: (0.15 r - 4.575, 0.15 c + 5.075); row 14 -> x = -2.475
    pts = [(-2.25, 3.0)] + [(0.15 * r - 4.575, 0.15 * c + 5.075) for r, c in path] \
        + [(-2.25, 13.0)]
    by_hand = sum(math.dist(a, b) for a, b in zip(pts, pts[1:]))
    length = barn.reference_path_length(path)
    assert length == pytest.approx(by_hand)
    t_opt = length / 2
    assert barn.score(True, 0.5 * t_opt, length) == pytest.approx(0.5)
    assert barn.score(True, 4 * t_opt, length) == pytest.approx(0.25)
    assert barn.score(True, 100 * t_opt, length) == pytest.approx(1 / 8)
    assert barn.score(False, 3 * t_opt, length) == 0.0
    assert barn.score(True, 12.0, 11.0) == pytest.approx(5.5 / 12.0)


@pytest.mark.parametrize("content, problem", [
    (np.zeros((29, 30)), "shape"), (np.full((30, 30), 2), "0 or 1"), (None, "does not exist")])
def test_bad_grid_files_name_the_file(tmp_path, content, problem):
    path = tmp_path / "grid_files" / "grid_7.npy"
    path.parent.mkdir()
    if content is not None:
        np.save(path, content)
    with pytest.raises(ValueError, match=f"grid_7.npy.*{problem}"):
        barn.load_grid(path)
    bad = tmp_path / "path.npy"
    bad.write_text("not numpy")
    with pytest.raises(ValueError, match="path.npy.*not a NumPy"):
        barn.load_path(bad)


def settings(folder, **changes):
    kw = dict(data=str(folder), solver="sampling", n_samples=128, time_limit=0.6)
    kw.update(changes)
    return barn.BarnSettings(**kw)


def test_run_world_gives_a_full_row(tmp_path):
    write_world(tmp_path, 0)
    row = barn.run_world(0, settings(tmp_path))
    assert row["outcome"] == "timeout" and row["score"] == 0.0
    assert row["tortuosity"] == 4.0 and row["cycles"] == 3
    assert row["plan_time_median"] > 0


def test_benchmark_resume_skips_done_worlds(tmp_path, monkeypatch):
    for i in (0, 1):
        write_world(tmp_path / "data", i, with_metrics=i == 0)
    s = settings(tmp_path / "data")
    rows, summary = barn.run_benchmark(s, [0], tmp_path / "out", workers=1, progress=None)
    assert summary["worlds"] == 1 and (tmp_path / "out" / "barn.png").exists()
    assert 0 < summary["plan_time_median"] <= summary["plan_time_p95"]
    ran = []
    original = barn.run_world
    monkeypatch.setattr(barn, "run_world",
                        lambda i, st, *out: ran.append(i) or original(i, st, *out))
    rows, summary = barn.run_benchmark(s, [0, 1], tmp_path / "out", workers=1, resume=True,
                                       progress=None)
    assert ran == [1] and [r["world"] for r in rows] == [0, 1]
    assert rows[1]["tortuosity"] is None  # no metrics file: empty difficulty columns
    assert summary["timeout_rate"] == 1.0


def test_command_line_json_and_refusal_to_overwrite(tmp_path, capsys):
    write_world(tmp_path / "data", 0)
    argv = ["benchmark", "barn", "--data", str(tmp_path / "data"), "--worlds", "0",
            "--solver", "sampling", "--samples", "64", "--time-limit", "0.4", "--workers", "1",
            "--out", str(tmp_path / "out"), "--json"]
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    for key in ("worlds", "success_rate", "collision_rate", "timeout_rate", "mean_score"):
        assert key in summary
    assert summary["worlds"] == 1
    assert cli.main(argv) == 2
    assert "--resume" in capsys.readouterr().err
    assert cli.main(argv + ["--resume"]) == 0


@pytest.mark.slow
def test_real_world_zero_succeeds():
    import pathlib

    data = pathlib.Path("/work/shared/data/barn")
    if not data.exists():
        pytest.skip("no BARN data")
    row = barn.run_world(0, barn.BarnSettings(data=str(data), solver="sampling"))
    assert row["outcome"] == "success"


def test_overrides_reach_the_configuration(tmp_path):
    s = settings(tmp_path, overrides=(("sigma_static", 0.05), ("robot.omega_limit", 1.0)))
    config = s.config()
    assert config.cost.sigma_static == 0.05 and config.robot.omega_limit == 1.0
    assert config.robot.footprint == barn.jackal_robot().footprint
    assert s.meta()["overrides"] == {"sigma_static": 0.05, "robot.omega_limit": 1.0}
    with pytest.raises(ValueError, match="one value"):
        params.overrides(["sigma_static=0.05,0.1"])


def test_a_sensed_benchmark_on_a_local_dask_cluster_matches_local_processes(tmp_path, capsys):
    """``--scheduler`` on loopback (a Dask scheduler and a worker in this process) gives the
    rows local workers give, under a sensing profile; the table records the profile and both
    scores, and a bad profile file fails before anything runs, naming the file."""
    distributed = pytest.importorskip("distributed")
    write_world(tmp_path / "data", 0)
    base = ["benchmark", "barn", "--data", str(tmp_path / "data"), "--worlds", "0",
            "--solver", "sampling", "--samples", "64", "--time-limit", "0.6"]
    argv = base + ["--sensing", "lidar", "--json"]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None, protocol="tcp",
                                  host="127.0.0.1") as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        assert cli.main(argv + ["--scheduler", cluster.scheduler_address,
                                "--out", str(tmp_path / "dask")]) == 0
    on_dask = json.loads(capsys.readouterr().out)
    assert cli.main(argv + ["--workers", "1", "--out", str(tmp_path / "local")]) == 0
    local = json.loads(capsys.readouterr().out)
    table = json.loads((tmp_path / "dask" / "barn.json").read_text())
    assert table["meta"]["sensing"] == "lidar"
    rows = [{k: r[k] for k in ("world", "outcome", "score", "score_2020", "path_length")}
            for r in table["rows"]]
    local_rows = [{k: r[k] for k in ("world", "outcome", "score", "score_2020", "path_length")}
                  for r in json.loads((tmp_path / "local" / "barn.json").read_text())["rows"]]
    assert rows == local_rows and on_dask["worlds"] == local["worlds"] == 1
    bad = tmp_path / "bad.yaml"
    bad.write_text("lidar: {beams: 1}\n")
    assert cli.main(base + ["--sensing", str(bad), "--out", str(tmp_path / "x")]) == 2
    assert "bad.yaml" in capsys.readouterr().err and not (tmp_path / "x").exists()
