"""IR-SIM objects as the planner's bodies: the robot's footprint circles and limits, a moving
object's circles, and a static object's shape for the rasteriser.

IR-SIM keeps a circle as a shapely polygon (a buffered point) and reports its radius as that
polygon's bounding radius (``0.20000000000000004`` for 0.2); radii and centres are read back
rounded to :data:`ROUND` so a circle stays the circle the world file wrote. A rectangle (or a
polygon, a compound) is covered by a row of circles along its longer side of its body-frame
bounding box, each covering its slice exactly (the slice's half-diagonal; as for the BARN
Jackal).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.config import RobotConfig
from ..core.errors import MAX_SPEED, InputError
from ..core.world import DynamicObstacle

ROUND = 9
"""Decimals (m) of the radii and centres read from IR-SIM's circles (1e-9 m)."""
MAX_CIRCLES = 8
"""Most circles covering one rectangle (our choice: each extra circle costs plan time)."""
AREAL = ("circle", "rectangle", "polygon", "compound")
"""IR-SIM shapes with area (the body shapes the adapter covers with circles)."""
STATIC = ("circle", "rectangle", "polygon", "compound", "linestring", "map")
"""IR-SIM shapes a static obstacle may have (``map``: the world's obstacle map)."""


def describe(obj) -> str:
    """How a message names an IR-SIM object: its name and id."""
    return f"{getattr(obj, 'role', 'object')} {obj.name!r} (id {obj.id})"


def _bounds(geometry) -> tuple:
    return tuple(float(b) for b in geometry.bounds)


def cover_box(xmin: float, ymin: float, xmax: float, ymax: float) -> tuple:
    """Circles ``(cx, cy, r)`` covering the box: a row along its longer side, about two a
    width (``ceil(2 * long / short)``, at most :data:`MAX_CIRCLES`), each the circumcircle of
    its slice."""
    length, width = xmax - xmin, ymax - ymin
    along_x = length >= width
    long_side, short = (length, width) if along_x else (width, length)
    n = max(1, min(MAX_CIRCLES, math.ceil(2.0 * long_side / max(short, 1e-12) - 1e-9)))
    if short <= 0.0:
        n = MAX_CIRCLES
    piece = long_side / n
    radius = round(0.5 * math.hypot(piece, short), ROUND)
    circles = []
    for k in range(n):
        mid = (xmin if along_x else ymin) + (k + 0.5) * piece
        cx, cy = (mid, 0.5 * (ymin + ymax)) if along_x else (0.5 * (xmin + xmax), mid)
        circles.append((round(cx, ROUND), round(cy, ROUND), radius))
    return tuple(circles)


def body_circles(obj) -> tuple:
    """Circles ``(cx, cy, r)`` in ``obj``'s body frame covering its shape; InputError naming the
    object for a shape without area."""
    shape = obj.shape
    if shape not in AREAL:
        raise InputError(f"{describe(obj)}: its shape {shape!r} cannot be covered by circles "
                         f"(the adapter knows {', '.join(AREAL)})")
    original = obj.original_geometry
    if shape == "circle":
        centre = np.asarray(obj.gf.original_centroid, dtype=float).reshape(-1)
        return ((round(float(centre[0]), ROUND), round(float(centre[1]), ROUND),
                 round(float(obj.radius), ROUND)),)
    return cover_box(*_bounds(original))


def _pair(value, name, obj, allow_inf=False) -> np.ndarray:
    arr = np.asarray(value, dtype=float).reshape(-1)
    ok = (lambda a: ~np.isnan(a)) if allow_inf else np.isfinite
    if arr.size < 2 or not np.all(ok(arr[:2])):
        raise InputError(f"{describe(obj)}: {name}={arr.tolist()}: expected [linear, angular]")
    return arr[:2]


def robot_config(robot) -> RobotConfig:
    """The planner's :class:`RobotConfig` of an IR-SIM diff robot.

    ``v_limit`` is ``vel_max[0]``, ``reverse_limit`` is ``-vel_min[0]`` (0 when vel_min[0] >= 0),
    ``omega_limit`` the smaller of ``vel_max[1]`` and ``-vel_min[1]``, and ``accel_limit``,
    ``alpha_limit`` IR-SIM's ``acce`` (m/s^2 and rad/s^2; IR-SIM applies them per step from the
    commanded velocity; ``inf``, its default, turns them off). The footprint: see
    :func:`body_circles`.
    """
    if robot.kinematics != "diff":
        raise InputError(f"{describe(robot)}: kinematics {robot.kinematics!r}: the planner "
                         "drives a differential-drive robot (kinematics: {name: diff})")
    vel_max = _pair(robot.vel_max, "vel_max", robot)
    vel_min = _pair(robot.vel_min, "vel_min", robot)
    acce = np.abs(_pair(robot.info.acce, "acce", robot, allow_inf=True))
    if not 0.0 < vel_max[0] <= MAX_SPEED:
        raise InputError(f"{describe(robot)}: vel_max[0]={vel_max[0]:g}: the planner needs a "
                         f"forward speed limit in (0, {MAX_SPEED:g}] m/s")
    omega = min(vel_max[1], -vel_min[1])
    if not omega > 0.0:
        raise InputError(f"{describe(robot)}: vel_min={vel_min.tolist()}, "
                         f"vel_max={vel_max.tolist()}: the planner needs -vel_min[1] > 0 and "
                         "vel_max[1] > 0 (it turns both ways)")
    try:
        return RobotConfig(v_limit=float(vel_max[0]), omega_limit=float(omega),
                           accel_limit=float(acce[0]), alpha_limit=float(acce[1]),
                           footprint=body_circles(robot),
                           reverse_limit=float(max(0.0, min(-vel_min[0], MAX_SPEED))))
    except InputError as exc:
        raise InputError(f"{describe(robot)}: {exc}") from None


def pose_of(obj) -> np.ndarray:
    """``(x, y, theta)`` of ``obj``, m and rad."""
    state = np.asarray(obj.state, dtype=float).reshape(-1)
    return np.array([state[0], state[1], state[2] if state.size > 2 else 0.0])


def moving_obstacle(obj, velocity) -> DynamicObstacle:
    """``obj`` as the planner's moving obstacle with world ``velocity`` (2,) (m/s): a circle as a
    pedestrian of its radius, any other body (another robot, a moving box) as its covering
    circles (kind ``robot``)."""
    circles = body_circles(obj)
    if obj.shape == "circle" and obj.role != "robot":
        centre = np.asarray(obj.geometry.centroid.coords[0], dtype=float)
        return DynamicObstacle.pedestrian(centre, velocity, circles[0][2])
    return DynamicObstacle.robot(pose_of(obj), velocity, circles)


def static_part(obj):
    """What the rasteriser draws of a static ``obj``: ``("disc", (centre, radius))``,
    ``("geometry", shapely geometry)`` or ``("map", None)`` (the world's map grid, drawn from
    the grid itself). InputError naming the object for a shape it does not know."""
    shape = obj.shape
    if shape not in STATIC:
        raise InputError(f"{describe(obj)}: static shape {shape!r} is unknown to the adapter "
                         f"(it knows {', '.join(STATIC)})")
    if shape == "map":
        return "map", None
    if shape == "circle":
        centre = np.asarray(obj.geometry.centroid.coords[0], dtype=float)
        return "disc", (np.round(centre, ROUND), round(float(obj.radius), ROUND))
    return "geometry", obj.geometry
