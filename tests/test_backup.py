"""The stall ladder's back-up rung (solve/behaviours/backup.py): reverse trajectories within the
robot's limits, costed by the exact cost, taken only over a plan that stands, once stalled (the
ladder's ``back_up_level``) or where the robot expects to be struck (``back_up_threat``), and
only when cheaper; and its forward dodges, over a plan the robot expects to be struck on."""

import dataclasses
import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState, StallConfig
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.exact_cost import evaluate, exact_geometry
from dsmpepc_nlp.core.grid import OccupancyGrid
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import DynamicObstacle, World
from dsmpepc_nlp.solve.behaviours import backup, chain, docking
from dsmpepc_nlp.solve.behaviours import ways as moves
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import Evaluator
from dsmpepc_nlp.solve.planner import Planner

ON = PlannerConfig(stall=StallConfig(back_up=0.3))
GOAL = (5.0, 0.0)


def person_just_ahead(gap=0.05):
    """A standing person ``gap`` m in front of a round robot (r = 0.3) at the origin facing +x,
    between it and the goal."""
    return World(obstacles=[DynamicObstacle.pedestrian((0.6 + gap, 0.0), (0.0, 0.0), 0.3)])


def test_the_back_ups_reverse_within_the_robots_limits_and_then_brake():
    state = RobotState(0.0, 0.0, 0.0, 0.2, 0.5)      # still rolling forward and turning
    config = PlannerConfig(stall=StallConfig(back_up=2.0, back_up_time=1.0))
    t = moves.back_up_trajectories(state, config)
    robot, dt = config.robot, config.horizon.dt
    assert t.poses.shape == (3, config.horizon.n_steps + 1, 3)
    assert np.all(t.poses[:, 0] == [0.0, 0.0, 0.0])
    speed = robot.accel_limit * dt                   # capped: one period brakes it back
    assert np.min(t.v) == pytest.approx(-speed) and np.max(t.v) <= 0.2 + 1e-12
    v = np.concatenate([np.full((3, 1), 0.2), t.v], axis=1)
    omega = np.concatenate([np.full((3, 1), 0.5), t.omega], axis=1)
    assert np.all(np.abs(np.diff(v, axis=1)) <= robot.accel_limit * dt + 1e-12)
    assert np.all(np.abs(np.diff(omega, axis=1)) <= robot.alpha_limit * dt + 1e-12)
    assert np.all(t.v[:, -5:] == 0.0)                # braked and standing at the end
    assert np.all(t.poses[:, -1, 0] < 0.0)           # every one ended behind the start
    assert t.poses[1, -1, 2] > t.poses[0, -1, 2] > t.poses[2, -1, 2]   # left, straight, right


def test_a_measured_state_outside_the_limits_still_gives_commands_inside_them():
    state = RobotState(0.0, 0.0, 0.0, -1.77, -2.5)    # measured: faster back than allowed
    t = moves.back_up_trajectories(state, ON)
    assert np.all(t.v >= -moves.back_up_speed(ON)) and np.all(t.v <= ON.robot.v_limit)
    assert np.all(np.abs(t.omega) <= ON.robot.omega_limit)


def test_backing_toward_a_wall_sees_the_wall_in_its_time_to_collision():
    occupied = np.zeros((40, 40), dtype=bool)
    occupied[:, :7] = True                           # a wall at x < -0.65
    world = World(OccupancyGrid(occupied, 0.05, origin=(-1.0, -1.0)))
    back = moves.back_up_trajectories(RobotState(0.0, 0.0, 0.0), ON)[0:1]
    # the same path driven forward: facing the wall (heading + pi), speed +|v|
    forward = dataclasses.replace(back, poses=back.poses + [0.0, 0.0, np.pi], v=-back.v)
    reversing = exact_geometry(back, world, GOAL, ON)
    driving = exact_geometry(forward, world, GOAL, ON)
    near_and_reversing = (reversing.distance[0, :, 0] < 0.2) & (np.r_[back.v[0], 0.0] < 0)
    assert np.any(near_and_reversing)
    assert np.all(reversing.inv_ttc[0, near_and_reversing, 0] > 0.0)  # the wall behind: seen
    np.testing.assert_allclose(reversing.inv_ttc, driving.inv_ttc, rtol=1e-12, atol=0)
    np.testing.assert_allclose(evaluate(back, world, GOAL, ON).survivability,
                               evaluate(forward, world, GOAL, ON).survivability, rtol=1e-12)


