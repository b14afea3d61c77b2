"""tools/dev/docking_timing.py: docking's time with and without the goal's region, side by side."""

import json


def test_the_region_docks_where_the_goal_point_does_not(capsys, tool):
    assert tool("docking_timing").main(["--plans", "2", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["robot"], r["region_points"]) for r in rows] == [
        ("facing the goal", 0), ("facing the goal", 8), ("facing away", 0), ("facing away", 8)]
    assert [r["docked"] for r in rows] == [False, True, False, True]
    assert all(r["median_ms"] > 0.0 for r in rows)
