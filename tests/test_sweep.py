"""Sweeps: grid expansion, failed runs kept, resume, heatmaps, Dask on a local cluster."""

import json

import pytest

from dsmpepc_nlp import cli
from dsmpepc_nlp.bench import params as bench_params
from dsmpepc_nlp.bench import sweep

TINY = """name: tiny
duration: 0.6
robots:
- name: r
  start: [0.0, 0.0, 0.0]
  goal:
    position: [3.0, 0.0]
  footprint:
  - [0.0, 0.0, 0.3]
pedestrians:
- start: [2.0, 1.0]
  velocity: [0.0, -0.3]
"""


@pytest.fixture
def tiny(tmp_path):
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY)
    return str(path)


SETTINGS = sweep.SweepSettings(solver="sampling", n_samples=32)


def test_parse_and_expand():
    params = bench_params.parse_params(["s_ttc=0.25,0.5,1", "s_ttg=1e-3,1e-2", "robot.v_limit=1"])
    assert params == {"s_ttc": [0.25, 0.5, 1.0], "s_ttg": [0.001, 0.01],
                      "robot.v_limit": [1.0]}
    runs = sweep.expand_grid(params, ["a", "b"], [0, 1, 2])
    assert len(runs) == 3 * 2 * 1 * 2 * 3
    assert runs[0] == {"params": {"s_ttc": 0.25, "s_ttg": 0.001, "robot.v_limit": 1.0},
                       "scenario": "a", "seed": 0}
    config = bench_params.configure({"s_ttc": 0.25, "robot.v_limit": 1.5}, "mpepc")
    assert config.cost.s_ttc == 0.25 and config.robot.v_limit == 1.5
    assert not config.anticipatory_pc


@pytest.mark.parametrize("spec, problem", [
    ("nope=1", "no field 'nope'"), ("s_ttc", "NAME=V1"), ("s_ttc=a", "numbers"),
    ("wheels.x=1", "section 'wheels'")])
def test_bad_params_are_errors(spec, problem):
    with pytest.raises(ValueError, match=problem):
        bench_params.parse_params([spec])


def test_failed_run_is_recorded_and_resume_skips_done(tmp_path, tiny):
    params = {"a": [0.5, 2.0]}  # a = 2 is outside [0, 1]: the run fails
    out = tmp_path / "out"
    summary = sweep.run_sweep(params, [tiny], [0, 1], SETTINGS, out, workers=1, progress=None)
    assert summary["runs"] == 4 and summary["failed"] == 2
    rows = json.loads((out / "sweep.json").read_text())["rows"]
    failed = [r for r in rows if r["status"] == "failed"]
    assert {r["a"] for r in failed} == {2.0}
    assert "CostConfig.a" in failed[0]["message"]
    assert (out / "sweep_a_scenario.png").exists()
    ok = [r for r in rows if r["status"] == "ok"]
    assert ok[0]["outcomes"] == ok[1]["outcomes"]  # seeded, reproducible
    # same settings, same grid: nothing to run again
    from io import StringIO

    stream = StringIO()
    again = sweep.run_sweep(params, [tiny], [0, 1], SETTINGS, out, workers=1, resume=True,
                            progress=stream)
    assert again["runs"] == 4 and "4 already done, 0 to run on" in stream.getvalue()


def test_two_parameters_give_a_pair_heatmap_and_cli_json(tmp_path, tiny, capsys):
    argv = ["sweep", "--param", "s_ttc=0.5,1", "--param", "s_ttg=1e-3,1e-2", "--scenarios",
            tiny, "--seeds", "0", "--solver", "sampling", "--samples", "16", "--workers", "1",
            "--out", str(tmp_path / "o"), "--json"]
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["runs"] == 4 and summary["failed"] == 0
    assert (tmp_path / "o" / "sweep_s_ttc_s_ttg.png").exists()
    xs, ys, grid = sweep.rate_grid(json.loads((tmp_path / "o" / "sweep.json").read_text())
                                   ["rows"], "s_ttc", "s_ttg", "success_rate")
    assert xs == [0.5, 1.0] and ys == [0.001, 0.01] and grid.shape == (2, 2)