def test_facing_a_person_just_ahead_the_robot_backs_up_from_its_level():
    state = RobotState(0.0, 0.0, 0.0)
    # the default: once the ladder says stalled (the threat gate off here: a person 5 cm
    # ahead already costs a standing robot's survival, see the next test)
    assert ON.stall.back_up_level == 1
    level_only = PlannerConfig(stall=StallConfig(back_up=0.3, back_up_threat=0.0))
    planner = Planner(level_only, SolverConfig.sampling(n_samples=256))
    plans = [planner.plan(state, person_just_ahead(), GOAL) for _ in range(12)]
    assert plans[0].status != "backing-up" and plans[0].stall_level == 0
    backing = [p for p in plans if p.status == "backing-up"]
    assert backing and all(p.stall_level >= 1 for p in backing), [p.message for p in plans]
    plan = backing[0]
    assert plan.control[0] < 0.0 and np.all(np.isfinite(plan.x)) and np.isfinite(plan.fun)
    assert "backing up" in plan.message and plan.trajectory.poses[-1, 0] < 0.0
    # from level 0: any plan that stands, the first one included
    eager = PlannerConfig(stall=StallConfig(back_up=0.3, back_up_level=0))
    first = Planner(eager, SolverConfig.sampling(n_samples=256)).plan(
        state, person_just_ahead(), GOAL)
    assert first.stall_level == 0 and first.status == "backing-up", first.message


def test_a_person_walking_at_a_standing_robot_makes_it_back_up_at_once_with_the_threat_gate():
    """Below the ladder's level, the rung acts only where the robot expects to be struck
    (``back_up_threat``): a person walking at it, not an open floor."""
    state = RobotState(0.0, 0.0, 0.0)
    walking = World(obstacles=[DynamicObstacle.pedestrian((1.8, 0.3), (-1.0, -0.2), 0.3)])
    solver = SolverConfig.sampling(n_samples=256)
    assert PlannerConfig().stall.back_up_threat == 0.5
    gated = PlannerConfig()
    first = Planner(gated, solver).plan(state, walking, GOAL)
    assert first.stall_level == 0 and first.status == "backing-up", first.message
    assert "expects to be struck" in first.message and first.control[0] < 0.0
    ungated = PlannerConfig(stall=dataclasses.replace(gated.stall, back_up_threat=0.0))
    plan = Planner(ungated, solver).plan(state, walking, GOAL)
    assert plan.status != "backing-up" and backup.stands(plan, ungated)
    assert not backup.threatened(plan, ungated) and backup.threatened(plan, gated)
    # an open floor: nothing threatens, the plan drives off
    assert Planner(gated, solver).plan(state, World(), GOAL).status != "backing-up"


def test_the_dodges_turn_hard_then_go_ahead_forward_within_the_limits():
    state = RobotState(0.0, 0.0, 0.0, 0.4, -0.5)
    config = PlannerConfig()
    t = moves.dodge_trajectories(state, config)
    robot, dt = config.robot, config.horizon.dt
    assert t.poses.shape == (96, config.horizon.n_steps + 1, 3)
    assert np.all(t.poses[:, 0] == [0.0, 0.0, 0.0])
    assert np.min(t.v) >= 0.0 and np.max(t.v) <= robot.v_limit + 1e-12     # never reversing
    assert np.max(np.abs(t.omega)) <= robot.omega_limit + 1e-12
    v = np.concatenate([np.full((96, 1), 0.4), t.v], axis=1)
    omega = np.concatenate([np.full((96, 1), -0.5), t.omega], axis=1)
    assert np.max(np.abs(np.diff(v, axis=1))) <= robot.accel_limit * dt + 1e-12
    assert np.max(np.abs(np.diff(omega, axis=1))) <= robot.alpha_limit * dt + 1e-12
    turned = t.poses[:, -1, 2]
    assert turned.max() > 1.5 and turned.min() < -1.5                      # both ways, hard


