"""What every crowd benchmark (ETH/UCY replay, CrowdNav protocol) writes and sums up: a row's
fields from one episode, the summary of a variant's rows, and the run over every (variant,
episode). One table shape, so the two benchmarks' tables have the same columns."""

from __future__ import annotations

import math
import time

import numpy as np

from ..sim.metrics import episode_metrics
from .results import keep_failure
from .runner import mean, outcome_rates, plan_time_summary, run_all

OFFSTAGE = (1.0e4, 1.0e4)
"""Where pedestrians wait before their track starts and after it ends, m: the replay parks them
there, and a gap near it is no pedestrian on stage, not a distance."""
OFF_STAGE_BEYOND = OFFSTAGE[0] / 10
"""m from the origin: a pedestrian farther out is parked off stage (:func:`off_stage`)."""


def off_stage(positions) -> np.ndarray:
    """Whether each pedestrian position (..., 2) is the replay's parking place, not a place on
    stage (the replay parks people at :data:`OFFSTAGE` before and after their tracks)."""
    return np.linalg.norm(np.asarray(positions, dtype=float), axis=-1) > OFF_STAGE_BEYOND


APPEARED = 1.0
"""A pedestrian on stage for less than this at contact appeared beside the robot (its track
began there, out of nowhere), s: braking from 1 m/s at 1.5 m/s^2 alone takes 0.67 s, and a
plan sees a newcomer up to a 0.2 s cycle late. The failure classifier's ``appeared-in-reach``
uses it too."""


def footprint_core(circles) -> float:
    """The radius (m) about the robot's reference point that its body covers whatever its
    heading: ``max(r - |(cx, cy)|)`` over its ``(cx, cy, r)`` circles (one circle at the
    centre: its radius)."""
    return max(float(r) - math.hypot(float(cx), float(cy)) for cx, cy, r in circles)


def goal_covered(distances, radii, tolerance: float, core: float):
    """Whether pedestrians at ``distances`` (m, centre to goal; any shape, pedestrians last) with
    body ``radii`` cover the goal: every point within ``tolerance`` of it is within
    ``r_person + core`` of one (``|person - goal| + tolerance < r_person + core``), so a robot
    whose body covers ``core`` (:func:`footprint_core`) cannot arrive without touching them.
    Reduced over the last axis."""
    return np.any(np.asarray(distances) + tolerance < np.asarray(radii) + core, axis=-1)


def contact_age(episode, robot: int = 0) -> float:
    """How long (s) the pedestrian the robot collided with had been on stage at the contact;
    NaN without a collision with a pedestrian (the touched one: the smallest gap then)."""
    if episode.outcomes[robot] != "collision" or not episode.ped_radii.size:
        return math.nan
    k = int(np.searchsorted(episode.times, episode.outcome_times[robot] - 1e-9))
    gaps = np.linalg.norm(episode.ped_positions[k] - episode.states[robot, k, :2], axis=1) \
        - episode.ped_radii
    j = int(np.argmin(gaps))
    offstage = off_stage(episode.ped_positions[:k + 1, j])
    gone = np.flatnonzero(offstage)
    return float(episode.times[k] - (episode.times[gone[-1] + 1] if gone.size else 0.0))


def measured_row(row: dict, run, extra=None, keep=(None, "")) -> dict:
    """``row`` with the :func:`crowd_fields` of the episode ``run()`` returns (and
    ``extra(episode)``) and its ``wall_time``; ``outcome="error"`` and the message when ``run``
    raises (an ImportError, a missing extra, propagates). Shared by the crowd benchmarks.
    ``keep = (out_dir, stem)``: where an unsuccessful episode is kept (:func:`keep_failure`)."""
    started = time.perf_counter()
    try:
        episode = run()
        row.update(crowd_fields(episode_metrics(episode)[0]))
        if extra is not None:
            row.update(extra(episode))
        row["episode_file"] = keep_failure(episode, *keep)
    except ImportError:
        raise
    except Exception as exc:
        row.update(outcome="error", message=f"{type(exc).__name__}: {exc}")
    row["wall_time"] = time.perf_counter() - started
    return row


