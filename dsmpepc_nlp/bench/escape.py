"""Was a contact avoidable? A search over the robot's own commands against the logged people.

For a run that ended in a collision, :func:`search` starts from the robot's logged state
:data:`LOOKBACK` seconds before the contact, or where the person it touched was first seen
walking if that is later (no planner knows before where a standing person will go), and tries
every sequence of commands the simulator could have executed: each step changes the speed and
the turn rate by ``-max``, 0 or ``+max`` (the robot's acceleration limits over one plan
period), holds them for the simulator's step along the exact arc, and keeps only states whose
footprint touches no pedestrian (at their logged positions) and no map cell at any logged time
up to and including the contact, then for :data:`HOLD` more seconds against the people walking
on at their last logged velocity (the log ends at the contact). States closer than
:data:`CELL` (and :data:`HEADING_CELL`) with the same commands are merged, so the search is
exhaustive over those commands until :data:`MAX_STATES` would be exceeded (then a seeded
subset goes on, and the answer says it was not exhaustive).

It is valid only where the pedestrians do not react to the robot (CrowdNav's invisible robot,
the ETH/UCY replays, the built-in scenarios): their logged paths are then what they would have
walked whatever the robot did. "No escape" with a reverse as fast as the forward speed limit
means no planner with this robot's limits could have avoided the contact from that state (to
the resolution of the search); an escape found only with a faster reverse than the planner has
says what the contact would have needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from ..core.world import World
from ..sim.metrics import run_length

LOOKBACK = 2.0
"""s: the search starts this long before the contact: braking from 1 m/s takes 0.67 s and a
half turn at 1.5 rad/s 2.1 s, so 2 s lets every way out begin."""
HOLD = 1.0
"""s: after the contact the way must stay clear this long against people walking on at their
last velocity: clear only at the contact's instant, a robot is struck a step later."""
CELL = 0.02
"""m: two states nearer than this (with headings within HEADING_CELL and the same commands)
are one; far below the 0.3 m bodies and the 0.25 m a walker moves per step."""
HEADING_CELL = 0.03
"""rad: the heading's merge width (3 cm sideways at 1 m)."""
WALKING = 0.1
"""m/s: the touched person counts as walking above this (the failure classifier's standing
speed); the search starts no earlier than the first state they walked in."""
MAX_STATES = 100_000
"""States kept per step; beyond it a seeded subset goes on and the search is not exhaustive."""


@dataclass(frozen=True)
class Escape:
    """The answer of :func:`search`: ``found`` a collision-free way from ``start`` (s) through
    ``contact`` (s) and :data:`HOLD` beyond, with reverses up to ``reverse`` m/s;
    ``exhaustive`` when no step's states were cut to :data:`MAX_STATES`; ``states`` the
    largest number kept at one step."""

    start: float
    contact: float
    reverse: float
    found: bool
    exhaustive: bool
    states: int


def reacting_people(episode) -> bool:
    """True where the episode's pedestrians react to the robot (CrowdNav's visible robot):
    their logged paths are then not what they would have walked, and :func:`search` does not
    apply."""
    return "-visible-" in str(episode.meta.get("scenario", ""))


def search(episode, robot: int = 0, reverse: float = math.inf, lookback: float = LOOKBACK,
           seed: int = 0) -> Escape:
    """Search the robot's commands for a collision-free way past the contact that ended
    ``robot``'s run (module docstring). ``reverse`` caps the backward speed (m/s; inf: the
    forward speed limit, 0: forward only).

    Raises
    ------
    InputError
        When the run did not end in a collision, the episode has other robots (they react), or
        its pedestrians react to the robot (:func:`reacting_people`).
    """
    if episode.outcomes[robot] != "collision":
        raise InputError(f"robot {robot}: outcome {episode.outcomes[robot]}, not a collision")
    if episode.n_robots != 1:
        raise InputError("escape search: single-robot episodes only (other robots react)")
    if reacting_people(episode):
        raise InputError("escape search: the pedestrians of this run react to the robot; "
                         "their logged paths are not what they would have walked")
    config = episode.meta.get("config") or {}
    limits = {**{"v_limit": 1.0, "omega_limit": 1.5, "accel_limit": 1.5, "alpha_limit": 3.0},
              **{k: float(v) for k, v in (config.get("robot") or {}).items()
                 if k in ("v_limit", "omega_limit", "accel_limit", "alpha_limit")}}
    period = float((config.get("horizon") or {}).get("dt", 0.2))
    times = episode.times
    contact = run_length(episode, robot) - 1
    step = float(times[1] - times[0])
    first = max(0, contact - int(round(lookback / step)), _walking_since(episode, robot, contact))
    back = min(float(reverse), limits["v_limit"])
    dv = limits["accel_limit"] * period * np.array([-1.0, 0.0, 1.0])
    dw = limits["alpha_limit"] * period * np.array([-1.0, 0.0, 1.0])
    fp = episode.footprint(robot)
    world = World(episode.grid) if episode.grid is not None else None
    rng = np.random.default_rng(seed)
    states = episode.states[robot, first][None].astype(float)
    exhaustive, largest = True, 1
    held = int(round(HOLD / step))
    people = np.concatenate([episode.ped_positions[:contact + 1],
                             episode.ped_positions[contact][None]
                             + episode.ped_velocities[contact][None]
                             * (step * np.arange(1, held + 1))[:, None, None]])
    for k in range(first, contact + held):
        v = np.clip(states[:, 3, None, None] + dv[None, :, None], -back, limits["v_limit"])
        w = np.clip(states[:, 4, None, None] + dw[None, None, :], -limits["omega_limit"],
                    limits["omega_limit"])
        shape = (len(states), 3, 3)
        v, w = np.broadcast_to(v, shape).reshape(-1), np.broadcast_to(w, shape).reshape(-1)
        pose = np.repeat(states[:, :3], 9, axis=0)
        half = w * step / 2.0
        chord = v * step * np.sinc(half / np.pi)
        heading = pose[:, 2] + half
        nxt = np.column_stack([pose[:, 0] + chord * np.cos(heading),
                               pose[:, 1] + chord * np.sin(heading), pose[:, 2] + w * step, v, w])
        nxt = nxt[_clear(nxt, fp, people[k + 1], episode.ped_radii, world)]
        if not len(nxt):
            return Escape(float(times[first]), float(times[contact]), back, False, exhaustive,
                          largest)
        keys = np.column_stack([np.round(nxt[:, :2] / CELL),
                                np.round(np.angle(np.exp(1j * nxt[:, 2])) / HEADING_CELL),
                                np.round(nxt[:, 3:] * 1e6)])
        states = nxt[np.unique(keys, axis=0, return_index=True)[1]]
        if len(states) > MAX_STATES:
            states, exhaustive = states[rng.choice(len(states), MAX_STATES, replace=False)], False
        largest = max(largest, len(states))
    return Escape(float(times[first]), float(times[contact]), back, True, exhaustive, largest)


