"""tools/dev/stuck_cycle.py: a logged cycle re-costed: the best sampled trajectory, the stop."""

import json

import numpy as np
from test_failures import make_episode, standing


def test_a_robot_facing_an_open_goal_is_told_to_go_not_to_stand(tmp_path, capsys, tool):
    episode = make_episode(standing(6), "deadlock", goal=(5.0, 0.0))   # nobody around
    path = episode.save(tmp_path / "open.npz")
    assert tool("stuck_cycle").main([str(path), "--cycle", "2", "--samples", "64"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["cycle"] == 2
    assert report["stop"]["z"][3] == 0.0
    assert report["best_is_stop"] is False
    assert report["lowest_cost"]["total"] < report["stop"]["total"]
    assert report["lowest_cost"]["z"][3] > 0.0                       # it moves


def test_the_law_cannot_back_away_from_a_person_just_ahead(tmp_path, tool):
    """The trap of docs/experiments/2026-11-25-two-more-failure-classes.md: a standing person
    0.05 m ahead, the goal beyond them.
    The pose-following law turns only while driving forward, so no trajectory keeps more
    survivability than standing (a law that can back up or spin in place would)."""
    peds = np.tile([[[0.65, 0.0]]], (6, 1, 1))
    episode = make_episode(standing(6), "deadlock", peds=peds, goal=(5.0, 0.0))
    evaluation, stop = tool("stuck_cycle").costed(episode, 2, episode.config(), n_samples=256)
    assert evaluation.z[stop, 3] == 0.0
    survival = evaluation.costs.survivability
    assert np.max(survival[:, -1]) <= survival[stop, -1] + 1e-12  # nothing outlives standing


def test_the_cycle_is_costed_at_the_robots_ladder_level(tmp_path, capsys, tool):
    """After 12 s standing the robot planned at the ladder's top (3): the tool says so and
    costs the cycle with the progress weight it planned with, so the moving plan's lead over
    standing is larger than at level 0 (``--level 0``, the weight unraised)."""
    from test_failures import STALL
    episode = make_episode(standing(STALL), "deadlock", goal=(5.0, 0.0))
    path = episode.save(tmp_path / "stood.npz")
    runs = {}
    for extra in ([], ["--level", "0"]):
        assert tool("stuck_cycle").main([str(path), "--cycle", "40", "--samples", "64",
                                         *extra]) == 0
        runs[tuple(extra)] = json.loads(capsys.readouterr().out)
    at, zero = runs[()], runs[("--level", "0")]
    assert at["stall_level"] == 3 and zero["stall_level"] == 0
    lead = at["stop"]["total"] - at["lowest_cost"]["total"]
    assert lead > zero["stop"]["total"] - zero["lowest_cost"]["total"] > 0.0
