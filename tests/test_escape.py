"""The escape search on hand-built collisions whose way out (or its absence) is known."""

import math

import numpy as np
import pytest
from test_failures import DT, make_episode, standing

from dsmpepc_nlp.bench import escape, failure_report
from dsmpepc_nlp.bench.failure_report import classify_folder
from dsmpepc_nlp.bench.results import ResultTable, keep_failure
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.world import OccupancyGrid
from dsmpepc_nlp.sim.episode import Episode


def walker(start, velocity, n):
    return (np.asarray(start, float) + np.arange(n)[:, None] * DT * np.asarray(velocity))[:, None]


def corridor(width):
    """Walls at |y| > width / 2 everywhere on a 6 x 2 m grid centred on the origin."""
    h = 0.05
    ys = -1.0 + (np.arange(40) + 0.5) * h
    occupied = np.broadcast_to((np.abs(ys) > width / 2)[:, None], (40, 120)).copy()
    return OccupancyGrid(occupied, h, (-3.0, -1.0))


@pytest.fixture(autouse=True)
def fewer_states(monkeypatch):
    monkeypatch.setattr(escape, "MAX_STATES", 10_000)       # fast; the answers stay the same


def test_a_walker_from_the_side_could_have_been_left_behind_driving_forward():
    # the robot stands facing +x; a walker at 1 m/s from -y touches it after 1.4 s
    ep = make_episode(standing(8), "collision", peds=walker((0.0, -1.95), (0.0, 1.0), 8))
    found = escape.search(ep, 0, reverse=0.0)
    assert found.found and found.start == 0.0 and found.states == 10_000
    assert not found.exhaustive                       # cut to MAX_STATES, and said so
    assert escape.escapes(ep)["escape"] == "forward"


def test_a_walker_already_at_arms_length_cannot_be_escaped():
    # 5 cm apart and closing at 1.5 m/s: one step moves the robot at most 6 cm
    ep = make_episode(standing(2), "collision", peds=walker((0.0, -0.65), (0.0, 1.5), 2))
    assert not escape.search(ep, 0).found
    evidence = escape.escapes(ep)
    assert evidence["escape"] == "none" and evidence["escape_exhaustive"]


def test_head_on_in_a_corridor_only_a_full_speed_reverse_gets_away():
    # 0.9 m corridor: no passing, and turning round takes longer than the 1 m gap lasts at
    # 1 m/s; reversing at the rung's 0.3 m/s closes 0.7 m/s; at up to 1 m/s the gap holds
    ep = make_episode(standing(6), "collision", peds=walker((1.6, 0.0), (-1.0, 0.0), 6),
                      grid=corridor(0.9))
    assert not escape.search(ep, 0, reverse=0.0).found
    assert not escape.search(ep, 0, reverse=0.3).found
    assert escape.search(ep, 0, reverse=math.inf).found
    assert escape.escapes(ep)["escape"] == "full"


def test_the_search_starts_when_the_person_set_off():
    # the walker stands, then walks at 1.5 m/s from state 4 on (the hand-built log's velocity
    # at a state is its next step's): nothing was known before it set off
    n = 9
    y = np.concatenate([np.full(5, -1.5), -1.5 + 0.3 * np.arange(1, n - 4)])
    ep = make_episode(standing(n), "collision", peds=np.stack([np.zeros(n), y], 1)[:, None])
    assert escape.search(ep, 0).start == pytest.approx(4 * DT)


def test_reacting_people_other_robots_and_successes_are_refused():
    ep = make_episode(standing(8), "collision", peds=walker((0.0, -1.95), (0.0, 1.0), 8))
    ep.meta["scenario"] = "crowdnav-circle-visible-0-3"
    with pytest.raises(InputError, match="react to the robot"):
        escape.search(ep)
    assert escape.escapes(ep)["escape"].startswith("not searched: ")
    with pytest.raises(InputError, match="not a collision"):
        escape.search(make_episode(standing(8), "deadlock"))


def test_the_folder_report_counts_the_ways_out(tmp_path):
    table = ResultTable(tmp_path, "crowd", ("episode",), {"benchmark": "crowd"})
    for i, (start, v, n) in enumerate((((0.0, -1.95), (0.0, 1.0), 8),
                                       ((0.0, -0.65), (0.0, 1.5), 2))):
        ep = make_episode(standing(n), "collision", peds=walker(start, v, n))
        table.add({"episode": i, "outcome": "collision",
                   "episode_file": keep_failure(ep, tmp_path, f"e{i}")})
    assert "escapes" not in classify_folder(tmp_path)
    report = classify_folder(tmp_path, escape=True)
    assert report["escapes"] == {"forward": 1, "none": 1}
    assert {f["evidence"]["escape"] for f in report["failures"]} == {"forward", "none"}
    for i in range(2, 4):                                   # two runs that succeeded
        table.add({"episode": i, "outcome": "success"})
    report = classify_folder(tmp_path, escape=True)
    assert report["no_way_out"] == 1                        # the walker 0.65 m off at 1.5 m/s
    assert report["bound_given_path"] == pytest.approx(0.75)
    assert "no_way_out" not in classify_folder(tmp_path)
    for i in range(2):                                      # people who react: no search
        ep = Episode.load(tmp_path / f"episodes/e{i}.npz")
        ep.meta["scenario"] = "crowdnav-circle-visible-0-3"
        ep.save(tmp_path / f"episodes/e{i}.npz")
    report = classify_folder(tmp_path, escape=True)
    assert report["escapes"] == {"not searched": 2} and "bound_given_path" not in report


def test_the_bound_counts_only_exhaustive_searches_and_never_free_goals():
    def failure(escape=None, exhaustive=True, free_at="absent"):
        evidence = {} if escape is None else {"escape": escape, "escape_exhaustive": exhaustive}
        if free_at != "absent":
            evidence["goal_free_at"] = free_at
        return {"evidence": evidence}

    failures = [failure("none"), failure("none", exhaustive=False), failure("forward"),
                failure(free_at=None)]
    bound = failure_report._bound_given_path(failures, never=1, runs=10)
    assert bound == {"no_way_out": 1, "bound_given_path": pytest.approx(0.8)}
