"""Why a run failed: a deterministic classification of one robot's logged episode.

:func:`classify` reads an :class:`~dsmpepc_nlp.sim.episode.Episode` (nothing is re-run) and
returns a :class:`FailureClass`: the class's name, the cycle to look at and the numbers the
rules used. The rules, in the order they are tried (the first that holds names the class):

``not-perceived``
    Under a sensing profile (``meta["perception"]``), a collision with something that was not
    in the world the robot believed at its last plan: a map cell never marked there, or a
    person with no track within half a metre (:meth:`~dsmpepc_nlp.sim.senses.Senses.perceived`).
    A failure of perception, not of planning.
``appeared-in-reach``
    The outcome is a collision with a pedestrian whose track began (who came on stage from
    ``OFFSTAGE``, in the ETH/UCY replays: where the annotation starts) less than
    :data:`~dsmpepc_nlp.bench.crowd_rows.APPEARED` (1 s) before the contact: braking from
    1 m/s alone takes 0.67 s, and a plan sees a newcomer a cycle late. The benchmark still
    counts the collision (at fault or struck, as the evidence says).
``at-fault``, ``struck-moving``, ``struck-stopped``
    Any other collision. :func:`~dsmpepc_nlp.sim.metrics.collision_kind` says
    ``at-fault`` (the robot moved toward what it touched faster than
    :data:`~dsmpepc_nlp.sim.metrics.AT_FAULT_SPEED`) or ``struck``; a struck robot is
    ``struck-moving`` when a footprint circle moved faster than :data:`STOPPED_SPEED` over the
    last step, else ``struck-stopped``.
``goal-occupied``
    Not a collision, and over the whole last :data:`STUCK_WINDOW` of the run a pedestrian
    stood where the robot would have to be to arrive: its body overlaps every point within the
    goal tolerance, for what the footprint covers at any heading
    (:func:`~dsmpepc_nlp.bench.crowd_rows.goal_covered`: ``|person - goal| + tolerance <
    r_person + core``). No planner can arrive while it stands there (in ETH/UCY's zara2,
    goals drawn where people walked fall on people who stand talking for minutes).
``slow`` / ``wandering``
    Not a collision, not ``goal-occupied`` and not stuck: over the last
    :data:`STUCK_WINDOW` of the run the robot got the stuck limit ``STUCK_SHARE * v_limit *
    window`` or farther (``slow``: the time ran out while it still made way; ``wandering``:
    the deadlock rule fired though it kept moving).
``oscillating``
    Stuck, but moving back and forth: a path of :data:`OSCILLATION_SHARE` times the stuck
    limit or more over the window, or :data:`OSCILLATION_REVERSALS` or more sign changes of v
    or omega.
``stalled-near-goal-person``, ``stalled-beside-person``
    Stuck and standing, with a pedestrian standing (mean speed below :data:`STANDING_SPEED`
    over the last :data:`STANDING_WINDOW`) within :data:`PERSON_GAP` of the footprint; near the
    goal (within the run's ``docking.radius``, IROS 2012's 2 m, not the horizon's reach the
    product docks from) or not.
``stalled-in-gap``
    Stuck and standing where the map is narrow: the narrowest chord through the robot's
    centre, or through a point up to :data:`GAP_LOOKAHEAD` ahead along the navigation
    function, is shorter than the robot's width plus ``2 *`` :data:`GAP_MARGIN`.
``stalled-near-goal``, ``stalled-open``
    Stuck and standing, with neither cause: within ``docking.radius`` of the goal or not.

Every threshold below is a named constant with the reason for its value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError
from ..core.geometry import footprint_points
from ..core.world import World
from ..sim.metrics import collision_kind, contact_approach_speed, run_length
from ..sim.outcomes import OutcomeConfig
from .crowd_rows import APPEARED, contact_age, footprint_core, goal_covered, off_stage

CLASSES = ("not-perceived", "appeared-in-reach", "at-fault", "struck-moving", "struck-stopped",
           "goal-occupied", "stalled-near-goal-person", "stalled-beside-person",
           "stalled-in-gap", "stalled-near-goal", "stalled-open", "oscillating", "wandering",
           "slow")
"""Every class :func:`classify` returns, in the order of the module docstring's rules."""

