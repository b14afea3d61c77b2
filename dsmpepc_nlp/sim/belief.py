"""What a sensing robot believed, logged beside the truth: an episode's belief arrays and meta.

Under a sensing profile (:mod:`.sensing`) the closed loop (:mod:`.simulate`) keeps, every
cycle and for every robot that planned, the state it believed it was in and the people it
planned with (:class:`~dsmpepc_nlp.core.world.DynamicObstacle` pedestrians as its senses
handed them over). :func:`belief_log` turns them, with each robot's local map at the end of
the run, into the :class:`~.episode.Episode` fields ``believed_states``, ``believed_people``
and ``believed_occupied``.
"""

from __future__ import annotations

import numpy as np


def belief_log(senses, profile, perception, believed, believed_people, meta) -> dict:
    """The episode's belief arrays; adds the profile, the sensing counts, what each collision
    touched and the local maps' frames to ``meta``.

    Parameters
    ----------
    senses : list of Senses
        One a robot (:class:`~.senses.Senses`).
    profile : SensingProfile
    perception : list
        Per robot, at a collision, what it touched and whether it believed it there.
    believed, believed_people : list of dict
        Per cycle, robot -> its believed state (5,) and the people it planned with (m, 5):
        ``[x, y, vx, vy, radius]``.
    meta : dict
        The episode's meta, added to.
    """
    meta["sensing"] = profile.as_dict()
    meta["sensing_counts"] = [dict(s.counts) for s in senses]
    meta["perception"] = perception
    n = len(senses)
    extra = {"believed_states": _states(n, believed),
             "believed_people": _people(n, believed_people)}
    if senses[0].local_map is not None:
        grids = [s.local_map.grid() for s in senses]
        extra["believed_occupied"] = np.stack([g.occupied for g in grids])
        meta["believed_origin"] = [g.origin.tolist() for g in grids]
        meta["believed_resolution"] = grids[0].resolution
    return extra


def _states(n, believed) -> np.ndarray:
    """(R, K, 5): the state each robot believed it was in when it planned; NaN when it did
    not plan."""
    out = np.full((n, len(believed), 5), np.nan)
    for k, cycle in enumerate(believed):
        for i, state in cycle.items():
            out[i, k] = state
    return out


def _people(n, believed_people) -> np.ndarray:
    """(R, K, M, 5): the people each robot planned with at each cycle, ``[x, y, vx, vy,
    radius]``, NaN-padded to the most of any cycle (M may be 0)."""
    most = max((len(p) for cycle in believed_people for p in cycle.values()), default=0)
    out = np.full((n, len(believed_people), most, 5), np.nan)
    for k, cycle in enumerate(believed_people):
        for i, people in cycle.items():
            out[i, k, :len(people)] = people
    return out
