"""The closed loop's configuration: docking at a fixed goal and the stall monitor with its
back-up rung (our extensions, docs/method.md sections 7.1 and 7.5; :class:`PlannerConfig`
holds them as ``docking`` and ``stall``, and :mod:`.config` re-exports both)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .validation import check_booleans, check_integers, validate_fields


@dataclass(frozen=True)
class DockingConfig:
    """Docking near a fixed goal (IROS 2012, docs/method.md section 7.1)."""

    radius: float = 2.0
    """Within this distance of a fixed goal the target pose is the goal itself, m (IROS 2012);
    see ``radius_from_reach``."""
    radius_from_reach: bool = True
    """Our extension (off in :meth:`PlannerConfig.paper`): dock within the horizon's reach,
    ``v_limit * n_steps * dt`` (5 m by default), or ``radius`` if that is larger. Once the goal
    is within reach, every trajectory that arrives by the horizon's end earns the same
    progress, and the action cost then prefers the slowest of them: a robot that does not
    dock slows down to arrive just as the horizon ends (docs/method.md section 7.1)."""
    min_survival: float = 0.9
    """Dock only while the docking trajectory's survivability is above this (our choice)."""
    arrival_radius: float = 0.1
    """Our extension (0 in :meth:`PlannerConfig.paper`): the docking trajectory's survivability
    is read where it first comes within this distance of the goal, m, not at the horizon's end.
    Standing at the goal after arriving is the next task's risk, and counting it kept robots
    short of a goal with a person standing beside it (docs/method.md section 7.1). 0: read at
    the horizon's end."""
    follow: bool = True
    """Our extension (off in :meth:`PlannerConfig.paper`): dock at a goal that moves (a
    followed person's point, ``FollowGoal``) as at a fixed one. The planner sees each cycle's
    goal standing still, so a goal that walks on stays within reach, every arriving trajectory
    earns the same progress and the action cost picks the slowest: the hall's follower trailed
    3-3.5 m behind its goal and lost its person in the crowd. Docking heads for the goal at the
    speed limit, slowed only by the law's ramp (docs/method.md section 7.1)."""

    turn_in_place: float = math.pi / 4
    """Our extension, rad (0: off, as in :meth:`PlannerConfig.paper`): a robot whose heading is
    more than this off the line to the goal it docks at first turns in place toward it (a
    differential drive can; the law turns only along its curve and slows with the curvature,
    so near a goal behind it the robot crawled round in a wide arc until the deadlock rule
    ended the run: ETH/UCY's 'wandering' class). Docking's survivability test judges the turn
    and the approach together. pi/4 is the angle at which Nav2's rotation shim controller
    turns a robot in place before its path follower takes over (docs/method.md section 7.1).
    On by default: it won on the tuning episodes
    (docs/experiments/2026-11-27-turning-in-place-to-dock.md)."""

    region_points: int = 8
    """Our extension, a count (0: off, as in :meth:`PlannerConfig.paper`): when the straight
    trajectory to the goal point fails the survivability test within ``radius`` (IROS 2012's
    2 m, the last metres, not the horizon's reach), try docking at this many points evenly
    round the circle of radius ``goal_tolerance - arrival_radius`` about the goal (the first
    the nearest to the robot), each judged by the same test, and take the one of lowest exact
    cost that passes. ``goal_tolerance`` is the task's (``Planner.plan``'s argument: how near
    the goal counts as arrived); the robot is judged by it, so any point that near is its goal,
    and a person standing beside the goal point need not keep it off the rest. 8 points put
    neighbours 0.15 m apart on the 0.2 m circle of a 0.3 m tolerance, under a person's
    radius (docs/method.md section 7.1). On by default: it won on the tuning episodes
    (docs/experiments/2026-11-28-docking-within-the-goals-region.md)."""
    region_turns: bool = True
    """With ``region_points``: whether a point of the goal's region that lies more than
    ``turn_in_place`` off the heading may be docked at (after a turn in place toward it). A
    region point is tried only when the goal point failed, that is with somebody near the goal,
    and a turn in place holds the robot still for 0.5-2 s among them; False tries only
    the region points the robot can head to straight (docs/method.md section 7.1). Left on:
    on the tuning episodes False changed no run
    (docs/experiments/2026-11-28-region-points-behind-a-turn.md)."""
    arrival_at_tolerance: bool = True
    """Our extension (off in :meth:`PlannerConfig.paper`): with a ``goal_tolerance`` larger
    than ``arrival_radius``, read a docking trajectory's survivability where it first comes
    within that tolerance of the goal (the goal point's and each region point's alike): the
    task ends there, as the simulator judges a fixed goal, so the rest of the way to the point
    is the next task's risk, the reason ``arrival_radius`` is read at all. With a person
    standing beside the goal the last 0.2 m are the riskiest of the way (docs/method.md
    section 7.1). On by default: it won on the tuning episodes
    (docs/experiments/2026-11-28-docking-arrival-at-tolerance.md)."""

    def __post_init__(self):
        check_integers(self, {"region_points": 0})
        validate_fields(self, {"radius": dict(low=0.0), "min_survival": dict(low=0.0, high=1.0),
                                "arrival_radius": dict(low=0.0),
                                "turn_in_place": dict(low=0.0, high=math.pi)})
        check_booleans(self, ("radius_from_reach", "follow", "region_turns",
                              "arrival_at_tolerance"))


