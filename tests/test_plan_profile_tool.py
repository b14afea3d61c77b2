"""tools/plan_profile.py: one CrowdNav episode re-run with its plans kept, each plan's speed
over its horizon beside the speed the robot then drove at."""

import json


def test_a_plans_first_speed_is_the_speed_the_robot_drove(capsys, tool):
    assert tool("plan_profile").main([
        "--scene", "circle", "--seed", "0", "--episode", "0", "--at", "0", "0.25", "9",
        "--solver", "sampling", "--samples", "64", "--duration", "1"]) == 0
    report = json.loads(capsys.readouterr().out)
    first, second, beyond = report["plans"]
    assert first["time"] == 0.0 and second["time"] == 0.25
    assert beyond == {"time": 9.0, "planned": False}       # past the 1 s episode
    for plan in (first, second):
        assert plan["planned"] and len(plan["z"]) == 4
        assert len(plan["speed"]) == 13                     # 25 steps of 0.2 s, every 0.4 s
        assert all(0.0 <= v <= 1.0 + 1e-9 for v in plan["speed"])
        # The loop holds the plan's first control for its 0.25 s cycle.
        assert abs(plan["speed"][0] - plan["next_speed"]) <= 2e-3
    assert second["state"][3] == first["next_speed"]
