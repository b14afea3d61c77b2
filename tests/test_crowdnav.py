"""CrowdNav protocol: the scenes' geometry, the ORCA humans, the two settings, the command."""

import dataclasses
import json
import math

import numpy as np
import pytest

from dsmpepc_nlp import cli
from dsmpepc_nlp.bench import crowdnav as cn
from dsmpepc_nlp.core.config import RobotState

pytest.importorskip("pyrvo")  # the humans are ORCA agents


def spacing_ok(points, radius=0.3, extra=cn.DISCOMFORT_DIST):
    d = np.linalg.norm(points[:, None] - points[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    return np.all(d >= 2 * radius + extra - 1e-12)


@pytest.mark.parametrize("seed", range(20))
def test_circle_crossing_geometry(seed):
    starts, goals = cn.circle_crossing(np.random.default_rng(seed))
    assert starts.shape == goals.shape == (5, 2)
    assert np.allclose(goals, -starts)  # the antipode of the perturbed start
    # on the 4 m circle up to the perturbation, uniform in [-v_pref / 2, v_pref / 2] per axis
    r = np.linalg.norm(starts, axis=1)
    assert np.all(np.abs(r - cn.CIRCLE_RADIUS) <= math.sqrt(2) * 0.5 + 1e-12)
    assert spacing_ok(np.concatenate([starts, goals]))  # starts vs starts and goals
    robot = np.array([cn.ROBOT_START, cn.ROBOT_GOAL])
    gaps = np.linalg.norm(starts[:, None] - robot[None], axis=-1)
    assert np.all(gaps >= 0.3 + 0.3 + cn.DISCOMFORT_DIST)


@pytest.mark.parametrize("seed", range(20))
def test_square_crossing_geometry(seed):
    starts, goals = cn.square_crossing(np.random.default_rng(seed))
    half = cn.SQUARE_WIDTH / 2
    assert np.all(np.abs(starts) <= half) and np.all(np.abs(goals) <= half)
    assert np.all(np.sign(starts[:, 0]) == -np.sign(goals[:, 0]))  # crossing to the other side
    assert spacing_ok(starts) and spacing_ok(goals)
    assert np.all(np.linalg.norm(starts - cn.ROBOT_START, axis=1) >= 0.8)
    assert np.all(np.linalg.norm(goals - cn.ROBOT_GOAL, axis=1) >= 0.8)


def crowdnav_circle_case(case, n=5, robot=((0.0, -4.0), (0.0, 4.0))):
    """CrowdNav's test case ``case`` written out as its ``generate_circle_crossing_human``
    draws it: the global legacy generator seeded 1000 + case, angle then x and y noise, each
    start redrawn while within 0.8 m of the robot's or a placed human's start or goal."""
    np.random.seed(1000 + case)
    placed, starts = [robot], []
    for _ in range(n):
        while True:
            angle = np.random.random() * np.pi * 2
            px = 4 * np.cos(angle) + (np.random.random() - 0.5)
            py = 4 * np.sin(angle) + (np.random.random() - 0.5)
            if all(np.hypot(px - s[0], py - s[1]) >= 0.8 and np.hypot(px - g[0], py - g[1]) >= 0.8
                   for s, g in placed):
                break
        placed.append(((px, py), (-px, -py)))
        starts.append((px, py))
    return np.array(starts)


@pytest.mark.parametrize("case", [0, 1, 17, 499])
def test_episodes_are_crowdnavs_test_cases(case):
    starts, goals = cn.circle_crossing(cn.case_rng(0, case))
    assert np.array_equal(starts, crowdnav_circle_case(case))
    assert np.array_equal(goals, -starts)


def test_no_deadlock_rule_a_stalled_robot_times_out():
    # a robot too slow to make 0.1 m of progress in 10 s: the loop's rule calls it a deadlock
    # at 10 s; the CrowdNav protocol (no deadlock rule) lets it run to the end: a timeout
    from dsmpepc_nlp.core.config import PlannerConfig, RobotConfig
    from dsmpepc_nlp.core.solver_config import SolverConfig
    from dsmpepc_nlp.sim.outcomes import OutcomeConfig
    from dsmpepc_nlp.sim.simulate import simulate
    from dsmpepc_nlp.sim.types import Agent, FixedGoal, Scenario
    scenario = Scenario("slow", (Agent("r", RobotState(0.0, 0.0, 0.0), FixedGoal((5.0, 0.0)),
                                       robot=RobotConfig(v_limit=0.005)),), duration=11.0)
    solver = SolverConfig.sampling(n_samples=16)
    stalled = simulate(scenario, PlannerConfig(), solver, record_trajectories=False)
    assert stalled.outcomes == ["deadlock"]
    on = simulate(scenario, PlannerConfig(), solver, record_trajectories=False,
                  outcomes=OutcomeConfig(deadlock=False))
    assert on.outcomes == ["timeout"] and on.outcome_times[0] == pytest.approx(11.0)


def test_a_contact_within_a_step_ends_the_episode_as_a_collision():
    settings = cn.CrowdNavSettings(n_samples=16, duration=6.0)
    log, _ = cn.simulate_episode(settings, "ds-mpepc", 0, 0, record_trajectories=False)
    assert cn.with_swept_contact(log) is log or log.outcomes == ["collision"]
    # a human put across the robot's path between two states: a collision at that state
    k = 4
    t = log.times
    ped = log.ped_positions.copy()
    robot = log.states[0, :, :2]
    ped[:, 0] = robot[k] + (robot[k + 1] - robot[k]) / 2 + np.outer(t - t[k] - 0.125,
                                                                    [40.0, 0.0])
    hit = cn.with_swept_contact(dataclasses.replace(log, ped_positions=ped))
    assert hit.outcomes == ["collision"] and hit.outcome_times[0] == pytest.approx(t[k + 1])


def test_draws_are_seeded_and_differ_between_seeds():
    a = cn.circle_crossing(np.random.default_rng([0, 3]))
    b = cn.circle_crossing(np.random.default_rng([0, 3]))
    c = cn.circle_crossing(np.random.default_rng([0, 4]))
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not np.array_equal(a[0], c[0])
    settings = cn.CrowdNavSettings(scene="square")
    s1 = cn.episode_scenario(settings, 7, 1)
    s2 = cn.episode_scenario(settings, 7, 1)
    assert np.array_equal(s1[2], s2[2]) and np.array_equal(s1[3], s2[3])


def test_humans_walk_to_their_goals_at_the_preferred_speed():
    starts, goals = cn.circle_crossing(np.random.default_rng(0))
    crowd = cn.OrcaCrowd(starts, goals)
    humans = crowd.members()
    assert all(h.radius == cn.HUMAN_RADIUS for h in humans)
    speeds = [np.linalg.norm(crowd.at(k * cn.TIME_STEP)[1], axis=1) for k in range(120)]
    assert np.max(speeds) <= cn.HUMAN_SPEED + 1e-6
    alone = cn.OrcaCrowd([[-3.0, 0.0]], [[3.0, 0.0]])  # nobody to avoid: v_pref to the goal
    assert np.allclose(alone.at(1.0)[1], [[cn.HUMAN_SPEED, 0.0]])
    assert np.allclose(alone.at(1.0)[0], [[-2.0, 0.0]])
    final = crowd.at(119 * cn.TIME_STEP)[0]
    assert np.all(np.linalg.norm(final - goals, axis=1) < 0.3)  # everyone arrived
    # positions follow the velocities (holonomic steps of 0.25 s); the past is kept
    p1, v1 = crowd.at(cn.TIME_STEP)
    assert np.allclose(p1, starts + v1 * cn.TIME_STEP)
    assert np.allclose(humans[2].position(0.0), starts[2])
    with pytest.raises(ValueError, match="multiple of dt"):
        crowd.at(0.1)


def head_on(visible):
    """One human walking from (0.1, 3) to (0.1, -3) through a robot standing at the origin
    (0.1 m off centre: exactly head-on, ORCA's symmetric answer is to stop in front)."""
    crowd = cn.OrcaCrowd([[0.1, 3.0]], [[0.1, -3.0]], visible=visible)
    robot = RobotState(0.0, 0.0, 0.0)
    gaps = []
    for k in range(40):
        crowd.observe_robot(robot)
        gaps.append(float(np.linalg.norm(crowd.at(k * cn.TIME_STEP)[0][0])) - 0.6)
    return np.array(gaps), crowd.at(39 * cn.TIME_STEP)[0][0]


def test_invisible_robot_is_walked_through_and_visible_robot_is_avoided():
    gaps, end = head_on(visible=False)
    assert gaps.min() < -0.45  # straight through the robot's body
    assert np.linalg.norm(end - (0.1, -3.0)) < 0.1
    gaps, end = head_on(visible=True)
    assert gaps.min() > -0.05  # around it (ORCA's 0.01 m pads, discrete steps)
    assert np.linalg.norm(end - (0.1, -3.0)) < 0.1


def test_settings_are_checked():
    with pytest.raises(ValueError, match="--scene 'oval'"):
        cn.CrowdNavSettings(scene="oval")
    with pytest.raises(ValueError, match="--robot 'hidden'"):
        cn.CrowdNavSettings(setting="hidden")


@pytest.mark.parametrize("setting", cn.SETTINGS)
def test_episode_row_has_the_fields_metrics(setting):
    settings = cn.CrowdNavSettings(setting=setting, solver="sampling", n_samples=16,
                                   duration=3.0)
    row = cn.run_episode(settings, "ds-mpepc", 0, 0)
    assert row["outcome"] in ("success", "collision", "timeout", "deadlock"), row
    assert row["time"] <= 3.0 and row["time"] / cn.TIME_STEP == pytest.approx(
        round(row["time"] / cn.TIME_STEP))  # the loop runs at the 0.25 s control period
    for key in ("collision_kind", "spl", "min_distance", "discomfort", "jerk",
                "plan_time_median"):
        assert key in row


def test_command_runs_resumes_and_reports_the_split(tmp_path, capsys):
    assert cn.CrowdNavSettings().solver == "nlp"      # the engine by default, as elsewhere
    assert cli.build_parser().parse_args(["benchmark", "crowdnav"]).solver == "nlp"
    argv = ["benchmark", "crowdnav", "--episodes", "2", "--variants", "ds-mpepc", "orca",
            "--solver", "sampling", "--samples", "16", "--duration", "2", "--workers", "1",
            "--robot", "visible", "--out", str(tmp_path / "out"), "--json"]
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["solver"] == "sampling" and summary["setting"] == "visible"
    assert set(summary["variants"]) == {"ds-mpepc", "orca"}
    for figures in summary["variants"].values():
        assert figures["episodes"] == 2 and "at_fault_rate" in figures
        assert figures["error_rate"] == 0
    assert cli.main(argv + ["--resume", "--episodes", "3"]) == 0
    captured = capsys.readouterr()
    assert "6 runs, 4 already done, 2 to run" in captured.err
    assert cli.main(argv[:-1] + ["--episodes", "0"]) == 2
    assert "--episodes" in capsys.readouterr().err


def test_visible_humans_react_to_the_robot_in_the_loop():
    runs = {}
    for setting in cn.SETTINGS:
        settings = cn.CrowdNavSettings(setting=setting, n_samples=16, duration=6.0)
        runs[setting] = cn.simulate_episode(settings, "orca", 0, 0, record_trajectories=False)
    (invisible, crowd_i), (visible, crowd_v) = runs["invisible"], runs["visible"]
    assert crowd_i.robot is not None  # the state is reported either way, used only if visible
    k = visible.n_cycles - 1  # the state the robot planned from last is what the crowd saw
    assert np.allclose(crowd_v.robot[0], visible.states[0, k, :2])
    n = min(invisible.times.size, visible.times.size)
    assert np.allclose(invisible.ped_positions[0], visible.ped_positions[0])  # same draw
    assert not np.allclose(invisible.ped_positions[:n], visible.ped_positions[:n])
    # the humans logged in the episode are the crowd's
    assert np.allclose(visible.ped_positions[-1], crowd_v.at(visible.times[-1])[0])


def test_set_robot_fields_reach_the_robot_that_drives():
    """The simulator puts each agent's body in place of the configuration's robot, so a
    ``--set robot.*`` pair must reach the scenario's body (it was silently dropped)."""
    slow = cn.CrowdNavSettings(overrides=(("robot.v_limit", 0.5),))
    scenario, *_ = cn.episode_scenario(slow, 0, 0)
    assert scenario.agents[0].robot.v_limit == 0.5
    default, *_ = cn.episode_scenario(cn.CrowdNavSettings(), 0, 0)
    assert default.agents[0].robot.v_limit == 1.0


def test_the_episode_keeps_the_planners_configuration_and_the_loops_step():
    """The loop steps 0.25 s, the planner plans in 0.2 s steps: the episode's ``dt`` is the
    loop's and its configuration the planner's, so a speed change per step within
    ``accel_limit * config.horizon.dt`` (what the escape search allows) is what the robot did:
    from standing, its first step is at that limit (the robot's own, here set lower)."""
    settings = cn.CrowdNavSettings(n_samples=64, duration=1.0, solver="sampling",
                                   overrides=(("robot.accel_limit", 1.0),))
    log, _ = cn.simulate_episode(settings, "ds-mpepc", 0, 0, record_trajectories=False)
    config = log.config()
    assert log.dt == cn.TIME_STEP and config.horizon.dt == 0.2
    assert config.robot.accel_limit == 1.0
    step = config.robot.accel_limit * config.horizon.dt
    change = np.abs(np.diff(log.states[0, :-1, 3]))       # the last state is the outcome's stop
    assert change[0] == pytest.approx(step) and np.all(change <= step + 1e-12)
