"""The people tracker: noisy detections in, tracks and the planner's dynamic obstacles out.

Each :meth:`PeopleTracker.update` predicts every track to the detections' stamp with a
constant-velocity Kalman filter (:mod:`.kalman`), associates detections with tracks, corrects
the matched tracks, starts a tentative track at each detection left over, and counts misses
and deletes the tracks unseen too long. Association is by the detector's ids when it gives
them; otherwise each detection is gated by its squared Mahalanobis distance (with the
innovation covariance) to each track's prediction, and the gated pairs are assigned optimally
(``scipy.optimize.linear_sum_assignment``), confirmed tracks first, so a tentative track never
takes a confirmed track's detection. A track is confirmed, and reported, after
``confirm_hits`` detections. :meth:`PeopleTracker.obstacles` hands the confirmed tracks to
the planner as :class:`DynamicObstacle` pedestrians moving at the estimated velocity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError, finite_number, shown
from ..core.world import DynamicObstacle
from . import kalman
from .detections import Detections, TrackerConfig

__all__ = ["Detections", "PeopleTracker", "Track", "TrackerConfig"]

_FIELDS = ("means", "covariances", "ids", "hits", "misses", "born", "last_hit", "confirmed",
           "radius_buffer", "radius_count", "radii")


@dataclass(frozen=True, eq=False)
class Track:
    """One tracked person, as the tracker saw it at ``stamp``: a read-only snapshot.

    Attributes
    ----------
    id : int
        The track's identity: the detector's id when it gives ids, else the tracker's own.
    mean : ndarray, shape (4,)
        State estimate ``[x, y, vx, vy]`` (m, m, m/s, m/s), world frame, unclipped.
    covariance : ndarray, shape (4, 4)
        Its covariance (m^2, m^2/s, m^2/s^2).
    radius : float
        Median of the last detected radii (m), or the configured default.
    hits : int
        Detections matched to the track since its birth.
    misses : int
        Consecutive updates without a detection.
    age : float
        Time since the track's first detection (s).
    confirmed : bool
        Whether it has had ``confirm_hits`` detections (then :meth:`PeopleTracker.obstacles`
        reports it).
    stamp : float
        The time of the estimate (s): the last update's stamp.
    """

    id: int
    mean: np.ndarray
    covariance: np.ndarray
    radius: float
    hits: int
    misses: int
    age: float
    confirmed: bool
    stamp: float

    @property
    def position(self) -> np.ndarray:
        """Estimated position (m), shape (2,)."""
        return self.mean[:2]

    @property
    def velocity(self) -> np.ndarray:
        """Estimated velocity (m/s), shape (2,), unclipped."""
        return self.mean[2:]

    @property
    def position_std(self) -> float:
        """Standard deviation (m) of the position along its most uncertain direction: large
        for a young or coasting track, so a planner could widen its collision spread."""
        return float(position_stds(self.covariance[None])[0])


def position_stds(covariances) -> np.ndarray:
    """Each track's position standard deviation (m) along its most uncertain direction, from
    its state covariances ``(n, 4, 4)``."""
    largest = np.linalg.eigvalsh(np.asarray(covariances)[:, :2, :2])[:, -1]
    return np.sqrt(np.maximum(largest, 0.0))


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array)
    array.flags.writeable = False
    return array


class PeopleTracker:
    """Tracks people from a stream of :class:`Detections` (see the module's docstring).

    Parameters
    ----------
    config : TrackerConfig, optional
        The settings; None: the defaults.
    """

    def __init__(self, config: TrackerConfig | None = None):
        if config is None:
            config = TrackerConfig()
        if not isinstance(config, TrackerConfig):
            raise InputError(f"config={shown(config)}: expected a TrackerConfig or None")
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Forget every track, the last stamp and the counts."""
        window = self.config.radius_window
        self._state = {
            "means": np.zeros((0, 4)), "covariances": np.zeros((0, 4, 4)),
            "ids": np.zeros(0, np.int64), "hits": np.zeros(0, np.int64),
            "misses": np.zeros(0, np.int64), "born": np.zeros(0), "last_hit": np.zeros(0),
            "confirmed": np.zeros(0, bool), "radius_buffer": np.zeros((0, window)),
            "radius_count": np.zeros(0, np.int64), "radii": np.zeros(0),
        }
        self._stamp: float | None = None
        self._next_id = 0
        self.dropped = 0
        """Detection rows dropped as bad data since the last reset."""

    @property
    def stamp(self) -> float | None:
        """The last update's stamp (s); None before the first."""
        return self._stamp

    @property
    def tracks(self) -> list[Track]:
        """Every live track, tentative ones included, by id."""
        return self._views(np.ones(len(self._state["ids"]), bool))

    def update(self, detections: Detections) -> list[Track]:
        """Take one cycle's detections; returns the confirmed tracks, by id.

        Raises
        ------
        InputError
            ``detections`` is not a :class:`Detections`, or its stamp is earlier than the last
            update's (an equal stamp is allowed: no prediction).
        """
        if not isinstance(detections, Detections):
            raise InputError(f"detections={shown(detections)}: expected a Detections")
        stamp = detections.stamp
        if self._stamp is not None and stamp < self._stamp:
            raise InputError(f"stamp={shown(stamp)}: expected a time (s) no earlier than the "
                             f"last update's stamp {shown(self._stamp)}")
        if self._stamp is not None and stamp > self._stamp and len(self._state["ids"]):
            state = self._state
            state["means"], state["covariances"] = kalman.predict(
                state["means"], state["covariances"], stamp - self._stamp,
                self.config.acceleration_density)
        self._stamp = stamp
        self.dropped += detections.dropped
        rows, columns = (self._match_ids(detections) if detections.ids is not None
                         else self._match_gated(detections.positions))
        self._correct(rows, columns, detections)
        unmatched = np.ones(len(detections), bool)
        unmatched[columns] = False
        self._forget(rows)
        self._birth(detections, unmatched)
        return self._views(self._state["confirmed"])

    def obstacles(self, now: float | None = None) -> list[DynamicObstacle]:
        """The confirmed tracks as pedestrians for the planner, by id.

        Each moves at its estimated velocity, clipped to ``max_speed``; its position is at
        ``now`` (s), predicted at that velocity from the last update, or at the last update's
        stamp if ``now`` is None. ``now`` may lie before the last stamp (extrapolated back).
        """
        state = self._state
        confirmed = state["confirmed"]
        if now is not None:
            now_value = finite_number("now", now, "a finite time (s) or None")
        if not np.any(confirmed):
            return []
        ahead = 0.0 if now is None else now_value - self._stamp
        means = state["means"][confirmed]
        velocities = kalman.clip_speed(means[:, 2:], self.config.max_speed)
        positions = means[:, :2] + ahead * velocities
        order = np.argsort(state["ids"][confirmed], kind="stable")
        radii = state["radii"][confirmed]
        if self.config.inflate > 0.0:
            radii = radii + self.config.inflate * position_stds(state["covariances"][confirmed])
        return [DynamicObstacle.pedestrian(positions[i], velocities[i], radii[i])
                for i in order]

    # -----------------------------------------------------------------------------------------
    # association

    def _match_ids(self, detections: Detections):
        """Rows of the tracks and columns of the detections that share an id."""
        row_of = {int(track_id): row for row, track_id in enumerate(self._state["ids"])}
        pairs = [(row_of[int(track_id)], column)
                 for column, track_id in enumerate(detections.ids) if int(track_id) in row_of]
        if not pairs:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        rows, columns = np.array(pairs, dtype=np.int64).T
        return rows, columns

    def _match_gated(self, positions: np.ndarray):
        """Gated optimal assignment, confirmed tracks first, then the tentative ones."""
        state = self._state
        empty = np.zeros(0, np.int64)
        if not len(state["ids"]) or not len(positions):
            return empty, empty
        s_inverse = kalman.innovation_inverse(state["covariances"],
                                              self.config.measurement_std ** 2)
        distances = kalman.mahalanobis(state["means"], s_inverse, positions)
        confirmed = np.flatnonzero(state["confirmed"])
        tentative = np.flatnonzero(~state["confirmed"])
        rows, columns = self._assign(distances, confirmed, np.arange(len(positions)))
        free = np.ones(len(positions), bool)
        free[columns] = False
        free = np.flatnonzero(free)
        more_rows, more_columns = self._assign(distances, tentative, free)
        return np.concatenate([rows, more_rows]), np.concatenate([columns, more_columns])

    def _assign(self, distances: np.ndarray, rows: np.ndarray, columns: np.ndarray):
        """The least-cost assignment of ``rows`` to ``columns`` among the gated pairs.

        A pair outside the gate costs more than any set of gated pairs, so the assignment
        takes as many gated pairs as it can and, among those sets, the cheapest; the pairs
        outside the gate it makes are then dropped.
        """
        empty = np.zeros(0, np.int64)
        if not len(rows) or not len(columns):
            return empty, empty
        cost = distances[np.ix_(rows, columns)]
        allowed = cost <= self.config.gate
        useful_rows = np.flatnonzero(allowed.any(axis=1))
        useful_columns = np.flatnonzero(allowed.any(axis=0))
        if not len(useful_rows):
            return empty, empty
        cost = cost[np.ix_(useful_rows, useful_columns)]
        allowed = allowed[np.ix_(useful_rows, useful_columns)]
        outside = self.config.gate * (min(cost.shape) + 1)
        # here, not at the top: scipy.optimize costs ~0.4 s of imports, and a process that
        # imports this package need not track anyone
        from scipy.optimize import linear_sum_assignment

        picked_rows, picked_columns = linear_sum_assignment(np.where(allowed, cost, outside))
        keep = allowed[picked_rows, picked_columns]
        return (rows[useful_rows[picked_rows[keep]]],
                columns[useful_columns[picked_columns[keep]]])

    # -----------------------------------------------------------------------------------------
    # bookkeeping

    def _correct(self, rows: np.ndarray, columns: np.ndarray, detections: Detections) -> None:
        """Kalman-update the matched tracks; count their hits; record their radii."""
        if not len(rows):
            return
        state, config = self._state, self.config
        variance = config.measurement_std ** 2
        s_inverse = kalman.innovation_inverse(state["covariances"][rows], variance)
        state["means"][rows], state["covariances"][rows] = kalman.correct(
            state["means"][rows], state["covariances"][rows], s_inverse,
            detections.positions[columns], variance)
        state["hits"][rows] += 1
        state["misses"][rows] = 0
        state["last_hit"][rows] = detections.stamp
        state["confirmed"][rows] |= state["hits"][rows] >= config.confirm_hits
        if detections.radii is not None:
            slots = state["radius_count"][rows] % config.radius_window
            state["radius_buffer"][rows, slots] = detections.radii[columns]
            state["radius_count"][rows] += 1
            state["radii"][rows] = np.nanmedian(state["radius_buffer"][rows], axis=1)

    def _forget(self, matched_rows: np.ndarray) -> None:
        """Count a miss for every track not matched; delete those missed or unseen too long."""
        state, config = self._state, self.config
        missed = np.ones(len(state["ids"]), bool)
        missed[matched_rows] = False
        state["misses"][missed] += 1
        limit = np.where(state["confirmed"], config.max_misses, config.max_tentative_misses)
        dead = (state["misses"] >= limit) | (
            self._stamp - state["last_hit"] >= config.max_unseen_time)
        if np.any(dead):
            self._state = {name: state[name][~dead] for name in _FIELDS}

    def _birth(self, detections: Detections, unmatched: np.ndarray) -> None:
        """A tentative track at each detection no track took."""
        count = int(np.count_nonzero(unmatched))
        if not count:
            return
        config = self.config
        if detections.ids is not None:
            ids = detections.ids[unmatched]
            self._next_id = max(self._next_id, int(ids.max()) + 1)
        else:
            ids = np.arange(self._next_id, self._next_id + count, dtype=np.int64)
            self._next_id += count
        means, covariances = kalman.initial(detections.positions[unmatched],
                                            config.measurement_std,
                                            config.initial_velocity_std)
        buffer = np.full((count, config.radius_window), np.nan)
        radii = np.full(count, config.default_radius)
        if detections.radii is not None:
            radii = detections.radii[unmatched]
            buffer[:, 0] = radii
        hits = np.ones(count, np.int64)
        new = {
            "means": means, "covariances": covariances, "ids": ids, "hits": hits,
            "misses": np.zeros(count, np.int64), "born": np.full(count, detections.stamp),
            "last_hit": np.full(count, detections.stamp),
            "confirmed": hits >= config.confirm_hits, "radius_buffer": buffer,
            "radius_count": np.full(count, int(detections.radii is not None), np.int64),
            "radii": radii,
        }
        self._state = {name: np.concatenate([self._state[name], new[name]])
                       for name in _FIELDS}

    def _views(self, mask: np.ndarray) -> list[Track]:
        """Read-only :class:`Track` snapshots of the rows in ``mask``, by id."""
        state = self._state
        rows = np.flatnonzero(mask)
        rows = rows[np.argsort(state["ids"][rows], kind="stable")]
        return [Track(int(state["ids"][r]), _frozen(state["means"][r]),
                      _frozen(state["covariances"][r]), float(state["radii"][r]),
                      int(state["hits"][r]), int(state["misses"][r]),
                      float(self._stamp - state["born"][r]), bool(state["confirmed"][r]),
                      float(self._stamp)) for r in rows]
