"""tools/dev/plan_profile.py: one CrowdNav episode (or ETH/UCY replay) run, then replayed plan by
plan by a fresh planner (the same plans), each plan's speed over its horizon beside the speed
the robot drove."""

import json
import math


def test_the_replayed_plans_are_the_logged_ones_and_their_first_speed_was_driven(capsys, tool):
    assert tool("plan_profile").main([
        "--scene", "circle", "--seed", "0", "--episode", "0", "--at", "0", "0.25", "9",
        "--solver", "sampling", "--samples", "64", "--duration", "1"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["replayed"] is True
    first, second, beyond = report["plans"]
    assert first["time"] == 0.0 and second["time"] == 0.25
    assert beyond == {"time": 9.0, "planned": False}       # past the 1 s episode
    for plan in (first, second):
        assert plan["planned"] and len(plan["z"]) == 4 and plan["stall_level"] == 0
        assert len(plan["speed"]) == 13                     # 25 steps of 0.2 s, every 0.4 s
        assert all(0.0 <= v <= 1.0 + 1e-9 for v in plan["speed"])
        assert len(plan["survivability"]) == 9 and plan["survivability"][0] == 1.0
        assert math.isfinite(plan["turn_cost"])
        # The loop holds the plan's first control for its 0.25 s cycle.
        assert abs(plan["speed"][0] - plan["next_speed"]) <= 1e-3


def test_a_planner_that_is_not_the_runs_is_caught(monkeypatch, capsys, tool):
    """The check can fail: a replay with other settings than the run's plans otherwise."""
    module = tool("plan_profile")
    real = module.Planner

    def other(config, solver):
        import dataclasses
        return real(dataclasses.replace(config, cost=dataclasses.replace(
            config.cost, w_progress=0.01)), solver)

    monkeypatch.setattr(module, "Planner", other)
    module.main(["--scene", "circle", "--seed", "0", "--episode", "0", "--at", "0",
                 "--solver", "sampling", "--samples", "64", "--duration", "1"])
    assert json.loads(capsys.readouterr().out)["replayed"] is False


def test_an_ethucy_replay_is_profiled_as_its_benchmark_ran_it(tmp_path, capsys, tool):
    """With ``--data`` the episode is ``dsmpepc benchmark crowd``'s crossing: the same outcome
    and time as the benchmark's row, replayed plan by plan. A CrowdNav-less scene without
    ``--data`` is refused by name."""
    import pytest
    from test_crowds import write_recording

    from dsmpepc_nlp import cli
    write_recording(tmp_path / "data" / "toy" / "test" / "toy.txt")
    common = ["--solver", "sampling", "--samples", "32", "--duration", "8"]
    assert cli.main(["benchmark", "crowd", "--data", str(tmp_path / "data"), "--scene", "toy",
                     "--episodes", "2", "--variants", "ds-mpepc", "--workers", "1",
                     "--out", str(tmp_path / "out"), "--json", *common]) == 0
    capsys.readouterr()
    rows = json.loads((tmp_path / "out" / "crowd.json").read_text())["rows"]
    row = next(r for r in rows if r["episode"] == 1)
    assert tool("plan_profile").main(["--data", str(tmp_path / "data"), "--scene", "toy",
                                      "--seed", "0", "--episode", "1", "--at", "0", "1",
                                      *common]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["replayed"] is True
    assert (report["outcome"], report["time"]) == (row["outcome"], row["time"])
    assert [p["time"] for p in report["plans"]] == [0.0, 1.0]
    assert all(p["planned"] and len(p["z"]) == 4 for p in report["plans"])
    with pytest.raises(SystemExit):
        tool("plan_profile").main(["--scene", "toy", "--episode", "0", "--at", "0"])
    assert "needs --data" in capsys.readouterr().err