@dataclass(frozen=True)
class StallConfig:
    """The planner's stall monitor and its escalation ladder (our extension, docs/method.md
    section 7.5; off in :meth:`PlannerConfig.paper`).

    A robot that moved less than ``min_displacement`` (or came less than ``min_progress``
    nearer its goal) over its last ``window`` of plans while farther than
    ``docking.arrival_radius`` from its goal is stalled; each such window raises
    the ladder one level, up to ``levels``, and level ``k`` plans with the progress weight
    times ``gain ** k``: progress is worth more of the risk the cost weighs it against. A
    window with progress puts the ladder back to 0. The simulator's deadlock rule does not
    know of it: a robot the ladder cannot free still deadlocks.
    """

    window: float = 2.0
    """Stall window, s, counted in plans of ``horizon.dt`` each (our choice: a fifth of the
    simulator's 10 s deadlock window, so the ladder's levels come well before it)."""
    min_displacement: float = 0.2
    """Least net displacement over the window, m, of a robot that is not stalled: 1 m in
    10 s, ten times the simulator's deadlock rule (0.1 m of progress in 10 s), so a robot
    far slower than a walk escalates long before the rule fires (our choice)."""
    min_progress: float = 0.2
    """Least progress toward the goal over the window, m, of a robot that is not stalled; 0
    turns the test off. Progress is the fall of the straight-line distance to the goal as it
    is now, from the window's first position to its last (a goal that moves with the robot,
    a follower's, is progress). The simulator's deadlock rule measures progress, not motion:
    a robot circling people at its goal, or pushed back by a crowd walking at it, moves more
    than ``min_displacement`` in every window, so without this test it never climbs the
    ladder before the rule fires. 0.2 m, ``min_displacement``'s rate (ours). On by default:
    it won 4 tuning runs and lost 1, and most that arrived either way arrived sooner
    (docs/experiments/2026-11-29-stall-progress-test.md)."""
    levels: int = 3
    """The ladder's highest level; 0 turns the monitor off."""
    gain: float = 2.0
    """Level ``k`` multiplies the progress weight by ``gain ** k``."""
    back_up: float = 0.3
    """The back-up rung's speed, m/s; 0 turns it off. From ``back_up_level`` of the ladder on,
    a plan that would stand (less than ``min_displacement`` over the horizon) is set against
    reverse trajectories at this speed (straight back, and curving back either way at a 1 m
    radius) for ``back_up_time``, then braking; the exact cost takes the cheapest if it is
    cheaper than the plan. The pose-following law turns only while it drives forward, so a
    robot facing a person just ahead has no way out of its own
    (docs/experiments/2026-11-25-two-more-failure-classes.md; ours, as Nav2's back-up).
    0.3 m/s is what one plan period's braking takes back (``accel_limit * dt``, the cap). On
    by default: it won on the tuning episodes (docs/experiments/2026-11-25-back-up-rung.md)."""
    back_up_time: float = 1.0
    """How long the back-up rung reverses before braking, s (our choice: five plans)."""
    back_up_level: int = 1
    """The ladder's level from which the back-up rung acts: 1, once stalled for a window (the
    stall monitor does not count a robot at its goal); 0, on any plan that would stand, which
    also backed robots away from a goal they stood at
    (docs/experiments/2026-11-25-back-up-rung.md: measured, not taken).
    The rung acts only with the ladder on (``levels`` > 0)."""
    back_up_threat: float = 0.5
    """Below ``back_up_level`` too, the rung acts on a plan that would stand where the robot
    expects to be struck: its survival to the horizon's end (the exact cost's ``p^s_N``; a
    docked plan's where the task ends, ``threat_until_arrival``) is below this; 0 turns it
    off. A person walking at a standing robot (CrowdNav's invisible robot, a replayed crowd)
    makes every forward way out cost as much as the wait, since the law cannot turn without
    first closing the gap; a reverse can open it. 0.5, "more likely
    struck than not", was set before any run (ours). On by default: it won on the tuning
    episodes (docs/experiments/2026-11-25-threat-gate-and-speed-ramp.md)."""

    dodge: bool = True
    """With the rung on (``back_up`` > 0), a plan the robot expects to be struck on (its
    survival to the horizon's end below ``back_up_threat``), standing or not, also meets
    forward dodges the law cannot make: a turn at the full turn rate either way, for up to
    1.4 s and at a standstill, half or full speed, then straight ahead at half or full speed
    (``backup.dodge_trajectories``); the exact cost takes the cheapest if it is cheaper than
    the plan. The law turns only by driving forward along its curve, so a person walking at
    the robot's side leaves it no way out of its own; a failure search of CrowdNav's square
    crossing (``dsmpepc failures --escape``) found a forward way out of most of its
    collisions (ours; docs/method.md section 7.5). On by default: it won on the tuning
    episodes (docs/experiments/2026-11-25-dodges-follower-escape-search.md)."""
    dodge_within: float = 5.0
    """s: the dodges answer a blow expected this soon, where the plan's survival at this time
    (the first step at or after it; the horizon's end when it is longer) is below
    ``back_up_threat``; the reverse keeps the horizon's end. 5 s, the default horizon: any
    threat the gate sees. 1 s is about the time a dodge takes to turn a quarter turn at the
    full turn rate: a blow further off is one the law's own plans can still steer around,
    and a dodge taken against it can turn the robot away from its way (the built-in hall's
    follower, MPEPC, arrives with 1 s and times out with 5 s). Not the default: 1 s lost on
    the tuning episodes (docs/experiments/2026-11-27-turning-in-place-to-dock.md)."""
    threat_until_arrival: bool = True
    """Our extension (off in :meth:`PlannerConfig.paper`): with a fixed goal's tolerance
    (``plan(goal_tolerance=...)`` above 0), the gate reads a docked plan's survival where its
    way first comes within that tolerance of the goal, not at the horizon's end: the task ends
    there, and docking itself judged the way up to there (``docking.arrival_at_tolerance``).
    Read at the horizon's end, a person who walks over the goal after the robot would have
    arrived replaced the docked way with a dodge (ETH/UCY univ, episode 22). A followed goal's
    task does not end on arrival: its docked plans keep the horizon's end. On by default: it
    won on the tuning episodes
    (docs/experiments/2026-11-28-docked-plans-threat-until-arrival.md)."""

    turn_to_goal: float = math.pi / 4
    """rad (0: off): once stalled (from ``turn_level`` of the ladder on), the rung also sets
    turns in place against the plan, each then the law (``backup.turn_trajectories``, 16):
    toward the goal until the line to it is within this angle of the heading, then the docking
    trajectory to it; toward the plan's own target as far, then the law to it; and 1 to 7 plan
    periods either way, then the docking trajectory to the goal; the exact cost takes the
    cheapest if it is cheaper than the plan. The law turns only along its curve and slows with
    the curvature, so a robot whose way is round a person standing just ahead, or that faces
    away from its goal, crawls or stands: CrowdNav's 'stalled-beside-person' runs stood 10 s
    with the person 0.4 m away, and the built-in hall's follower (MPEPC) took 6 s to turn
    round at 0.03 m/s (it still times out with the turns). Nav2's recoveries spin a stuck
    robot in place; pi/4 is docking's angle, Nav2's rotation shim's (ours; docs/method.md
    section 7.5). Not over a docked plan. On by default: it won on the tuning episodes
    (docs/experiments/2026-11-27-turns-in-place-when-stalled.md)."""
    turn_level: int = 1
    """The ladder's level from which ``turn_to_goal`` acts: 1, once stalled for a window; 0,
    on every plan."""
    doomed_below: float = 0.05
    """The rung's last resort (0 turns it off; it acts with the rung on, ``back_up`` > 0): a
    plan whose survival over the next ``clearance_within`` seconds (the exact cost's ``p^s``;
    a docked plan's until it arrives, if sooner, ``threat_until_arrival``) is below this is
    doomed. The plan, the forward dodges and the reverses are then set by the gap each keeps
    to every object (the people where the cost predicts them, the map) over those seconds,
    and the clearest replaces the plan when its gap is wider (``backup.clearest``, status
    "clearing"). Why: the cost weighs a collision through a bell ``sigma_dynamic`` (0.2 m)
    wide, so a way that passes a person a few centimetres off is near-certain death to it
    too, and among ways that all are, it picks by progress and action, often braking, which
    leaves the robot in the path of the person walking at it; the gaps still tell the ways
    apart. Read within the second, not to the horizon's end: a doom seconds away is one the
    cost still weighs, and a gap over one second is blind to it. Ours: 0.05, struck nineteen
    times in twenty, set before any run. On by default: it won on the tuning episodes
    (docs/experiments/2026-11-29-last-resort-for-a-doomed-plan.md)."""
    clearance_within: float = 1.0
    """s: how far ahead a doomed plan's ways are set by their gaps (``doomed_below``). Within
    a second the constant-velocity prediction is about as good as the bell is wide (its
    error grows 0.15-0.18 m per second of look-ahead on ETH/UCY's eth and hotel); further
    on, the gap the prediction promises is one the people may not leave (ours)."""
    passive: bool = True
    """With ``doomed_below``: when every way of a doomed plan, its own included, touches
    someone within ``clearance_within`` (the widest gap below 0) and the robot touches no
    one yet, keep the ways that drive least toward whoever they touch, at the first pose they
    touch each (moving away counts as still; braking to a stop is among them), and take the
    widest gap of those (``solve/behaviours/passive.py``): no way then promises no contact, but
    one can promise not to close it, rather than a dodge that drives on into a walker the
    prediction has a little wrong. After Fraichard's passive motion safety (at rest at a
    contact); ours.
    On by default: on the tuning episodes it won as many runs as it lost and left fewer
    contacts at fault (docs/experiments/2026-11-30-passive-safety.md)."""

    def __post_init__(self):
        check_booleans(self, ("dodge", "threat_until_arrival", "passive"))
        validate_fields(self, {"window": dict(low=0.0, low_open=True),
                                "min_displacement": dict(low=0.0, low_open=True),
                                "min_progress": dict(low=0.0),
                                "gain": dict(low=1.0), "back_up": dict(low=0.0),
                                "back_up_time": dict(low=0.0, low_open=True),
                                "back_up_threat": dict(low=0.0, high=1.0),
                                "dodge_within": dict(low=0.0, low_open=True),
                                "turn_to_goal": dict(low=0.0, high=math.pi),
                                "doomed_below": dict(low=0.0, high=1.0),
                                "clearance_within": dict(low=0.0, low_open=True)})
        check_integers(self, {"levels": 0, "back_up_level": 0, "turn_level": 0})

    def progress_gain(self, level: int) -> float:
        """The progress weight's factor at ``level`` (1 at level 0)."""
        return self.gain ** level