def test_a_person_overtaking_faster_than_the_robot_makes_it_dodge_off_the_line():
    """From behind at 1.3 m/s the person outruns anything ahead, and the law leaves the line
    only along its slow curve: the dodge turns off at once (``stall.dodge``)."""
    state = RobotState(0.0, 0.0, 0.0, 0.3, 0.0)
    behind = World(obstacles=[DynamicObstacle.pedestrian((-1.2, 0.0), (1.3, 0.0), 0.3)])
    solver = SolverConfig.sampling(n_samples=256)
    on = PlannerConfig()
    off = dataclasses.replace(on, stall=dataclasses.replace(on.stall, dodge=False))
    assert on.stall.dodge and not PlannerConfig.paper().stall.dodge
    kept = Planner(off, solver).plan(state, behind, GOAL)
    assert kept.status == "sampling" and backup.threatened(kept, on)
    assert not backup.stands(kept, on)                      # threatened while moving
    dodged = Planner(on, solver).plan(state, behind, GOAL)
    assert dodged.status == "dodging" and "dodging: turning" in dodged.message
    assert dodged.fun < kept.fun
    assert dodged.cost.survivability[-1] > 2 * kept.cost.survivability[-1]
    assert abs(dodged.control[1]) > abs(kept.control[1])


def test_the_dodges_answer_only_a_blow_expected_within_dodge_within(monkeypatch):
    """Three people abreast walking at the robot from 3.5 m strike the law's plan two to three
    seconds out: the gate sees the threat at the horizon's end, so with ``dodge_within`` at the
    horizon (5 s) the rung builds its dodges, and with 1 s it does not (nothing strikes within
    1 s); the overtaking person of the test above, a blow within the second, is dodged either
    way."""
    state = RobotState(0.0, 0.0, 0.0, 0.3, 0.0)
    head_on = World(obstacles=[DynamicObstacle.pedestrian((3.5, y), (-1.0, 0.0), 0.3)
                               for y in (-0.7, 0.0, 0.7)])
    solver = SolverConfig.sampling(n_samples=256)
    on = PlannerConfig()
    soon = dataclasses.replace(on, stall=dataclasses.replace(on.stall, dodge_within=1.0))
    rung_off = dataclasses.replace(on, stall=dataclasses.replace(on.stall, back_up=0.0))
    kept = Planner(rung_off, solver).plan(state, head_on, GOAL)      # the law's own plan
    assert backup.threatened(kept, on) and not backup.threatened(kept, on, 1.0)
    built = []
    original = moves.dodge_trajectories
    monkeypatch.setattr(moves, "dodge_trajectories",
                        lambda *a: built.append(1) or original(*a))
    for config, expected in ((on, 1), (soon, 0)):
        built.clear()
        chain.recover(kept, state, Evaluator(Cycle.prepare(state, head_on, GOAL, config)),
                        level=0)
        assert len(built) == expected
    behind = World(obstacles=[DynamicObstacle.pedestrian((-1.2, 0.0), (1.3, 0.0), 0.3)])
    assert Planner(soon, solver).plan(state, behind, GOAL).status == "dodging"


def test_a_docked_plan_is_read_for_threat_where_the_task_ends_with_threat_until_arrival():
    """A person crosses the goal 2-3 s out, after the docked way has come within the task's
    0.3 m of it (step 6, 1.2 s): docking passes it (survival 1.00 until arrival), and the gate,
    reading the horizon's end (0.00), replaced it with a dodge. With
    ``stall.threat_until_arrival`` the gate reads where docking read and the robot docks; a
    followed goal (no tolerance: its task does not end on arrival) keeps the horizon's end."""
    state, goal = RobotState(0.0, 0.0, 0.0, 0.5, 0.0), (1.2, 0.0)
    crossing = World(obstacles=[DynamicObstacle.pedestrian((1.2, 3.0), (0.0, -1.0), 0.3)])
    solver = SolverConfig.sampling(n_samples=256)
    until = PlannerConfig()
    at_end = dataclasses.replace(until, stall=dataclasses.replace(until.stall,
                                                              threat_until_arrival=False))
    assert until.stall.threat_until_arrival
    assert not PlannerConfig.paper().stall.threat_until_arrival
    horizon_end = Planner(at_end, solver).plan(state, crossing, goal, goal_tolerance=0.3)
    assert horizon_end.status == "dodging" and "it replaced: docked" in horizon_end.message
    docked = Planner(until, solver).plan(state, crossing, goal, goal_tolerance=0.3)
    assert docked.status == "docked", docked.message
    assert docked.cost.survivability[-1] < 0.5 and backup.threatened(docked, until)
    assert backup.arrival_time(docked, goal, 0.3, until) == pytest.approx(1.2)
    assert not backup.threatened(docked, until, backup.arrival_time(docked, goal, 0.3, until))
    assert backup.arrival_time(docked, goal, 0.3, at_end) == math.inf
    assert backup.arrival_time(docked, goal, 0.0, until) == math.inf
    followed = Planner(until, solver).plan(state, crossing, goal)
    assert followed.status == "dodging", followed.message
    with pytest.raises(InputError, match="threat_until_arrival"):
        StallConfig(threat_until_arrival="yes")