STOPPED_SPEED = 0.05
"""m/s: below this a footprint circle moves under 1 cm per 0.2 s cycle: stopped by any reading."""
STUCK_WINDOW = OutcomeConfig().deadlock_window
"""s: the stuck window, the deadlock rule's own."""
STUCK_SHARE = 0.1
"""Stuck: a net displacement over the window under this share of what the speed limit allows
(1 m in 10 s at 1 m/s); a robot making a tenth of its possible way is not merely slow."""
OSCILLATION_SHARE = 2.0
"""Oscillating: a stuck robot whose path over the window is this many times the stuck limit
(it drove twice as far as it could have got while stuck): it went back and forth."""
OSCILLATION_REVERSALS = 6
"""Sign changes of v or omega over the window: three back-and-forth swings in 10 s."""
REVERSAL_V, REVERSAL_OMEGA = 0.02, 0.05
"""m/s, rad/s: smaller |v|, |omega| are noise about zero, not a direction (not counted)."""
STANDING_SPEED = 0.1
"""m/s: walking people move at 0.5-1.5 m/s; under a tenth of that a person is standing."""
STANDING_WINDOW = 2.0
"""s: the person's speed is averaged over this, so a pause between two steps is not standing."""
PERSON_GAP = 1.0
"""m (gap footprint to person): within this a person is in the robot's way at 1 m/s and 1 s."""
GAP_MARGIN = 0.2
"""m per side: 2 sigma_static (CostConfig, 0.1 m): nearer on both sides, the collision bell
weighs on every way through."""
GAP_RANGE = 2.0
"""m: rays for the chord stop here; wider than this on a side is open ground, not a gap."""
GAP_DIRECTIONS = 36
"""Chord directions over 180 degrees (5 degrees apart)."""
GAP_LOOKAHEAD = 0.75
"""m: a robot stalled at a gap's mouth has the gap just ahead along its path: look this far."""


@dataclass(frozen=True)
class FailureClass:
    """One robot's failure: its class, the cycle to look at and the evidence (numbers).

    ``cycle`` is the planning cycle the failure is seen in (the last before contact, or the
    last the robot planned in while stuck), ``time`` its time (s); ``evidence`` is JSON-able.
    """

    name: str
    outcome: str
    robot: int
    cycle: int
    time: float
    evidence: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"class": self.name, "outcome": self.outcome, "robot": self.robot,
                "cycle": self.cycle, "time": self.time, "evidence": dict(self.evidence)}


def classify(episode, robot: int = 0) -> FailureClass:
    """The :class:`FailureClass` of robot ``robot`` of ``episode`` (module docstring's rules).

    Raises
    ------
    InputError
        When ``robot`` is not a robot of the episode or its outcome is a success.
    """
    if not 0 <= robot < episode.n_robots:
        raise InputError(f"robot {robot}: the episode has {episode.n_robots} robot(s)")
    outcome = episode.outcomes[robot]
    if outcome == "success":
        raise InputError(f"robot {robot} ({episode.meta['robots'][robot]}): outcome success, "
                         "nothing to classify")
    stop = run_length(episode, robot)
    cycle = _last_cycle(episode, robot, stop)
    time = float(episode.times[cycle])
    if outcome == "collision":
        name, evidence = _collision(episode, robot, stop)
    else:
        name, evidence = _stuck(episode, robot, stop, outcome)
    return FailureClass(name, outcome, robot, cycle, time, _clean(evidence))


def _last_cycle(episode, robot, stop) -> int:
    """The last cycle before the outcome state in which the robot planned (0 if none)."""
    planned = np.flatnonzero(episode.active[robot, :max(stop - 1, 0)])
    return int(planned[-1]) if planned.size else 0


