"""People who stand, drawn into the map the plan sees (``PredictionConfig.standing_map``,
docs/method.md section 3.1).

Progress is measured along the navigation function, and without a map that is the straight
line to the goal. A person standing on that line, or two standing with a gap narrower than the
robot between them, leave the straight line the best the robot can do: every step toward the
gap is progress, the stall ladder multiplies its weight, and the robot creeps at a gap it
cannot pass until the deadlock rule ends the run (CrowdNav's people standing at their goals,
ETH/UCY's groups). A robot's own sensors would see them as its costmap sees a wall: a lidar
marks whatever stands still. With the option on, :class:`StandingPeople` keeps how long each
person has stood (matched across plans as :mod:`.tracking` matches them) and draws everyone who
has stood for ``standing_map`` seconds into a grid about the robot; the plan sees that grid as
its map, so the navigation function routes round them and closes the gaps the robot cannot
pass. They stay dynamic obstacles too. Worlds that have a map, and worlds with nobody standing
long enough, pass unchanged.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.config import PlannerConfig
from ..core.grid import OccupancyGrid
from ..core.world import World

RESOLUTION = 0.1
"""Cell side of the drawn grid, m: a person's 0.3 m radius is three cells."""

MARGIN = 2.0
"""Free margin of the drawn grid round the robot and the part of the way to the goal it draws,
m (the navigation function's own margin round a map)."""

SNAP = 1.0
"""The grid's corners are whole multiples of this, m, so it stays the same grid, and its
navigation function is reused, while the robot moves within it and nobody new stands."""


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


class StandingPeople:
    """Keeps last plan's people and how long each has stood; :meth:`update` returns the world
    to plan in.

    Parameters
    ----------
    config : PlannerConfig
        ``prediction`` (``standing_map``, the ``standing`` speed, the matching ``gate``),
        ``horizon.dt`` (a plan's period, as the stall monitor counts it), the robot's radius
        and the horizon's reach.
    """

    def __init__(self, config: PlannerConfig):
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Forget last plan's people and the last drawn world (a new episode); the drawn
        world keeps its grid's navigation functions for the next plan that draws the same."""
        self.last = None
        self.drawn = None

    def update(self, world: World, position, goal) -> World:
        """``world`` with a grid of the people who have stood ``standing_map`` seconds, for a
        robot at ``position`` (2,) going to ``goal`` (2,); ``world`` itself when the option
        is off, the world has a map, or nobody is drawn."""
        prediction = self.config.prediction
        if prediction.standing_map <= 0.0 or world.grid is not None:
            return world
        people = [world.obstacles[i] for i in pedestrian_indices(world)]
        stood = self._stood(people)
        hold = prediction.standing_map - 1e-9
        still = [p for p, t in zip(people, stood) if t >= hold]
        occupied, origin = self._draw(still, np.asarray(position, float),
                                      np.asarray(goal, float))
        last = self.drawn
        if occupied is None:
            self.drawn = None
            return world
        if last is not None and np.array_equal(last.grid.origin, origin) \
                and np.array_equal(last.grid.occupied, occupied):
            return last.with_obstacles(world.obstacles)
        self.drawn = World(OccupancyGrid.derived(occupied, RESOLUTION, origin), world.obstacles)
        return self.drawn

    def _stood(self, people) -> np.ndarray:
        """Seconds each person has stood (slower than ``standing``) up to this plan, counted in
        plans of ``horizon.dt``; 0 for one walking now. Remembered for the next plan."""
        prediction, period = self.config.prediction, self.config.horizon.dt
        if not people:
            self.last = None
            return np.zeros(0)
        position = np.array([p.centers[0] for p in people])
        speed = np.array([math.hypot(*p.velocity) for p in people])
        slow = speed < prediction.standing
        stood = np.where(slow, period, 0.0)
        if self.last is not None:
            match, near = matched(position, self.last[0], prediction.gate)
            stood = np.where(slow & near, self.last[1][match] + period, stood)
        self.last = (position, stood)
        return stood

    def _draw(self, still, position, goal) -> tuple:
        """The occupancy ``(ny, nx)`` and origin of the grid of ``still`` people, or
        ``(None, None)`` when none is drawn. The grid holds the robot and the goal, or the
        point of the way to it at the horizon's reach, with :data:`MARGIN` round them. A person
        whose disc, grown by the robot's radius, covers the goal or the robot is left out: the
        goal is theirs to leave (docking's business), and a robot already beside them must not
        stand inside its own map's wall."""
        if not still:
            return None, None
        robot_radius = self.config.robot.bounding_radius
        ahead = goal - position
        far = float(np.hypot(*ahead))
        reach = self.config.reach + MARGIN
        end = goal if far <= reach else position + ahead * (reach / far)
        low = np.floor((np.minimum(position, end) - MARGIN) / SNAP) * SNAP
        high = np.ceil((np.maximum(position, end) + MARGIN) / SNAP) * SNAP
        shape = np.round((high - low) / RESOLUTION).astype(int)
        xs = low[0] + (np.arange(shape[0]) + 0.5) * RESOLUTION
        ys = low[1] + (np.arange(shape[1]) + 0.5) * RESOLUTION
        occupied = np.zeros((shape[1], shape[0]), bool)
        for person in still:
            centre, radius = person.centers[0], float(person.radii[0])
            clear = radius + robot_radius
            if np.hypot(*(centre - goal)) < clear or np.hypot(*(centre - position)) < clear:
                continue
            # Only the cells round them: a disc spans a few cells of a grid of thousands.
            i0, i1 = _cells(centre[0] - radius, centre[0] + radius, low[0], shape[0])
            j0, j1 = _cells(centre[1] - radius, centre[1] + radius, low[1], shape[1])
            occupied[j0:j1, i0:i1] |= np.hypot(xs[None, i0:i1] - centre[0],
                                               ys[j0:j1, None] - centre[1]) <= radius
        if not occupied.any():
            return None, None
        return occupied, low


def _cells(lo: float, hi: float, origin: float, n: int) -> tuple:
    """The cells ``[first, last)`` of an axis of ``n`` cells from ``origin`` whose centres
    may lie in ``[lo, hi]`` (one cell of slack each side), clipped to the grid."""
    first = int(math.floor((lo - origin) / RESOLUTION)) - 1
    last = int(math.ceil((hi - origin) / RESOLUTION)) + 1
    return max(first, 0), min(max(last, 0), n)