def test_unknown_scenario_fails_before_running(tmp_path, capsys):
    assert cli.main(["sweep", "--param", "a=0.5", "--scenarios", "no-such-scenario",
                           "--out", str(tmp_path / "o")]) == 2
    assert "no-such-scenario" in capsys.readouterr().err


def test_dask_local_cluster(tmp_path, tiny):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        summary = sweep.run_sweep({"s_ttc": [0.5, 1.0]}, [tiny], [0], SETTINGS,
                                  tmp_path / "dask", scheduler=cluster.scheduler_address,
                                  progress=None)
    assert summary["runs"] == 2 and summary["failed"] == 0
    local = sweep.run_sweep({"s_ttc": [0.5, 1.0]}, [tiny], [0], SETTINGS, tmp_path / "proc",
                            workers=1, progress=None)
    rows = {r["key"]: r["outcomes"] for r in
            json.loads((tmp_path / "dask" / "sweep.json").read_text())["rows"]}
    rows_local = {r["key"]: r["outcomes"] for r in
                  json.loads((tmp_path / "proc" / "sweep.json").read_text())["rows"]}
    assert rows == rows_local and local["runs"] == 2


def test_start_noise_makes_seeds_differ_reproducibly(tiny):
    settings = sweep.SweepSettings(solver="sampling", n_samples=16, start_noise=0.2)
    rows = [sweep.run_one({"params": {}, "scenario": tiny, "seed": k}, settings)
            for k in (0, 1, 0)]
    assert rows[0]["path_length"] == rows[2]["path_length"] != rows[1]["path_length"]


def test_variants_side_by_side_with_orca(tmp_path, tiny, capsys):
    pytest.importorskip("pyrvo")
    argv = ["benchmark", "scenarios", "--scenarios", tiny, "--variants", "mpepc", "orca",
            "--seeds", "0-1", "--solver", "sampling", "--samples", "16", "--workers", "1",
            "--out", str(tmp_path / "s"), "--json"]
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["runs"] == 4
    assert summary["variants"]["orca"]["tiny"]["runs"] == 2
    assert summary["variants"]["orca"]["tiny"]["failed"] == 0
    planner = summary["variants"]["mpepc"]["tiny"]
    assert 0 < planner["plan_time_median"] <= planner["plan_time_p95"]


def test_scenarios_take_set_and_keep_it_in_the_table(tmp_path, tiny, capsys):
    """``benchmark scenarios --set NAME=VALUE`` replaces a field of the preset for every run
    (here the robot's speed limit, which changes the path), stores it in the table's meta,
    and a table made with other settings is not resumed with these."""
    common = ["benchmark", "scenarios", "--scenarios", tiny, "--variants", "ds-mpepc",
              "--solver", "sampling", "--samples", "16", "--workers", "1", "--json"]
    assert cli.main([*common, "--out", str(tmp_path / "a")]) == 0
    plain = json.loads(capsys.readouterr().out)
    argv = [*common, "--out", str(tmp_path / "b"), "--set", "robot.v_limit=0.5"]
    assert cli.main(argv) == 0
    slow = json.loads(capsys.readouterr().out)
    meta = json.loads((tmp_path / "b" / "scenarios.json").read_text())["meta"]
    assert meta["overrides"] == {"robot.v_limit": 0.5}
    rows = json.loads((tmp_path / "b" / "scenarios.json").read_text())["rows"]
    assert rows and all(r["robot.v_limit"] == 0.5 for r in rows)
    assert slow["variants"]["ds-mpepc"] != plain["variants"]["ds-mpepc"]
    assert cli.main([*common, "--out", str(tmp_path / "a"), "--set", "robot.v_limit=0.5",
                     "--resume"]) != 0
