"""One 2D lidar scan, as ROS's ``sensor_msgs/LaserScan`` carries it, with the sensor's pose.

Bad fields of the message (a non-finite pose or stamp, limits that make no sense, angles of the
wrong length) raise :class:`~dsmpepc_nlp.core.errors.InputError`. Bad *range values* are
ordinary data and are sorted, not raised (REP 117): ``+inf`` is "no return" (free along the
whole beam), NaN, ``-inf``, values below ``range_min`` and finite values above ``range_max``
are dropped and counted by :meth:`LaserScan.validity`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import MAX_COORDINATE, InputError, finite_number, finite_vector, shown

DROP_REASONS = ("not_a_number", "below_range_min", "above_range_max")
"""Why a range value is dropped: NaN; below ``range_min`` (negatives and ``-inf`` included);
finite and above ``range_max``."""


_finite = finite_number


def _readonly(arr):
    arr.setflags(write=False)
    return arr


def _float_vector(name, value) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}={shown(value)}: expected a 1-D array of numbers") from None
    if arr.ndim != 1:
        raise InputError(f"{name} has shape {arr.shape}: expected a 1-D array (n,)")
    return _readonly(arr)


@dataclass(frozen=True, eq=False)
class LaserScan:
    """A planar range scan and where the sensor stood when it took it.

    Equality and hashing are by identity (the fields are arrays).

    Parameters
    ----------
    ranges : array_like, shape (n,)
        Range (m) of each beam; any float, see :meth:`validity`.
    angle_min : float
        Angle (rad) of beam 0 in the sensor frame (x forward, y left).
    angle_increment : float
        Angle (rad) between consecutive beams.
    range_min, range_max : float
        The sensor's valid range (m): finite, ``0 <= range_min < range_max``.
    pose : array_like, shape (3,)
        The sensor's pose ``(x, y, yaw)`` in the world frame (m, m, rad), finite and within
        ``MAX_COORDINATE``.
    stamp : float
        Time of the scan (s), finite.
    angles : array_like, shape (n,), optional
        Explicit beam angles (rad) in the sensor frame, instead of ``angle_min`` and
        ``angle_increment``; see :meth:`from_angles`.

    Raises
    ------
    InputError
        Naming the field, the value and what is allowed.
    """

    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    pose: np.ndarray = (0.0, 0.0, 0.0)
    stamp: float = 0.0
    angles: np.ndarray | None = None

    def __post_init__(self):
        ranges = _float_vector("ranges", self.ranges)
        put = object.__setattr__  # frozen: fields are set once, here
        put(self, "ranges", ranges)
        put(self, "angle_min", _finite("angle_min", self.angle_min))
        put(self, "angle_increment", _finite("angle_increment", self.angle_increment))
        low = _finite("range_min", self.range_min)
        high = _finite("range_max", self.range_max)
        if low < 0.0:
            raise InputError(f"range_min={shown(self.range_min)}: expected a number >= 0 (m)")
        if high <= low:
            raise InputError(f"range_max={shown(self.range_max)}: expected a number > "
                             f"range_min={low:g} (m)")
        put(self, "range_min", low)
        put(self, "range_max", high)
        put(self, "pose", _readonly(finite_vector("pose", self.pose, 3, MAX_COORDINATE)))
        put(self, "stamp", _finite("stamp", self.stamp))
        if self.angles is not None:
            angles = _float_vector("angles", self.angles)
            if angles.shape != ranges.shape:
                raise InputError(f"angles has shape {angles.shape}: scan of the wrong length, "
                                 f"expected one angle per range, shape {ranges.shape}")
            if not np.all(np.isfinite(angles)):
                raise InputError(f"angles={shown(angles)}: expected finite angles (rad)")
            put(self, "angles", angles)

    @classmethod
    def from_angles(cls, ranges, angles, range_min, range_max, pose=(0.0, 0.0, 0.0),
                    stamp=0.0) -> LaserScan:
        """A scan with an explicit angle (rad, sensor frame) per beam.

        ``angle_min`` is then the first angle and ``angle_increment`` the mean step (both 0
        for an empty scan), for information: the beams point along ``angles``.
        """
        arr = _float_vector("angles", angles)
        usable = arr.size > 0 and bool(np.all(np.isfinite(arr)))  # else the constructor raises
        first = float(arr[0]) if usable else 0.0
        step = float((arr[-1] - arr[0]) / (arr.size - 1)) if usable and arr.size > 1 else 0.0
        return cls(ranges, first, step, range_min, range_max, pose, stamp, angles=arr)

    @property
    def size(self) -> int:
        """Number of beams n."""
        return int(self.ranges.size)

    def beam_angles(self) -> np.ndarray:
        """Angle (rad) of each beam in the sensor frame, shape (n,)."""
        if self.angles is not None:
            return self.angles
        return self.angle_min + self.angle_increment * np.arange(self.size)

    def validity(self) -> tuple[np.ndarray, dict]:
        """Which beams are usable, and how many of each kind there are.

        Returns
        -------
        valid : ndarray of bool, shape (n,)
            A hit (finite, ``range_min <= r <= range_max``) or a no-return (``+inf``).
        counts : dict of str to int
            ``hits``, ``no_return`` (usable) and one count per :data:`DROP_REASONS` entry.
        """
        r = self.ranges
        nan = np.isnan(r)
        below = r < self.range_min          # negatives and -inf: range_min >= 0
        no_return = np.isposinf(r)
        above = (r > self.range_max) & ~no_return
        hits = ~(nan | below | above | no_return)
        counts = {"hits": int(np.count_nonzero(hits)),
                  "no_return": int(np.count_nonzero(no_return)),
                  "not_a_number": int(np.count_nonzero(nan)),
                  "below_range_min": int(np.count_nonzero(below)),
                  "above_range_max": int(np.count_nonzero(above))}
        return hits | no_return, counts


def returns_off_objects(ranges, pose, angles, obstacles, margin: float) -> np.ndarray:
    """``ranges`` (m, per beam at ``angles`` rad from the sensor's ``pose`` (x, y, yaw)) with
    the returns within ``margin`` of a circle of ``obstacles`` (DynamicObstacles the planner
    is given already) made NaN: a moving object is planned round as itself, not marked into
    the map (as people-aware costmaps do)."""
    ranges = np.asarray(ranges, dtype=float)
    if not obstacles:
        return ranges
    heading = pose[2] + np.asarray(angles, dtype=float)
    with np.errstate(invalid="ignore"):
        hits = pose[:2] + ranges[:, None] * np.stack([np.cos(heading), np.sin(heading)], 1)
    centres = np.concatenate([o.centers for o in obstacles])
    reach = np.concatenate([o.radii for o in obstacles]) + margin
    gap = np.linalg.norm(hits[:, None, :] - centres[None], axis=-1) - reach[None]
    on_object = np.isfinite(ranges) & np.any(gap <= 0.0, axis=1)
    return np.where(on_object, np.nan, ranges)
