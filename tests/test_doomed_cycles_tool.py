"""tools/dev/doomed_cycles.py: every collision of a benchmark folder replayed plan by plan (the
same plans, or it says not), and the plans of its last seconds read for their survival."""

import dataclasses
import json

import numpy as np

from dsmpepc_nlp.bench.results import TABLE_FORMAT
from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.sim.simulate import simulate
from dsmpepc_nlp.sim.types import Agent, FixedGoal, Pedestrian, Scenario


def head_on_folder(tmp_path):
    """A benchmark-like folder: a person walking at 1.5 m/s into a robot that starts 2 m away
    (a collision, its episode kept) and a success row without one. Passive safety is off, so
    that the last resort makes every plan: with it, one plan in which standing is already the
    stillest way goes on to the rung's reverse by the cost (``tests/test_passive.py``)."""
    walker = (Pedestrian.constant((2.0, 0.0), (-1.5, 0.0), 0.3),)
    scenario = Scenario("head-on", (Agent("robot", RobotState(0.0, 0.0, 0.0),
                                          FixedGoal((5.0, 0.0))),), None, walker, duration=3.0)
    config = PlannerConfig()
    config = dataclasses.replace(config, stall=dataclasses.replace(config.stall, passive=False))
    episode = simulate(scenario, config, SolverConfig.sampling(n_samples=64),
                       np.random.default_rng(0), record_trajectories=False)
    assert episode.outcomes == ["collision"]
    episode.save(tmp_path / "episodes" / "head-on.npz")
    rows = [{"episode": 0, "outcome": "collision", "episode_file": "episodes/head-on.npz"},
            {"episode": 1, "outcome": "success", "episode_file": ""}]
    (tmp_path / "toy.json").write_text(json.dumps(
        {"format": TABLE_FORMAT, "key_fields": ["episode"], "rows": rows}))
    return episode


def test_a_collision_after_doomed_plans_is_counted_with_the_logged_plans(tmp_path, capsys,
                                                                          tool):
    episode = head_on_folder(tmp_path)
    assert set(episode.status_names(0)) == {"clearing"}       # the last resort acted
    module = tool("doomed_cycles")
    assert module.main([str(tmp_path), "--before", "0.5", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["summary"] == {"collisions": 1, "below": 0.05, "doomed_by_the_end": 1,
                                 "doomed_within": 1, "cleared": 1, "not_replayed": []}
    run = report["runs"]["toy episode=0"]
    contact = float(episode.outcome_times[0])
    assert run["replayed"] is True and run["contact"] == contact
    times = [p["time"] for p in run["plans"]]
    assert times and min(times) >= contact - 0.5 - 1e-9 and max(times) < contact
    for plan in run["plans"]:
        assert plan["status"] == "clearing"
        assert plan["survival_within"] >= plan["survival_end"]   # survival only falls
        assert plan["survival_end"] < 0.05 and np.isfinite(plan["cheapest"])


def test_a_replay_with_other_settings_than_the_runs_is_caught(tmp_path, capsys, tool):
    """The check can fail: without the last resort the replayed plans are not the logged."""
    head_on_folder(tmp_path)
    module = tool("doomed_cycles")
    assert module.main([str(tmp_path), "--set", "stall.doomed_below=0"]) == 0
    out = capsys.readouterr().out
    assert "(NOT the logged plans)" in out and "not replayed: 1" in out
    assert "1 of 1 collisions came after a plan doomed by the horizon's end" in out
    assert "0 after a plan the last resort made (clearing)" in out     # it was off


def test_the_summary_counts_doom_below_the_threshold_only(tool):
    summary = tool("doomed_cycles").summary
    runs = {"a": {"replayed": True, "plans": [{"survival_end": 0.04, "survival_within": 0.5,
                                               "status": "nlp"}]},
            "b": {"replayed": False, "plans": [{"survival_end": 0.2, "survival_within": 0.3,
                                                "status": "clearing"}]},
            "c": {"replayed": True, "plans": []}}
    assert summary(runs, 0.05) == {"collisions": 3, "below": 0.05, "doomed_by_the_end": 1,
                                   "doomed_within": 0, "cleared": 1, "not_replayed": ["b"]}
    assert summary(runs, 0.4)["doomed_within"] == 1