def _walking_since(episode, robot, contact) -> int:
    """The first state at which the person touched at ``contact`` was walking (logged speed
    above :data:`WALKING`): before it no planner could know where they would go (CrowdNav's
    humans stand at the start and set off in the first step)."""
    if not len(episode.ped_radii):
        return 0
    fp = episode.footprint(robot)
    x, y, phi = episode.states[robot, contact, :3]
    c, s = np.cos(phi), np.sin(phi)
    centres = np.column_stack([x + c * fp[:, 0] - s * fp[:, 1], y + s * fp[:, 0] + c * fp[:, 1]])
    gaps = (np.linalg.norm(episode.ped_positions[contact][None] - centres[:, None], axis=-1)
            - fp[:, 2, None] - episode.ped_radii[None])
    person = int(np.argmin(gaps.min(axis=0)))
    walking = np.flatnonzero(np.linalg.norm(episode.ped_velocities[:contact + 1, person], axis=-1)
                             > WALKING)
    return int(walking[0]) if walking.size else contact


def _clear(states, fp, people, radii, world) -> np.ndarray:
    """Which of ``states`` (n, 5) keep every footprint circle off every person and the map."""
    c, s = np.cos(states[:, 2]), np.sin(states[:, 2])
    px = states[:, None, 0] + c[:, None] * fp[None, :, 0] - s[:, None] * fp[None, :, 1]
    py = states[:, None, 1] + s[:, None] * fp[None, :, 0] + c[:, None] * fp[None, :, 1]
    ok = np.ones(len(states), dtype=bool)
    if len(radii):
        d = np.hypot(px[..., None] - people[None, None, :, 0],
                      py[..., None] - people[None, None, :, 1])
        ok &= np.all(d - fp[None, :, 2, None] - radii[None, None, :] >= 0.0, axis=(1, 2))
    if world is not None:
        points = np.stack([px, py], axis=-1).reshape(-1, 2)
        gap = world.static_distance(points).reshape(px.shape) - fp[None, :, 2]
        ok &= np.all(gap >= 0.0, axis=1)
    return ok


def escapes(episode, robot: int = 0) -> dict:
    """Evidence for the failure report: is there a way out forward only (the control law's
    own motions), with the run's back-up rung's reverse (``stall.back_up`` of its
    configuration, when above 0), with a reverse as
    fast as the speed limit? A way out of a tier is one of every wider tier (a robot allowed to
    reverse can drive the same commands), so the search stops at the first tier that finds one.
    ``escape`` is the narrowest tier with a way out, ``none`` or ``not searched: why``."""
    rung = float(((episode.meta.get("config") or {}).get("stall") or {}).get("back_up", 0.0))
    tiers = [("forward", 0.0)] + ([("rung", rung)] if rung > 0.0 else []) + [("full", math.inf)]
    evidence = {}
    for name, reverse in tiers:
        try:
            found = search(episode, robot, reverse)
        except InputError as exc:
            return {"escape": f"not searched: {exc}"}
        evidence.update(escape_from=found.start,
                        escape_exhaustive=evidence.get("escape_exhaustive", True)
                        and found.exhaustive)
        if found.found:
            return {"escape": name, **evidence}
    return {"escape": "none", **evidence}
