"""tools/docking_ways.py: docking's ways at each logged cycle, tried whether or not the run's
docking tried them."""

import json

import numpy as np
from test_failures import make_episode


def test_a_curve_passes_where_every_straight_way_fails(tmp_path, capsys, tool):
    """The scene of tests/test_docking_curves.py, logged: a robot creeping along +y with its
    goal 1.5 m to its right and a person standing 0.65 m off the middle of the line to it."""
    n = 4
    xy = np.stack([np.zeros(n), np.arange(n) * 1e-4], 1)
    peds = np.tile([[[0.75, -0.65]]], (n, 1, 1))
    path = make_episode(xy, "deadlock", peds=peds, goal=(1.5, 0.0)).save(tmp_path / "e.npz")
    assert tool("docking_ways").main([str(path), "--cycles", "0", "1", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["cycle"] for r in rows] == [0, 1]
    for r in rows:
        assert r["straight"]["turns_first"] and r["straight"]["passing"] == 0
        assert r["region"]["passing"] == 0 and r["region"]["best"] < 0.9
        assert r["curves"]["passing"] >= 1 and r["curves"]["best"] > 0.9
    assert tool("docking_ways").main([str(path), "--curves", "0"]) == 0
    text = capsys.readouterr().out
    assert "curves - (0 pass)" in text and text.count("cycle ") == 3


def test_cycles_beyond_the_docking_radius_are_left_out(tmp_path, capsys, tool):
    xy = np.stack([np.zeros(3), np.zeros(3)], 1)
    path = make_episode(xy, "deadlock", goal=(9.0, 0.0)).save(tmp_path / "far.npz")
    assert tool("docking_ways").main([str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == []
