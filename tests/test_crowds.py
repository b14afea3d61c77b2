"""ETH/UCY loader, crossing scenarios and the crowd benchmark on tiny recordings."""

import json

import numpy as np
import pytest

from dsmpepc_nlp import cli
from dsmpepc_nlp.bench import crowd_rows, crowds


def write_recording(path, n_steps=150, first_frame=0):
    """Four pedestrians: three walk across all along, one enters at step 25 and walks up."""
    lines = []
    for k in range(n_steps):
        frame = first_frame + 10 * k
        t = 0.4 * k
        lines.append(f"{frame}\t1.0\t{0.5 + 0.8 * t % 10:.3f}\t2.0")
        lines.append(f"{frame}.0\t2.0\t{9.5 - 0.8 * t % 10:.3f}\t6.0")
        lines.append(f"{frame}\t4.0\t{2.0 + 0.1 * t:.3f}\t10.0")
        if 25 <= k < 60:
            lines.append(f"{frame}\t3.0\t5.0\t{0.4 * (k - 25):.3f}")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def test_loader_reads_floats_and_times(tmp_path):
    rec = crowds.load_recording(write_recording(tmp_path / "zara" / "test" / "toy.txt"))
    assert rec.frame.dtype == np.int64 and rec.step_time == 0.4
    assert rec.span == (0.0, pytest.approx(0.4 * 149))
    assert set(rec.ped.tolist()) == {1, 2, 3, 4}
    eth = crowds.load_recording(write_recording(tmp_path / "biwi_eth.txt"))
    assert eth.step_time == 0.8  # FORMAT.md's eth caveat: time rescaled


@pytest.mark.parametrize("text, problem", [
    ("0\t1\t2.0\n", "line 1.*4 tab-separated"), ("0\t1\t2\tx\n", "line 1"),
    ("0\t1\t2\t3\n0\t1\t2\t3\n", "duplicate"), ("", "no rows")])
def test_loader_errors_name_the_file(tmp_path, text, problem):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(ValueError, match=f"bad.txt.*{problem}"):
        crowds.load_recording(path)
    with pytest.raises(ValueError, match="missing.txt.*does not exist"):
        crowds.load_recording(tmp_path / "missing.txt")


def test_crossing_is_seeded_clear_and_pedestrians_appear_on_time(tmp_path):
    rec = crowds.load_recording(write_recording(tmp_path / "toy.txt"))
    a, draw_a = crowds.crossing_scenario(rec, np.random.default_rng(3), duration=20.0)
    b, draw_b = crowds.crossing_scenario(rec, np.random.default_rng(3), duration=20.0)
    assert draw_a == draw_b
    start = a.agents[0].start
    goal = np.array(a.agents[0].goal.position)
    assert 4.0 <= np.hypot(goal[0] - start.x, goal[1] - start.y) <= 8.5
    for p in a.pedestrians:
        gap = np.hypot(*(p.position(0.0) - (start.x, start.y))) - 0.6
        assert gap >= 0.5
    # the walker that enters late is off stage before its first waypoint
    late = crowds._tracks(rec, 0.0, 30.0, 0.1)[2]
    assert np.allclose(late.position(0.0), crowds.OFFSTAGE)
    assert np.allclose(late.position(10.1), (5.0, 0.0))
    assert np.allclose(late.velocity_at(10.2), (0.0, 1.0))
    assert np.all(np.abs(late.velocity_at(t)) < 2 for t in np.arange(0, 30, 0.2))


def test_goal_clear_redraws_a_goal_a_person_stands_on_and_keeps_every_other_draw(tmp_path):
    """A person standing at (5, 8) for the whole recording: without ``goal_clear`` some seeds
    put the goal on them (a position a pedestrian took); with it none does, and a draw whose
    goal was clear anyway is the same draw."""
    path = write_recording(tmp_path / "toy.txt")
    path.write_text(path.read_text() + "".join(f"{10 * k}\t5.0\t5.0\t8.0\n"
                                               for k in range(150)))
    rec = crowds.load_recording(path)
    near, kept = 0, 0
    for seed in range(40):
        first, plain = crowds.crossing_scenario(rec, np.random.default_rng(seed), duration=20.0)
        _, clear = crowds.crossing_scenario(rec, np.random.default_rng(seed),
                                                   duration=20.0, goal_clear=True)
        on_person = np.hypot(plain["goal"][0] - 5.0, plain["goal"][1] - 8.0) < 1.1
        near += on_person
        assert np.hypot(clear["goal"][0] - 5.0, clear["goal"][1] - 8.0) >= 1.1
        if not crowds._occupied(first.pedestrians, plain["goal"], 19.0, 20.0, 0.2, 1.1):
            kept += 1
            assert clear == plain
        if plain["goal"] == [5.0, 8.0]:  # on the person who stands there to the end
            assert plain["goal_free_at"] is None
    assert near > 0 and kept > 0


def test_goal_free_at_is_none_only_when_no_robot_could_stand_at_the_goal():
    """The first time, no sooner than a straight run at the speed limit, at which nobody
    covers the goal's tolerance disc for the footprint's circle; None when that never comes."""
    from dsmpepc_nlp.sim.types import Pedestrian

    start, goal = (0.0, 0.0), (4.0, 0.0)

    def free_at(*peds):
        return crowds.goal_free_at(list(peds), start, goal, 0.3, 0.3, 1.0, 10.0, 0.2)

    def standing(until, at=goal):
        return Pedestrian(np.array([0.0, until, until + 0.5]),
                          np.array([at, at, (at[0], at[1] + 5.0)]))

    assert free_at() == pytest.approx(3.8)               # (4 - 0.3) / 1 m/s, on the 0.2 s grid
    assert crowds.goal_free_at([], start, (40.0, 0.0), 0.3, 0.3, 1.0, 10.0, 0.2) is None
    assert free_at(standing(20.0)) is None               # there past the end: no planner wins
    assert free_at(standing(2.0)) == pytest.approx(3.8)  # gone before the robot could arrive
    assert 6.0 < free_at(standing(6.0)) <= 6.4           # the goal frees as the person leaves
    # 0.35 m off the goal: the point of the tolerance disc farthest from them is 0.65 m away,
    # past the two bodies' 0.6 m; at 0.25 m every point of it is within 0.55 m
    assert free_at(standing(20.0, at=(4.0, 0.35))) == pytest.approx(3.8)
    assert free_at(standing(20.0, at=(4.0, 0.25))) is None


def test_footprint_core_is_what_the_body_covers_whatever_its_heading():
    from dsmpepc_nlp.core.config import RobotConfig

    assert crowd_rows.footprint_core(RobotConfig().footprint) == 0.3
    three = RobotConfig(footprint=((-0.15, 0.0, 0.2), (0.0, 0.0, 0.2), (0.15, 0.0, 0.2)))
    assert crowd_rows.footprint_core(three.footprint) == pytest.approx(0.2)
    # no circle on the reference point: only 0.05 m about it is body at every heading
    two = RobotConfig(footprint=((0.2, 0.0, 0.25), (-0.2, 0.0, 0.25)))
    assert crowd_rows.footprint_core(two.footprint) == pytest.approx(0.05)


def test_summary_counts_the_runs_no_planner_can_win():
    rows = [{"outcome": "deadlock", "goal_free_at": None},
            {"outcome": "success", "goal_free_at": 4.2},
            {"outcome": "success", "goal_free_at": 5.0},
            {"outcome": "deadlock", "goal_free_at": 12.0}]
    assert crowd_rows.summarise(rows)["goal_never_free_rate"] == 0.25
    assert "goal_never_free_rate" not in crowd_rows.summarise([{"outcome": "success"}])


def test_too_short_recording_is_an_error(tmp_path):
    rec = crowds.load_recording(write_recording(tmp_path / "toy.txt", n_steps=10))
    with pytest.raises(ValueError, match="shorter"):
        crowds.crossing_scenario(rec, np.random.default_rng(0), duration=30.0)


def test_benchmark_two_variants_and_resume(tmp_path, capsys):
    pytest.importorskip("pyrvo")  # the ORCA variant
    write_recording(tmp_path / "data" / "toy" / "test" / "toy.txt")
    argv = ["benchmark", "crowd", "--data", str(tmp_path / "data"), "--scene", "toy",
            "--episodes", "2", "--variants", "ds-mpepc", "orca", "--solver", "sampling",
            "--samples", "32", "--duration", "8", "--workers", "1",
            "--out", str(tmp_path / "out"), "--json"]
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["episodes"] == 2 and "collision_rate" in summary
    for variant in summary["variants"].values():  # the fair split is in every crowd table
        assert variant["at_fault_rate"] + variant["struck_rate"] == variant["collision_rate"]
        assert 0.0 <= variant["spl"] <= 1.0
    assert set(summary["variants"]) == {"ds-mpepc", "orca"}
    assert cli.main(argv + ["--resume", "--episodes", "3"]) == 0
    captured = capsys.readouterr()
    assert "6 runs, 4 already done, 2 to run" in captured.err
    assert json.loads(captured.out)["episodes"] == 3


def test_unknown_scene_is_an_error(tmp_path, capsys):
    assert cli.main(["benchmark", "crowd", "--data", str(tmp_path), "--scene", "nope",
                           "--out", str(tmp_path / "o")]) == 2
    assert "nope" in capsys.readouterr().err


