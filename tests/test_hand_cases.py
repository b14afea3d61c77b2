"""Hand-worked cases for what the mutation check (tools/dev/mutation_check.py) found untested:
the law's curvature off the axes, arcs, several-circle obstacles, time to collision against
moving obstacles along a trajectory and at the horizon's end. Each expected value is computed
here from docs/method.md's formulas, not from the package's helpers."""

import math

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.control_law import arc_step, law_command, rollout
from dsmpepc_nlp.core.exact_cost import evaluate, exact_geometry
from dsmpepc_nlp.core.world import DynamicObstacle, World

DS = PlannerConfig.ds_mpepc()


def _first_root_inverse(p, w, radius):
    """1/t for the smallest t >= 0 with |p + w t| = radius (0 for none), by the quadratic."""
    a, b, c = w @ w, 2 * p @ w, p @ p - radius**2
    if c <= 0:
        return math.inf
    disc = b * b - 4 * a * c
    if a == 0 or disc < 0:
        return 0.0
    t = (-b - math.sqrt(disc)) / (2 * a)
    return 1.0 / t if t > 0 else 0.0


def test_curvature_of_the_law_off_the_line_of_sight():
    # Park and Kuipers (2011):
    # kappa = -(1/r)[k2 (de - atan(-k1 th)) + (1 + k1/(1 + (k1 th)^2)) sin de]
    law = DS.control_law
    pose, target = (0.0, 0.0, 0.4), (2.0, 1.0, -0.3)
    los = math.atan2(1.0, 2.0)
    rho = math.hypot(2.0, 1.0)
    th, de = target[2] - los, pose[2] - los
    kappa = -(law.k2 * (de - math.atan(-law.k1 * th))
              + (1 + law.k1 / (1 + (law.k1 * th) ** 2)) * math.sin(de)) / rho
    v, omega = law_command(pose, target, 0.8, DS)
    assert omega / v == pytest.approx(kappa, rel=1e-12)
    slowed = 0.8 / (1 + law.beta * abs(kappa) ** law.lam)
    expected_v = min(slowed, 0.8 * rho / law.r_thresh, DS.robot.omega_limit / abs(kappa))
    assert v == pytest.approx(expected_v, rel=1e-12)


def test_arc_step_follows_the_circle():
    # Holding v = 1 m/s, omega = 1 rad/s for pi/2 s from the origin: a quarter of the unit
    # circle centred at (0, 1), ending at (1, 1) facing +y.
    x, y, phi = arc_step((0.0, 0.0, 0.0), 1.0, 1.0, math.pi / 2)
    assert (x, y, phi) == pytest.approx((1.0, 1.0, math.pi / 2), abs=1e-12)
    x, y, phi = arc_step((0.0, 0.0, 0.0), 1.0, -1.0, math.pi / 2)
    assert (x, y, phi) == pytest.approx((1.0, -1.0, -math.pi / 2), abs=1e-12)


def test_a_batch_knows_its_length():
    z = np.array([[2.0, 0.0, 0.0, 0.5]] * 3)
    assert len(rollout(z, RobotState(0, 0, 0), DS)) == 3
    assert len(rollout(z[0], RobotState(0, 0, 0), DS)) == 1


def test_a_robot_of_two_circles_is_one_object():
    # Another robot's footprint of two circles counts once: its distance is the nearer circle's.
    other = DynamicObstacle.robot((3.0, 0.4, math.pi / 2), (0.0, 0.0),
                                  ((0.2, 0.0, 0.25), (-0.2, 0.0, 0.25)))
    walker = DynamicObstacle.pedestrian((0.0, 3.0), (0.0, 0.0))
    world = World(obstacles=[other, walker])
    stop = rollout(np.array([2.0, 0.0, 0.0, 0.0]), RobotState(0.0, 0.0, 0.0), DS)
    geometry = exact_geometry(stop[None], world, (5.0, 0.0), DS)
    assert geometry.distance.shape[-1] == 2
    # Circles at (3, 0.6) and (3, 0.2) (the robot faces +y); the nearer is (3, 0.2).
    expected = math.hypot(3.0, 0.2) - 0.3 - 0.25
    assert geometry.distance[0, 0, 0] == pytest.approx(expected, rel=1e-12)
    assert geometry.distance[0, 0, 1] == pytest.approx(3.0 - 0.3 - 0.3, rel=1e-12)