def _collision(episode, robot, stop) -> tuple:
    k = stop - 1
    fp = episode.footprint(robot)
    here = footprint_points(episode.states[robot, k, :3], fp[:, :2])
    if k > 0:
        before = footprint_points(episode.states[robot, k - 1, :3], fp[:, :2])
        speed = float(np.max(np.linalg.norm(here - before, axis=-1))
                      / (episode.times[k] - episode.times[k - 1]))
    else:
        speed = abs(float(episode.states[robot, 0, 3]))
    kind = collision_kind(episode, robot)
    evidence = {"collision_kind": kind, "contact_time": float(episode.times[k]),
                "robot_speed": speed, "stopped_speed": STOPPED_SPEED,
                "approach_speed": contact_approach_speed(episode, robot),
                **_touched(episode, robot, k), **_appeared(episode, robot)}
    perceived = (episode.meta.get("perception") or [None] * episode.n_robots)[robot]
    if perceived is not None:
        evidence["perceived_touched"] = ",".join(perceived["touched"])
        if not perceived["believed"]:
            return "not-perceived", evidence
    if evidence.get("contact_age", math.inf) < APPEARED:
        return "appeared-in-reach", evidence
    if kind == "at-fault":
        return "at-fault", evidence
    return ("struck-moving" if speed > STOPPED_SPEED else "struck-stopped"), evidence


def _touched(episode, robot, k) -> dict:
    """What lies nearest the footprint at state ``k``: ``touched`` (map / pedestrian / other),
    its gap (m) and, for a pedestrian, its index, speed and ``start_gap``: the gap (m) between
    them at the run's first state, when the pedestrian was on stage then."""
    fp = episode.footprint(robot)
    points = footprint_points(episode.states[robot, k, :3], fp[:, :2])
    best = {"touched": "nothing", "touched_gap": math.inf}
    if episode.grid is not None:
        gap = float(np.min(World(episode.grid).static_distance(points) - fp[:, 2]))
        best = {"touched": "map", "touched_gap": gap}
    if episode.ped_radii.size:
        gaps = _pedestrian_gaps(episode, robot, k)
        j = int(np.argmin(gaps))
        if gaps[j] < best["touched_gap"]:
            best = {"touched": "pedestrian", "touched_gap": float(gaps[j]), "pedestrian": j,
                    "pedestrian_speed": float(np.linalg.norm(episode.ped_velocities[k, j])),
                    **_start_gap(episode, robot, j)}
    if best["touched_gap"] > 0.05 and episode.n_robots + len(episode.meta.get("parked", [])) > 1:
        best["touched"] = "other"  # nothing of the map or the people touches: a robot did
    return best


def _pedestrian_gaps(episode, robot, k) -> np.ndarray:
    """m, per pedestrian: the gap between the robot's footprint circles and their body at
    state ``k``."""
    fp = episode.footprint(robot)
    points = footprint_points(episode.states[robot, k, :3], fp[:, :2])
    d = np.linalg.norm(points[:, None, :] - episode.ped_positions[k][None], axis=-1)
    return (d - fp[:, 2][:, None] - episode.ped_radii[None]).min(axis=0)


def _start_gap(episode, robot, j) -> dict:
    """``start_gap``: the gap (m) between the robot's footprint and pedestrian ``j`` at the
    run's first state; {} when the pedestrian was not on stage then (a replay parks a person
    whose track begins later: :func:`~dsmpepc_nlp.bench.crowd_rows.off_stage`)."""
    if off_stage(episode.ped_positions[0, j]):
        return {}
    gap = float(_pedestrian_gaps(episode, robot, 0)[j])
    return {"start_gap": gap} if math.isfinite(gap) else {}