def crowd_fields(m: dict) -> dict:
    """The fields of a crowd benchmark's row from one robot's metrics (``robot_metrics``).

    Shared by every crowd benchmark (ETH/UCY replay, CrowdNav protocol) so that their tables
    have the same columns: outcome, collision kind (at-fault / struck), times, SPL, distances,
    discomfort, jerk and plan time.
    """
    return dict(outcome=m["outcome"], collision_kind=m["collision_kind"],
                time=m["outcome_time"], time_to_goal=m["time_to_goal"],
                path_length=m["path_length"], spl=m["spl"], discomfort=m["discomfort"],
                min_distance=m["min_dynamic_clearance"], jerk=m["mean_linear_jerk"],
                plan_time_median=m["plan_time_median"], plan_time_p95=m["plan_time_p95"],
                plan_time_p99=m["plan_time_p99"], plan_time_max=m["plan_time_max"],
                plans_out_of_time=m["plans_out_of_time"])


def summarise(rows) -> dict:
    """CrowdNav-style figures of a list of rows (one variant).

    ``success_rate`` counts any collision as a failure; ``collision_rate`` is split into
    ``at_fault_rate`` and ``struck_rate`` (:func:`~dsmpepc_nlp.sim.metrics.collision_kind`).
    ``spl`` is the mean over all episodes (0 for a failure), ``time_to_goal`` over successes;
    plan times: :func:`~dsmpepc_nlp.bench.runner.plan_time_summary`. Replay only:
    ``at_fault_appeared_rate`` counts the at-fault collisions with a pedestrian on stage for
    less than :data:`APPEARED` (``contact_age``), and ``goal_never_free_rate`` the runs whose
    goal a pedestrian covers from the robot's earliest possible arrival to the end
    (``goal_free_at`` None: :func:`~dsmpepc_nlp.bench.crowds.goal_free_at`), which no planner
    can win: ``1 - goal_never_free_rate`` bounds ``success_rate`` from above.
    """
    # A gap near OFFSTAGE means no pedestrian was on stage while the robot ran: not a distance.
    met = [r for r in rows if r.get("min_distance") is not None
           and r["min_distance"] < OFF_STAGE_BEYOND]
    gaps = [r["min_distance"] for r in met]
    n = len(rows)
    kinds = [r.get("collision_kind") for r in rows]
    return {"episodes": n, **outcome_rates(r["outcome"] for r in rows),
            "at_fault_rate": kinds.count("at-fault") / n if n else math.nan,
            "struck_rate": kinds.count("struck") / n if n else math.nan,
            "at_fault_appeared_rate": sum(
                1 for r in rows if r.get("collision_kind") == "at-fault"
                and r.get("contact_age") is not None and r["contact_age"] < APPEARED) / n
            if n else math.nan,
            "time_to_goal": mean(rows, "time_to_goal", lambda r: r["outcome"] == "success"),
            "spl": mean(rows, "spl"), "jerk": mean(rows, "jerk"),
            "discomfort": mean(rows, "discomfort"),
            "min_distance_mean": mean(met, "min_distance"),
            "episodes_with_pedestrians": len(met),
            "min_distance": float(np.min(gaps)) if gaps else math.nan,
            **plan_time_summary(rows), **_never_free(rows)}


def _never_free(rows) -> dict:
    """``goal_never_free_rate`` of replay rows (tables that record ``goal_free_at``), else {}."""
    if not rows or any("goal_free_at" not in r for r in rows):
        return {}
    return {"goal_never_free_rate": sum(r["goal_free_at"] is None for r in rows) / len(rows)}


def run_variants(run_episode, settings, variants, episodes: int, seed: int, table, *, label,
                 workers=None, scheduler=None, progress=True) -> dict:
    """:func:`~dsmpepc_nlp.bench.runner.run_all` over every (variant, episode) of a crowd
    benchmark (``run_episode(settings, variant, episode, seed)``) into ``table``; the
    :func:`summarise` of each variant's rows, by variant."""
    run_all(run_episode, [(settings, v, e, seed, str(table.folder)) for v in variants
                          for e in range(episodes)],
            table, label=label, key=lambda task: (task[1], task[2], task[3]),
            workers=workers, scheduler=scheduler, progress=progress,
            describe=lambda row: f"{row['variant']} episode {row['episode']}: {row['outcome']}")
    return {v: summarise([r for r in table.rows if r["variant"] == v and r["seed"] == seed
                          and r["episode"] < episodes]) for v in variants}
