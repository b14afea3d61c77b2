"""tools/dev/where_runs_part.py: two configurations on one crowd replay, where the runs part."""

import json
from types import SimpleNamespace

import numpy as np
from test_crowds import write_recording


def test_parting_is_the_first_state_either_robot_differs_in(tool):
    where = tool("where_runs_part")
    states = np.zeros((1, 6, 5))
    other = states.copy()
    other[0, 4, 1] = 1e-12                        # the smallest difference counts
    assert where.parting(SimpleNamespace(states=states), SimpleNamespace(states=states)) is None
    assert where.parting(SimpleNamespace(states=states), SimpleNamespace(states=other)) == 4
    shorter = SimpleNamespace(states=states[:, :3])   # an outcome ends one run sooner
    assert where.parting(shorter, SimpleNamespace(states=other)) is None


def test_a_setting_that_changes_the_path_is_found_where_it_acts(tmp_path, capsys, tool):
    """The same replay twice is the same path; with another gain of the law the paths part
    once the robot is free of its acceleration limit (cycle 4 from a standstill here), and
    each side's message is the plan made there. Both sides read docking's survivability 0.1 m
    from the goal and the gate's at the horizon's end (``docking.arrival_at_tolerance`` and
    ``stall.threat_until_arrival`` off), so that the outcomes this checks do not move with those
    defaults (with both on, the first side's docked plan is no longer replaced by a dodge and it
    arrives too)."""
    write_recording(tmp_path / "data" / "toy" / "test" / "toy.txt")
    common = ["--data", str(tmp_path / "data"), "--scene", "toy", "--episodes", "0",
              "--solver", "sampling", "--json"]
    fixed = ["docking.arrival_at_tolerance=0", "stall.threat_until_arrival=0"]
    where = tool("where_runs_part")
    assert where.main(common + ["--a", *fixed, "--b", *fixed]) == 0
    same = json.loads(capsys.readouterr().out)
    assert same["parting_cycle"] is None and same["outcome_a"] == same["outcome_b"]
    assert where.main(common + ["--a", *fixed, "--b", *fixed, "control_law.k1=4"]) == 0
    parted = json.loads(capsys.readouterr().out)
    assert parted["parting_cycle"] == 4
    assert parted["parting_time"] == 0.8
    assert parted["message_a"].startswith("docked") and parted["message_b"].startswith("docked")
    assert (parted["outcome_a"], parted["outcome_b"]) == ("deadlock", "success")