def test_time_to_collision_along_a_trajectory_against_moving_obstacles():
    # Every pose's 1/TTC, worked with the quadratic: robot speed along its heading, each
    # pedestrian at its constant-velocity prediction for that pose's time.
    walkers = [DynamicObstacle.pedestrian((4.0, 0.7), (-0.6, -0.1)),
               DynamicObstacle.pedestrian((1.0, -2.5), (0.1, 0.5))]
    world = World(obstacles=walkers)
    traj = rollout(np.array([4.0, 0.2, -0.1, 0.9]), RobotState(0.0, 0.0, 0.1, 0.3, 0.0), DS)
    geometry = exact_geometry(traj[None], world, (6.0, 0.0), DS)
    dt = DS.horizon.dt
    speeds = np.append(traj.v, traj.v[-1])
    for k, (x, y, phi) in enumerate(traj.poses):
        velocity = speeds[k] * np.array([math.cos(phi), math.sin(phi)])
        for i, walker in enumerate(walkers):
            centre = walker.centers[0] + walker.velocity * k * dt
            expected = _first_root_inverse(np.array([x, y]) - centre,
                                           velocity - walker.velocity, 0.3 + 0.3)
            assert geometry.inv_ttc[0, k, i] == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_terminal_time_to_collision_sees_where_the_obstacle_will_be():
    # A stop trajectory ends where it starts; the terminal TTC moves it at v_limit along its
    # heading and the pedestrian from its position at the horizon's end, t = N dt.
    walker = DynamicObstacle.pedestrian((3.0, 0.4), (-0.1, 0.02))
    stop = rollout(np.array([2.0, 0.0, 0.0, 0.0]), RobotState(0.0, 0.0, 0.0), DS)
    costs = evaluate(stop, World(obstacles=[walker]), (8.0, 0.0), DS)
    t_end = DS.horizon.n_steps * DS.horizon.dt
    centre = np.array([3.0, 0.4]) + np.array([-0.1, 0.02]) * t_end
    expected = _first_root_inverse(-centre, np.array([DS.robot.v_limit + 0.1, -0.02]), 0.6)
    assert expected > 0.0
    assert 1.0 / costs.ttc_terminal == pytest.approx(expected, rel=1e-9)


def test_action_term_is_the_weighted_sum_of_squared_commands():
    # J_action = sum_j (c_v v_j^2 + c_w omega_j^2) dt on a turning trajectory.
    traj = rollout(np.array([3.0, 0.6, 0.9, 0.8]), RobotState(0.0, 0.0, 0.0, 0.2, 0.1), DS)
    assert np.max(np.abs(traj.omega)) > 0.1
    cost = DS.cost
    expected = np.sum(cost.c_v * traj.v**2 + cost.c_w * traj.omega**2) * DS.horizon.dt
    costs = evaluate(traj, World(), (6.0, 2.0), DS)
    assert costs.terms["action"] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("heading", [0.0, 0.3, 2.5])
def test_on_the_goal_the_heading_error_is_zero_whatever_the_heading(heading):
    # The descent direction is undefined on the goal (the paper gives only the limits;
    # docs/method.md section 4.1); the package defines the heading error as 0 there, on a map
    # too, where the grid's central differences around the goal need not vanish.
    from dsmpepc_nlp.core.world import OccupancyGrid

    occupied = np.zeros((60, 60), bool)
    occupied[:, 45:] = True
    world = World(OccupancyGrid.from_array(occupied, 0.1, (-3.0, -3.0)))
    goal = (0.513, 0.227)
    stop = rollout(np.array([2.0, 0.0, 0.0, 0.0]), RobotState(*goal, heading), DS)
    geometry = exact_geometry(stop[None], world, goal, DS)
    assert geometry.heading_error[0, 0, 0] == 0.0
    assert evaluate(stop, world, goal, DS).terms["heading"] == 0.0


def test_time_to_goal_off_the_axes():
    # TTG = |g - p_N| / (v_N u_N . (g - p_N) / |g - p_N|), with the goal off both axes of the
    # end pose (a goal on an axis hides a sign error in the other coordinate).
    traj = rollout(np.array([3.0, 0.4, -0.5, 0.9]), RobotState(0.2, -0.1, 0.3, 0.5, 0.0), DS)
    goal = np.array([4.0, 2.5])
    x, y, phi = traj.poses[-1]
    d = goal - np.array([x, y])
    along = traj.v[-1] * (math.cos(phi) * d[0] + math.sin(phi) * d[1]) / np.linalg.norm(d)
    assert along > 0.0
    costs = evaluate(traj, World(), goal, DS)
    assert costs.ttg == pytest.approx(np.linalg.norm(d) / along, rel=1e-9)