def _stuck(episode, robot, stop, outcome) -> tuple:
    dt = float(episode.times[1] - episode.times[0]) if episode.times.size > 1 else 1.0
    first = max(0, stop - 1 - int(round(STUCK_WINDOW / dt)))
    states = episode.states[robot, first:stop]
    xy = states[:, :2]
    net = float(np.linalg.norm(xy[-1] - xy[0]))
    path = float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=-1)))
    reversals = _reversals(states[:, 3], REVERSAL_V) + _reversals(states[:, 4], REVERSAL_OMEGA)
    goal = episode.goals[robot, stop - 1]
    goal_distance = float(np.linalg.norm(xy[-1] - goal))
    docking, v_limit = _from_config(episode, "docking", "radius", 2.0), \
        _from_config(episode, "robot", "v_limit", 1.0)
    window = float(episode.times[stop - 1] - episode.times[first])
    limit = STUCK_SHARE * v_limit * window
    evidence = {"window": window, "net_displacement": net, "stuck_limit": limit,
                "path_in_window": path, "reversals": reversals,
                "goal_distance": goal_distance, "docking_radius": docking,
                **_person(episode, robot, stop - 1), **_gap(episode, robot, stop - 1)}
    occupied = _goal_occupied(episode, robot, first, stop)
    evidence.update(occupied)
    if occupied and occupied["goal_occupied_share"] == 1.0:
        return "goal-occupied", evidence
    if net >= limit:
        return ("wandering" if outcome == "deadlock" else "slow"), evidence
    if path >= OSCILLATION_SHARE * limit or reversals >= OSCILLATION_REVERSALS:
        return "oscillating", evidence
    near = goal_distance <= docking
    if evidence.get("person_gap", math.inf) <= PERSON_GAP:
        return ("stalled-near-goal-person" if near else "stalled-beside-person"), evidence
    if evidence.get("in_gap"):
        return "stalled-in-gap", evidence
    return ("stalled-near-goal" if near else "stalled-open"), evidence


def _reversals(values, noise) -> int:
    """Sign changes of ``values``, ignoring those within ``noise`` of zero."""
    signs = np.sign(values[np.abs(values) > noise])
    return int(np.sum(signs[1:] != signs[:-1]))


def _from_config(episode, part: str, name: str, default: float) -> float:
    """A number of the run's planner configuration (``meta["config"][part][name]``), or the
    configuration's ``default`` when the episode does not say."""
    try:
        return float(episode.meta["config"][part][name])
    except (KeyError, TypeError, ValueError):
        return default


def _appeared(episode, robot) -> dict:
    """``contact_age``: how long (s) the touched pedestrian had been on stage, the crowd
    benchmark's own :func:`~dsmpepc_nlp.bench.crowd_rows.contact_age` (inf for one on stage
    from the run's first state: present all along, it did not appear), beside the threshold
    ``appeared_within`` (:data:`~dsmpepc_nlp.bench.crowd_rows.APPEARED`); {} without one."""
    age = contact_age(episode, robot)
    if not math.isfinite(age):
        return {}
    dt = float(episode.times[1] - episode.times[0]) if episode.times.size > 1 else 0.0
    if age >= float(episode.outcome_times[robot]) - dt - 1e-9:
        age = math.inf
    return {"contact_age": age, "appeared_within": APPEARED}


def _goal_occupied(episode, robot, first, stop) -> dict:
    """Over states ``first .. stop - 1``: the share of them in which a pedestrian's body
    covers every point within the goal tolerance for the footprint's core
    (``goal_occupied_share``), and at the last of them the nearest pedestrian to the goal
    (``goal_person``, ``goal_person_distance`` m, centre to goal); {} without pedestrians."""
    if not episode.ped_radii.size:
        return {}
    tolerance = float(episode.meta.get("goal_tolerances", [0.0] * (robot + 1))[robot])
    core = footprint_core(episode.footprint(robot))
    goals = episode.goals[robot, first:stop]
    d = np.linalg.norm(episode.ped_positions[first:stop] - goals[:, None, :], axis=-1)
    covered = goal_covered(d, episode.ped_radii[None], tolerance, core)
    j = int(np.argmin(d[-1]))
    return {"goal_occupied_share": float(np.mean(covered)), "goal_person": j,
            "goal_person_distance": float(d[-1, j])}