def test_no_simulation_time_falls_inside_a_jump(tmp_path):
    rec = crowds.load_recording(write_recording(tmp_path / "toy.txt"))
    for seed in range(5):
        scenario, draw = crowds.crossing_scenario(rec, np.random.default_rng(seed),
                                                  duration=20.0)
        assert draw["window_start"] / 0.4 == pytest.approx(round(draw["window_start"] / 0.4))
        times = np.arange(0.0, 20.0 + 1e-9, 0.2)
        for p in scenario.pedestrians:
            speeds = [np.hypot(*p.velocity_at(t)) for t in times]
            assert max(speeds) < 100.0  # a jump off stage would be ~1e6 m/s


def test_summary_ignores_runs_that_met_no_pedestrian():
    rows = [{"outcome": "success", "min_distance": 0.5, "time_to_goal": 5.0},
            {"outcome": "collision", "min_distance": -0.1},
            {"outcome": "success", "min_distance": 9000.0, "time_to_goal": 7.0}]
    summary = crowd_rows.summarise(rows)
    assert summary["min_distance_mean"] == pytest.approx(0.2)
    assert summary["min_distance"] == -0.1 and summary["episodes_with_pedestrians"] == 2
    assert summary["time_to_goal"] == 6.0 and summary["collision_rate"] == pytest.approx(1 / 3)


def test_summary_splits_collisions_by_fault():
    rows = [{"outcome": "collision", "collision_kind": "at-fault", "spl": 0.0},
            {"outcome": "collision", "collision_kind": "struck", "spl": 0.0},
            {"outcome": "collision", "collision_kind": "struck", "spl": 0.0},
            {"outcome": "success", "collision_kind": None, "spl": 0.8}]
    summary = crowd_rows.summarise(rows)
    assert summary["collision_rate"] == 0.75 and summary["success_rate"] == 0.25
    assert summary["at_fault_rate"] == 0.25 and summary["struck_rate"] == 0.5
    assert summary["spl"] == pytest.approx(0.2)


def test_contact_age_tells_a_pedestrian_who_appeared_beside_the_robot(tmp_path):
    from dsmpepc_nlp.core.config import PlannerConfig, RobotState
    from dsmpepc_nlp.core.solver_config import SolverConfig
    from dsmpepc_nlp.sim.simulate import simulate
    from dsmpepc_nlp.sim.types import Agent, FixedGoal, Pedestrian, Scenario

    def run(appear_at):
        # offstage until ``appear_at`` (s), then standing 0.5 m ahead of the robot's path
        ped = Pedestrian(np.array([0.0, appear_at - crowds.JUMP, appear_at, 30.0]),
                         np.array([crowds.OFFSTAGE, crowds.OFFSTAGE, (2.0, 0.0), (2.0, 0.0)]))
        scenario = Scenario("pop", (Agent("r", RobotState(0.0, 0.0, 0.0, 1.0),
                                          FixedGoal((8.0, 0.0))),), pedestrians=(ped,),
                            duration=6.0)
        return simulate(scenario, PlannerConfig(), SolverConfig.sampling(n_samples=64),
                        record_trajectories=False)

    popped = run(1.3)  # appears where the robot, at about 1 m/s, is 0.3 m later
    assert popped.outcomes == ["collision"]
    assert crowd_rows.contact_age(popped) < crowd_rows.APPEARED
    clear = run(0.1)   # there from the start: the robot stops in front of it
    assert clear.outcomes != ["collision"] and np.isnan(crowd_rows.contact_age(clear))
    rows = [{"outcome": "collision", "collision_kind": "at-fault", "contact_age": 0.2},
            {"outcome": "collision", "collision_kind": "at-fault", "contact_age": 3.0},
            {"outcome": "success", "collision_kind": None, "contact_age": None}]
    summary = crowd_rows.summarise(rows)
    assert summary["at_fault_rate"] == pytest.approx(2 / 3)
    assert summary["at_fault_appeared_rate"] == pytest.approx(1 / 3)


def test_set_robot_fields_reach_the_robot_that_drives(tmp_path):
    """``--set robot.v_limit`` reaches the replay's robot body, which the simulator puts in
    place of the configuration's robot; ``--v-limit`` stays the default it changes."""
    write_recording(tmp_path / "data" / "toy" / "test" / "toy.txt")
    settings = crowds.CrowdSettings(data=str(tmp_path / "data"), scene="toy", v_limit=0.8,
                                    overrides=(("robot.omega_limit", 1.0),))
    scenario, _ = crowds.episode_scenario(settings, 0, 0)
    assert scenario.agents[0].robot.omega_limit == 1.0
    assert scenario.agents[0].robot.v_limit == 0.8
    slower = crowds.CrowdSettings(data=str(tmp_path / "data"), scene="toy",
                                  overrides=(("robot.v_limit", 0.5),))
    assert crowds.episode_scenario(slower, 0, 0)[0].agents[0].robot.v_limit == 0.5