def test_a_robot_standing_at_its_goal_does_not_back_away_by_default():
    """What level 0 did (docs/experiments/2026-11-25-back-up-rung.md) and level 1 does not: the
    stall monitor never counts a robot at its goal as stalled, so the rung leaves it standing
    there."""
    state, goal = RobotState(1.0, 1.0, 0.0), (1.0, 1.0)
    planner = Planner(PlannerConfig(), SolverConfig.sampling(n_samples=64))
    assert all(planner.plan(state, World(), goal).status != "backing-up" for _ in range(15))


def test_switched_off_never_backs_up_and_a_moving_plan_is_kept():
    assert PlannerConfig().stall.back_up == 0.3 and PlannerConfig.paper().stall.back_up == 0.0
    off = PlannerConfig(stall=StallConfig(back_up=0.0))
    planner = Planner(off, SolverConfig.sampling(n_samples=256))
    state = RobotState(0.0, 0.0, 0.0)
    assert all(planner.plan(state, person_just_ahead(), GOAL).status != "backing-up"
               for _ in range(12))
    # a plan that drives off unthreatened is never replaced, whatever the ladder says
    cycle = Cycle.prepare(state, World(), GOAL, ON)
    moving = Planner(ON, SolverConfig.sampling(n_samples=256)).plan(state, World(), GOAL)
    assert not backup.stands(moving, ON)
    assert chain.recover(moving, state, Evaluator(cycle), level=3) is None


def test_a_stalled_robot_facing_away_from_its_goal_turns_in_place_toward_it():
    """Goal behind, nobody about: the law's plan crawls round (it slows with its curvature);
    once stalled, the rung's turn in place toward the goal, then ahead to it, is far cheaper by
    the exact cost (``stall.turn_to_goal``). Not before the ladder's level, not when off."""
    state, goal = RobotState(0.0, 0.0, math.pi, 0.05, 0.0), (3.0, 0.5)
    solver = SolverConfig.sampling(n_samples=256)
    monitor = Planner(PlannerConfig(), solver).stall
    assert PlannerConfig().stall.turn_to_goal == pytest.approx(math.pi / 4)
    assert PlannerConfig.paper().stall.turn_to_goal == 0.0
    for level in (0, 1, 3):
        config = monitor.config_for(level)
        plan = Planner(config, solver).plan(state, World(), goal, dock=False)
        cycle = Cycle.prepare(state, World(), goal, config)
        turned = chain.recover(plan, state, Evaluator(cycle), level)
        if level == 0:
            assert turned is None
            continue
        assert turned.status == "turning" and "turning in place toward the goal" in turned.message
        assert turned.fun < plan.fun - 1.0
        assert turned.control[0] == 0.0 and turned.control[1] < 0.0    # right, the short way
        end = turned.trajectory.poses[-1]
        assert math.hypot(goal[0] - end[0], goal[1] - end[1]) < 1.0     # and on to the goal
        assert path_length(turned.trajectory.poses) > 2 * path_length(plan.trajectory.poses)
        off = dataclasses.replace(config, stall=dataclasses.replace(config.stall,
                                                                    turn_to_goal=0.0))
        kept = chain.recover(plan, state, Evaluator(Cycle.prepare(state, World(), goal, off)),
                               level)
        assert kept is None or kept.status != "turning"


def path_length(poses) -> float:
    return float(np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T)))


