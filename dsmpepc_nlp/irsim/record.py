"""One IR-SIM episode's log and its metrics, with the keys of the product's
:func:`~dsmpepc_nlp.sim.metrics.robot_metrics` (NaN or None where a key does not apply).

Every IR-SIM step is logged: the robot's state and the gap from its footprint to the moving
objects (IR-SIM's truth). Clearance to the map is measured on the exactly rasterised static map
(:func:`~.inputs.oracle_grid`) whatever the robot sensed. Smoothness is taken at the planning
period, as in the product's simulator. The collision kind follows the product's rule
(``at-fault`` when the robot's velocity over its last step had a component above
``AT_FAULT_SPEED`` toward what it touched), the touched parts from IR-SIM's own collision list.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.geometry import footprint_points
from ..core.world import World
from ..sim.metrics import AT_FAULT_SPEED, DISCOMFORT_GAP
from .shapes import moving_obstacle

FALLBACK_STATUSES = ("sampling-fallback", "stopped")
"""Plan statuses counted as fallbacks (as :func:`~dsmpepc_nlp.sim.metrics.robot_metrics`)."""


def truth_circles(adapter) -> tuple:
    """Centres (M, 2), radii (M,), a pedestrian flag (M,) and IR-SIM's own world velocity
    (M, 2) of every moving object's circles now (the truth; the adapter's velocity measurement
    is left alone)."""
    centres, radii, walker, velocities = [], [], [], []
    for obj in adapter.moving_objects():
        body = moving_obstacle(obj, np.zeros(2))
        centres.append(body.centers)
        radii.append(body.radii)
        walker.append(np.full(len(body.radii), body.kind == "pedestrian"))
        velocity = np.asarray(obj.velocity_xy, dtype=float).reshape(-1)[:2]
        velocities.append(np.tile(velocity, (len(body.radii), 1)))
    if not centres:
        return np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=bool), np.zeros((0, 2))
    return (np.concatenate(centres), np.concatenate(radii), np.concatenate(walker),
            np.concatenate(velocities))


class EpisodeLog:
    """The log of one episode: states every IR-SIM step, plan times and statuses per plan."""

    def __init__(self, adapter, steps_per_plan: int):
        self.adapter, self.steps_per_plan = adapter, int(steps_per_plan)
        self.footprint = np.asarray(adapter.robot_config.footprint, dtype=float)
        self.times, self.states, self.gaps, self.walker_gaps = [], [], [], []
        self.plan_times, self.statuses, self.plan_steps, self.cuts = [], [], [], []
        self.circles, self.circle_velocities, self.circle_radii = [], [], np.zeros(0)
        self.outcome, self.outcome_time, self.collided = None, math.nan, []
        self.record()

    def record(self) -> None:
        """Log the state now and its gaps to the moving objects."""
        state = self.adapter.state()
        pose = np.array([state.x, state.y, state.phi])
        self.times.append(float(self.adapter.env.time))
        self.states.append([state.x, state.y, state.phi, state.v, state.omega])
        centres, radii, walker, velocities = truth_circles(self.adapter)
        self.circles.append(centres)
        self.circle_velocities.append(velocities)
        self.circle_radii = radii
        points = footprint_points(pose, self.footprint[:, :2])            # (C, 2)
        if radii.size:
            d = np.linalg.norm(points[:, None, :] - centres[None], axis=-1)
            gap = d - self.footprint[:, 2:3] - radii[None]
            self.gaps.append(float(gap.min()))
            self.walker_gaps.append(float(gap[:, walker].min()) if walker.any() else math.inf)
        else:
            self.gaps.append(math.inf)
            self.walker_gaps.append(math.inf)

    def planned(self, plan) -> None:
        """Log one plan's wall time, status and whether its time budget ran out (``Plan.cut``
        not empty); made at the last logged step."""
        self.plan_steps.append(len(self.times) - 1)
        self.plan_times.append(float(plan.wall_time))
        self.statuses.append(str(plan.status))
        self.cuts.append(bool(getattr(plan, "cut", ())))

    def finish(self, outcome: str, t: float) -> None:
        """Set the outcome (success, collision, timeout) and the time it was decided."""
        self.outcome, self.outcome_time = outcome, float(t)
        if outcome == "collision":
            self.collided = [obj.name for obj in getattr(self.adapter.robot, "collision_obj", [])]

    # -- metrics -----------------------------------------------------------------------------

    def array(self) -> np.ndarray:
        """The logged states (T, 5): x, y, phi, v, omega."""
        return np.asarray(self.states, dtype=float)

    def approach_speed(self) -> float:
        """m/s toward the touched objects over the last step; NaN without a collision."""
        states = self.array()
        robot = self.adapter.robot
        touched = getattr(robot, "collision_obj", [])
        if self.outcome != "collision" or len(states) < 2 or not touched:
            return math.nan
        velocity = (states[-1, :2] - states[-2, :2]) / max(self.adapter.step_time, 1e-12)
        best = -math.inf
        for obj in touched:
            contact = robot.geometry.intersection(obj.geometry)
            if contact.is_empty:
                continue
            direction = np.asarray(contact.centroid.coords[0]) - states[-1, :2]
            norm = float(np.hypot(*direction))
            if norm > 1e-12:
                best = max(best, float(velocity @ direction) / norm)
        return best if math.isfinite(best) else math.nan

    def shortest_path(self, start, goal) -> float:
        """The navigation function's value at the start on the oracle map, m; NaN on failure."""
        try:
            world = World(self.adapter.static_grid)
            inflation = float(np.max(self.footprint[:, 2]))
            value = float(world.navigation(goal, inflation).value(start))
        except (ValueError, ArithmeticError):
            return math.nan
        return value if math.isfinite(value) else math.nan

    def metrics(self, goal) -> dict:
        """The robot's metrics (see the module docstring)."""
        states = self.array()
        path = float(np.sum(np.linalg.norm(np.diff(states[:, :2], axis=0), axis=-1)))
        points = footprint_points(states[:, :3], self.footprint[:, :2])          # (T, C, 2)
        grid = self.adapter.static_grid
        static = World(grid).static_distance(points) - self.footprint[:, 2] \
            if grid.occupied.any() else np.array(math.inf)     # no map: inf, as the product's
        periodic = states[::self.steps_per_plan]
        dt = self.steps_per_plan * self.adapter.step_time
        alpha = np.abs(np.diff(periodic[:, 4])) / dt
        jerk = np.abs(np.diff(periodic[:, 3], n=2)) / dt**2
        times = np.asarray(self.plan_times)
        stats = ((float(np.median(times)), float(np.percentile(times, 95)),
                  float(np.percentile(times, 99)), float(np.max(times)))
                 if times.size else (math.nan,) * 4)
        success = self.outcome == "success"
        shortest = self.shortest_path(states[0, :2], goal)
        speed = self.approach_speed()
        kind = None if math.isnan(speed) else ("at-fault" if speed > AT_FAULT_SPEED else "struck")
        return {
            "robot": self.adapter.robot.name, "outcome": self.outcome,
            "outcome_time": self.outcome_time, "collision_kind": kind,
            "contact_approach_speed": speed,
            "spl": (shortest / max(path, shortest, 1e-12) if success else 0.0)
            if math.isfinite(shortest) else math.nan,
            "shortest_path_length": shortest,
            "time_to_goal": self.outcome_time if success else math.nan,
            "path_length": path, "min_static_clearance": float(np.min(static)),
            "min_dynamic_clearance": float(np.min(self.gaps)),
            "discomfort": float(np.mean(np.asarray(self.walker_gaps) < DISCOMFORT_GAP)),
            "mean_angular_acceleration": float(np.mean(alpha)) if alpha.size else 0.0,
            "mean_linear_jerk": float(np.mean(jerk)) if jerk.size else 0.0,
            "following_distance": math.nan,
            "plan_time_median": stats[0], "plan_time_p95": stats[1],
            "plan_time_p99": stats[2], "plan_time_max": stats[3],
            "plans_out_of_time": float(sum(self.cuts)),
            "cycles": len(self.plan_times), "nlp_plans": self.statuses.count("nlp"),
            "fallback_plans": sum(self.statuses.count(s) for s in FALLBACK_STATUSES),
            "collided_with": list(self.collided),
        }

    def save(self, path) -> str:
        """The log as ``.npz`` (times, states, plan_times, statuses); returns the path."""
        np.savez_compressed(path, times=np.asarray(self.times), states=self.array(),
                            plan_times=np.asarray(self.plan_times),
                            statuses=np.asarray(self.statuses, dtype=str))
        return str(path)
