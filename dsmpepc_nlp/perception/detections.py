"""What the people tracker reads: one cycle's detections and the tracker's configuration.

:class:`Detections` checks its arrays (a shape error raises :class:`InputError`; a row with a
non-finite position or radius is bad data, dropped and counted) and :class:`TrackerConfig`
its numbers. :mod:`.tracker` turns a stream of detections into tracks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import MAX_COORDINATE, MAX_SIZE, MAX_SPEED, InputError, shown
from ..core.validation import check_integers, validate_fields


def _readonly(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


def _positions(value) -> np.ndarray:
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"positions={shown(value)}: expected an (n, 2) array of positions "
                         "(m), n >= 0") from None
    if array.size == 0:
        return array.reshape(0, 2)
    if array.ndim != 2 or array.shape[1] != 2:
        raise InputError(f"positions={shown(value)}: expected an (n, 2) array of positions "
                         f"(m), n >= 0; got shape {array.shape}")
    return array


def _radii(value, count: int) -> np.ndarray:
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        array = None
    if array is None or array.shape != (count,):
        raise InputError(f"radii={shown(value)}: expected {count} radii (m), one a position")
    return array


def _ids(value, count: int) -> np.ndarray:
    array = np.asarray(value)
    if array.shape != (count,):
        raise InputError(f"ids={shown(value)}: expected {count} ids, one a position")
    integral = array.dtype.kind in "iu" or count == 0 or (
        array.dtype.kind == "f" and bool(np.all(np.isfinite(array) & (array == np.round(array)))))
    if not integral:
        raise InputError(f"ids={shown(value)}: expected {count} integer ids")
    array = array.astype(np.int64)
    if len(np.unique(array)) != count:
        raise InputError(f"ids={shown(value)}: expected {count} distinct ids")
    return array


@dataclass(frozen=True, eq=False)
class Detections:
    """The people one sensing cycle saw.

    A row whose position is not finite or beyond ``MAX_COORDINATE`` (m), or whose radius is
    not finite, not > 0 or beyond ``MAX_SIZE`` (m), is dropped and counted in ``dropped``: a
    detector's bad data, not an error. A field of the wrong shape or type, ids repeated within
    one cycle, or a non-finite ``stamp`` raise :class:`InputError` naming the field.

    Attributes
    ----------
    positions : ndarray, shape (n, 2)
        World positions (m) of the people seen; n = 0 is allowed. After construction: the valid
        rows only, read-only.
    stamp : float
        When they were seen (s), any clock the caller keeps, as long as it never runs back.
    radii : ndarray, shape (n,), optional
        Each person's radius (m); None: the tracker's ``default_radius``.
    ids : ndarray of int, shape (n,), optional
        Identities from a detector that associates on its own; the tracker then matches by id
        and names each track by its detector id. None: the tracker associates.
    dropped : int
        Rows dropped as bad data (set on construction).
    """

    positions: np.ndarray
    stamp: float
    radii: np.ndarray | None = None
    ids: np.ndarray | None = None
    dropped: int = field(init=False, default=0)

    def __post_init__(self):
        positions = _positions(self.positions)
        count = len(positions)
        if isinstance(self.stamp, bool):
            raise InputError(f"stamp={shown(self.stamp)}: expected a finite time (s)")
        try:
            stamp = float(self.stamp)
        except (TypeError, ValueError):
            stamp = math.nan
        if not math.isfinite(stamp):
            raise InputError(f"stamp={shown(self.stamp)}: expected a finite time (s)")
        valid = np.all(np.isfinite(positions) & (np.abs(positions) <= MAX_COORDINATE), axis=1)
        radii = None if self.radii is None else _radii(self.radii, count)
        if radii is not None:
            valid &= np.isfinite(radii) & (radii > 0.0) & (radii <= MAX_SIZE)
            radii = _readonly(radii[valid])
        ids = None if self.ids is None else _readonly(_ids(self.ids, count)[valid])
        object.__setattr__(self, "positions", _readonly(positions[valid]))
        object.__setattr__(self, "stamp", stamp)
        object.__setattr__(self, "radii", radii)
        object.__setattr__(self, "ids", ids)
        object.__setattr__(self, "dropped", int(count - np.count_nonzero(valid)))

    def __len__(self) -> int:
        return len(self.positions)


@dataclass(frozen=True)
class TrackerConfig:
    """The people tracker's settings (:class:`.tracker.PeopleTracker`)."""

    measurement_std: float = 0.1
    """Standard deviation of a detected position on each axis, m. Our choice: it matches the
    sensing profile the tracker was made for (0.1 m Gaussian noise on each detection)."""
    acceleration_density: float = 0.1
    """Spectral density of the white acceleration that perturbs a walker's velocity, m^2/s^3
    (:mod:`.kalman`). Our choice, by the rule of Bar-Shalom, Li and Kirubarajan (2001,
    section 6.2.2) that the velocity changes by about ``sqrt(density * T)`` over a period
    ``T``: 0.14 m/s per 0.2 s cycle, the 0.7 m/s^2 of a walker's ordinary speed changes.
    Larger follows turns and stops sooner (after a stop from 1.2 m/s the estimate falls
    under 0.3 m/s in about 0.8 s at 0.1, 0.4 s at 1.0) and is noisier (velocity error about
    0.11 m/s on each axis at 0.1, 0.26 m/s at 1.0, with 0.1 m noise every 0.2 s)."""
    initial_velocity_std: float = 1.0
    """Standard deviation of a new track's velocity on each axis, m/s (it starts standing
    still). Our choice: a typical walking speed, about 1.3 m/s, is then 1.3 standard
    deviations, well inside the gate; larger lets more pairs of false detections start a
    track (1.5 confirmed about twice as many false tracks as 1.0 in our clutter runs)."""
    gate: float = 9.21
    """Largest squared Mahalanobis distance, with the innovation covariance, at which a
    detection may continue a track: 9.21 is the chi-square quantile of 99 % for 2 degrees of
    freedom, so a true detection falls outside it once in a hundred."""
    confirm_hits: int = 3
    """Detections a track needs before it is confirmed and reported (our choice: at a
    0.2 s cycle, 0.4 s after first sight)."""
    max_misses: int = 5
    """A confirmed track is deleted at this many consecutive cycles without a detection
    (our choice: 1 s at a 0.2 s cycle)."""
    max_tentative_misses: int = 1
    """A tentative (not yet confirmed) track is deleted at this many consecutive misses. Our
    choice: 1, so the ``confirm_hits`` detections must come in a row, which a detector's
    isolated false detections rarely do."""
    max_unseen_time: float = 1.5
    """Any track is deleted once this long (s) has passed since its last detection, whatever
    the cycle (our choice: a walker at 1.3 m/s has gone 2 m; ``inf``: off)."""
    default_radius: float = 0.3
    """A track's radius (m) when the detector gives none: 0.3 m, the product's pedestrian
    radius (:meth:`dsmpepc_nlp.core.world.DynamicObstacle.pedestrian`)."""
    radius_window: int = 10
    """A track's radius is the median of its last this many detected radii (our choice:
    robust to a detection that merges two people)."""
    max_speed: float = 2.5
    """A reported velocity's speed is clipped to this, m/s (our choice: a brisk walk is
    about 2 m/s; a young track's estimate can overshoot)."""
    inflate: float = 2.0
    """A reported radius grows by this many standard deviations of the track's position
    (:attr:`.tracker.Track.position_std`, at the reported time): a young or coasting track is
    drawn larger, so a planner keeps a wider berth where the estimate is least sure (0: off).
    Our choice, on CrowdNav circle crossing's tuning cases (``--seed 1``, 40 cases,
    ``tracked``): 0.725 at 0, 0.80 at 1, 0.825 at 2; held out (``--seed 0``, 50 cases each)
    circle 0.66 -> 0.80, square 0.80 -> 0.80, at-fault collisions 0.22 -> 0.02 and
    0.08 -> 0.02, time to goal about 1.5 s longer
    (docs/experiments/2026-12-06-inflated-tracks.md)."""

    def __post_init__(self):
        validate_fields(self, {
            "measurement_std": {"low": 0.0, "high": MAX_SIZE, "low_open": True},
            "acceleration_density": {"low": 0.0, "high": 1.0e4, "low_open": True},
            "initial_velocity_std": {"low": 0.0, "high": MAX_SPEED, "low_open": True},
            "gate": {"low": 0.0, "high": 1.0e4, "low_open": True},
            "max_unseen_time": {"low": 0.0, "high": math.inf, "low_open": True,
                                "allow_inf": True},
            "default_radius": {"low": 0.0, "high": MAX_SIZE, "low_open": True},
            "max_speed": {"low": 0.0, "high": MAX_SPEED, "low_open": True},
            "inflate": {"low": 0.0, "high": 10.0},
        })
        check_integers(self, {"confirm_hits": 1, "max_misses": 1, "max_tentative_misses": 1,
                              "radius_window": 1})
