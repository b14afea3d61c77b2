"""The perception layer: what a robot senses, turned into what the planner reads; imports only
:mod:`dsmpepc_nlp.core`.

- :mod:`.tracker`: :class:`PeopleTracker` turns noisy people detections (:class:`Detections`,
  :mod:`.detections`) into tracks (:class:`Track`) and the planner's ``DynamicObstacle``
  pedestrians, with velocities from a constant-velocity Kalman filter (:mod:`.kalman`).
- :mod:`.local_map`: :class:`LocalMap` turns 2D lidar scans (:class:`LaserScan`, :mod:`.scan`)
  into a rolling occupancy window around the robot, handed to the planner as an
  ``OccupancyGrid`` (configured by :class:`LocalMapConfig`); the cells each beam passes through
  come from :mod:`.raycast` (numpy, or a numba kernel); the grid it hands out knows the cells a
  beam has crossed (:class:`SensedGrid`, :mod:`.sensed_grid`).
"""

from .local_map import LocalMap, LocalMapConfig
from .scan import LaserScan
from .sensed_grid import SensedGrid
from .tracker import Detections, PeopleTracker, Track, TrackerConfig

__all__ = ["Detections", "LaserScan", "LocalMap", "LocalMapConfig", "PeopleTracker", "SensedGrid",
           "Track", "TrackerConfig"]