def test_the_turns_stay_within_the_limits_and_end_near_the_line_to_their_target():
    state = RobotState(0.0, 0.0, 0.0, 0.3, 0.4)
    config = PlannerConfig()
    plan = Planner(config, SolverConfig.sampling(n_samples=64)).plan(state, World(), (-4.0, 1.0))
    t = moves.turn_trajectories(plan, state, (-4.0, 1.0), config)
    robot, dt = config.robot, config.horizon.dt
    assert t.poses.shape == (2 + 2 * (moves.DODGE_TURN_STEPS - 1), config.horizon.n_steps + 1, 3)
    assert np.min(t.v) >= 0.0 and np.max(t.v) <= robot.v_limit + 1e-12
    assert np.max(np.abs(t.omega)) <= robot.omega_limit + 1e-12
    v = np.concatenate([np.full((len(t.v), 1), 0.3), t.v], axis=1)
    omega = np.concatenate([np.full((len(t.v), 1), 0.4), t.omega], axis=1)
    assert np.max(np.abs(np.diff(v, axis=1))) <= robot.accel_limit * dt + 1e-9
    assert np.max(np.abs(np.diff(omega, axis=1))) <= robot.alpha_limit * dt + 1e-9
    assert np.all(t.v[:2, 3] == 0.0)                        # braked to turn where it stands
    turned = np.argmax(t.v > 0.0, axis=1)                   # where each sets off
    for i, aim in enumerate(((-4.0, 1.0), plan.trajectory.target[:2])):
        x, y, phi = t.poses[i, turned[i]]
        away = abs(math.remainder(math.atan2(aim[1] - y, aim[0] - x) - phi, 2 * math.pi))
        assert away <= config.stall.turn_to_goal + 0.3     # within a step's turn of the limit
    steps = moves.DODGE_TURN_STEPS - 1                      # then 1..7 periods either way
    for first, sign in ((2, 1.0), (2 + steps, -1.0)):
        ends = [t.poses[first + k - 1, k, 2] for k in range(1, steps + 1)]
        assert np.all(sign * np.diff(np.unwrap(ends)) > 0)     # each turns further in place
        assert np.all(t.v[first:first + steps, 0] <= 0.3)       # braking, not driving off


@pytest.mark.parametrize("changes, field", [({"back_up": -0.1}, "back_up"),
                                            ({"back_up_time": 0.0}, "back_up_time"),
                                            ({"back_up_level": -1}, "back_up_level"),
                                            ({"back_up_threat": 1.5}, "back_up_threat"),
                                            ({"dodge": "yes"}, "dodge"),
                                            ({"dodge_within": 0.0}, "dodge_within"),
                                            ({"turn_to_goal": -0.1}, "turn_to_goal"),
                                            ({"turn_to_goal": 4.0}, "turn_to_goal")])
def test_bad_back_up_settings_are_refused_by_name(changes, field):
    with pytest.raises(InputError, match=field):
        StallConfig(**changes)


def test_the_turns_law_rollouts_in_one_batch_are_each_the_law_from_where_its_turn_ends():
    """``docking.turns_then_law`` rolls every cut's law out in one batch of different starts and
    lengths; each row must be the turn up to its cut, then :func:`rollout` from the pose and
    command the turn ends with, as if alone."""
    config = PlannerConfig()
    state, goal = RobotState(0.5, -0.3, 2.4, 0.4, -0.2), (3.0, 1.0)
    left, right = (docking.turn_in_place(state, config, s) for s in (1.0, -1.0))
    target = np.array([1.0, 2.0, 0.5])
    cuts = [(left, 1, None, None), (right, 5, target, 0.7), (left, 23, None, None),
            (right, 40, None, None)]                                 # 40: clipped to n - 1
    batch = docking.turns_then_law(config, cuts, goal)
    n = config.horizon.n_steps
    assert batch.poses.shape == (4, n + 1, 3) and batch.v.shape == (4, n)
    for i, (turning, steps, aim, _) in enumerate(cuts):
        k = min(steps, n - 1)
        pose = turning.poses[k]
        alone = rollout(batch.z[i], RobotState(*pose, turning.v[k - 1], turning.omega[k - 1]),
                        config)
        np.testing.assert_array_equal(batch.poses[i], np.concatenate([turning.poses[:k + 1],
                                                                       alone.poses[1:n - k + 1]]))
        np.testing.assert_array_equal(batch.v[i], np.concatenate([turning.v[:k], alone.v[:n - k]]))
        np.testing.assert_array_equal(batch.omega[i],
                                      np.concatenate([turning.omega[:k], alone.omega[:n - k]]))
        np.testing.assert_array_equal(batch.target[i], alone.target)
        if aim is None:
            np.testing.assert_array_equal(batch.z[i], docking.docking_z(pose, goal, config))


