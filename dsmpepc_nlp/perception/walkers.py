"""People who start to walk: the planner's memory of last plan's people
(``PredictionConfig.speeding_up``, docs/method.md section 3.1).

A world shows each person's position and velocity now, with no name: :class:`SpeedingUp`
matches each pedestrian to last plan's nearest prediction and predicts one who stood then and
walks now as they will walk a few plans later. Robots (several circles), everyone else and
worlds without people pass unchanged; with the option off the world is passed on untouched.
"""

from __future__ import annotations

import numpy as np

from ..core.config import PlannerConfig
from ..core.world import DynamicObstacle, World


def pedestrian_indices(world: World) -> list:
    """Indices of the world's one-circle pedestrians."""
    return [i for i, o in enumerate(world.obstacles)
            if o.kind == "pedestrian" and len(o.centers) == 1]


def matched(position, expected, gate) -> tuple[np.ndarray, np.ndarray]:
    """Each person seen now (``position`` (n, 2)) matched to the nearest of last plan's people
    where they were predicted to be (``expected`` (m, 2), m >= 1): the index of that one and
    whether they are within ``gate`` (m) of it, each (n,)."""
    gap = np.linalg.norm(position[:, None, :] - expected[None, :, :], axis=2)
    match = np.argmin(gap, axis=1)
    return match, gap[np.arange(len(position)), match] <= gate


class SpeedingUp:
    """Keeps last plan's pedestrians; :meth:`update` returns the world to plan in.

    Parameters
    ----------
    config : PlannerConfig
        ``prediction`` (the look-ahead, the walking speed, the gate) and ``horizon.dt`` (the
        plan period last plan's people are predicted over).
    """

    def __init__(self, config: PlannerConfig):
        self.prediction, self.period = config.prediction, config.horizon.dt
        self.last = None

    def reset(self) -> None:
        """Forget last plan's people (a new episode)."""
        self.last = None

    def update(self, world: World) -> World:
        """``world`` with the velocity of each person who set off since last plan raised
        (:meth:`faster`); the people seen now are kept for the next plan."""
        if self.prediction.speeding_up <= 0.0:
            return world
        index = pedestrian_indices(world)
        if not index:
            self.last = None
            return world
        people = [world.obstacles[i] for i in index]
        position = np.array([p.centers[0] for p in people])
        velocity = np.array([p.velocity for p in people])
        last, self.last = self.last, (position, velocity)
        if last is None:
            return world
        faster = self.faster(position, velocity, *last)
        changed = np.flatnonzero(np.any(faster != velocity, axis=1))
        if not len(changed):
            return world
        obstacles = list(world.obstacles)
        for k in changed:
            person = people[k]
            obstacles[index[k]] = DynamicObstacle(person.centers, person.radii, faster[k])
        return world.with_obstacles(obstacles)

    def faster(self, position, velocity, last_position, last_velocity) -> np.ndarray:
        """The velocities to predict (n, 2): each person's own, or for one who stood at last
        plan (their match slower than ``standing``) and walks now, along their heading at
        ``speed + lookahead * rise`` capped at ``walking_speed`` (never below ``speed``)."""
        prediction = self.prediction
        match, near = matched(position, last_position + self.period * last_velocity,
                              prediction.gate)
        speed = np.linalg.norm(velocity, axis=1)
        last_speed = np.linalg.norm(last_velocity[match], axis=1)
        rise = speed - last_speed
        raised = near & (rise > 0.0) & (last_speed < prediction.standing)
        target = np.maximum(speed, np.minimum(speed + prediction.speeding_up * rise,
                                              prediction.walking_speed))
        scale = np.where(raised, target / np.where(speed > 0.0, speed, 1.0), 1.0)
        return velocity * scale[:, None]