def _person(episode, robot, k) -> dict:
    """The nearest standing pedestrian at state ``k``: ``person`` index, ``person_gap`` (m,
    footprint to body) and ``person_speed`` (m/s, mean over STANDING_WINDOW); {} if none."""
    if not episode.ped_radii.size:
        return {}
    dt = float(episode.times[1] - episode.times[0]) if episode.times.size > 1 else 1.0
    first = max(0, k - int(round(STANDING_WINDOW / dt)))
    speeds = np.linalg.norm(episode.ped_velocities[first:k + 1], axis=-1).mean(axis=0)
    fp = episode.footprint(robot)
    points = footprint_points(episode.states[robot, k, :3], fp[:, :2])
    d = np.linalg.norm(points[:, None, :] - episode.ped_positions[k][None], axis=-1)
    gaps = np.where(speeds < STANDING_SPEED,
                    (d - fp[:, 2][:, None] - episode.ped_radii[None]).min(axis=0), np.inf)
    j = int(np.argmin(gaps))
    if not math.isfinite(gaps[j]):
        return {}
    return {"person": j, "person_gap": float(gaps[j]), "person_speed": float(speeds[j])}


def robot_width(footprint) -> float:
    """Width of a footprint across its body (m): twice the largest ``|cy| + r``."""
    fp = np.asarray(footprint, dtype=float)
    return float(2 * np.max(np.abs(fp[:, 1]) + fp[:, 2]))


def chord(world: World, point) -> tuple:
    """The narrowest free chord through ``point``: its length (m), direction (rad, in
    [0, pi)) and two ends (m): over :data:`GAP_DIRECTIONS` directions the sum of the free travel
    both ways (rays stop at :data:`GAP_RANGE`, so open ground reads inf)."""
    angles = np.arange(GAP_DIRECTIONS) * math.pi / GAP_DIRECTIONS
    origins = np.broadcast_to(np.asarray(point, dtype=float), (2 * GAP_DIRECTIONS, 2))
    rays = world.static_ray_distance(origins, np.concatenate([angles, angles + math.pi]), 0.0,
                                     GAP_RANGE)
    chords = rays[:GAP_DIRECTIONS] + rays[GAP_DIRECTIONS:]
    i = int(np.argmin(chords))
    u = np.array([math.cos(angles[i]), math.sin(angles[i])])
    ends = [origins[0] + min(rays[i], GAP_RANGE) * u,
            origins[0] - min(rays[GAP_DIRECTIONS + i], GAP_RANGE) * u]
    return float(chords[i]), float(angles[i]), [[float(v) for v in e] for e in ends]


def _gap(episode, robot, k) -> dict:
    """The narrowest chord at the robot (and up to GAP_LOOKAHEAD ahead along the navigation
    function toward a fixed goal): ``gap_width``, ``gap_ahead`` (m from the robot),
    ``robot_width``, ``gap_limit`` and ``in_gap``; {} without a map."""
    grid = episode.grid
    if grid is None:
        return {}
    world = World(grid)
    here = episode.states[robot, k, :2].astype(float)
    probes, ahead = [here], [0.0]
    if episode.meta["goal_kinds"][robot] == "fixed":
        fp = episode.footprint(robot)
        nav = world.navigation(episode.goals[robot, k], float(np.max(fp[:, 2])))
        point = here
        for step in (0.25, 0.5, 0.75):
            g = np.asarray(nav.gradient(point[None]), dtype=float).reshape(-1)[:2]
            norm = float(np.hypot(*g))
            if not math.isfinite(norm) or norm < 1e-9 or step > GAP_LOOKAHEAD:
                break
            point = point - 0.25 * g / norm
            probes.append(point)
            ahead.append(step)
    found = [chord(world, p) for p in probes]
    i = int(np.argmin([c[0] for c in found]))
    width = robot_width(episode.footprint(robot))
    limit = width + 2 * GAP_MARGIN
    return {"gap_width": found[i][0], "gap_direction": found[i][1], "gap_ends": found[i][2],
            "gap_ahead": ahead[i],
            "gap_point": [float(v) for v in probes[i]], "robot_width": width,
            "gap_limit": limit, "in_gap": bool(found[i][0] < limit)}


def _clean(evidence: dict) -> dict:
    """JSON-able evidence: numpy scalars as Python numbers (inf kept; JSON writing cleans it)."""
    out = {}
    for key, value in evidence.items():
        if isinstance(value, np.generic):
            value = value.item()
        out[key] = value
    return out
