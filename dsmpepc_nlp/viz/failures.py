"""The figure of one failure class: a few example runs, each its scene and the stuck cycle.

A view over data computed elsewhere: the episodes, their classification (a
:meth:`~dsmpepc_nlp.bench.failures.FailureClass.to_dict`) and, when given, the cost panels of
the stuck cycle (:func:`dsmpepc_nlp.sim.panels.cost_panels`). One row per example: the scene
(map, the robot's path with the stuck window thick, the footprint at the stuck cycle, people
with their paths, the narrowest gap, the contact) with its evidence beside it, then the four
cost panels.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from ..core.errors import seconds
from ..core.files import atomic_savefig
from ..sim.outcomes import OutcomeConfig
from .plots import (
    _footprint,
    _limits,
    draw_believed_map,
    draw_believed_people,
    draw_cost_panel,
    draw_map,
    on_stage,
)

EVIDENCE_KEYS = ("collision_kind", "contact_time", "touched", "start_gap", "robot_speed",
                 "approach_speed", "contact_age", "escape", "net_displacement",
                 "path_in_window", "reversals", "goal_distance",
                 "goal_occupied_share", "goal_person_distance", "person_gap", "person_speed",
                 "gap_width", "robot_width", "stall_level")
"""Evidence printed in a scene, in this order (those the class has)."""


def _text(evidence: dict) -> str:
    lines = []
    for key in EVIDENCE_KEYS:
        if key in evidence and evidence[key] is not None:
            value = evidence[key]
            if key == "escape":     # "not searched: <why>" is a sentence: the box keeps its head
                value = str(value).split(":")[0]
            if key == "contact_age" and value == float("inf"):
                value = "on stage from the start"
            lines.append(f"{key}: {value:.2f}" if isinstance(value, float) else f"{key}: {value}")
    if "goal_free_at" in evidence:  # a replay's draw: None, no planner could have arrived
        free = evidence["goal_free_at"]
        lines.append("goal_free_at: never" if free is None
                     else f"goal_free_at: {seconds(free)} s")
    return "\n".join(lines)


def draw_scene(ax, episode, failure: dict, label: str) -> None:
    """One failed run: map (and the robot's believed map, when it sensed), path (stuck window
    thick), people, footprint at the stuck cycle."""
    draw_map(ax, episode.grid)
    robot, k = failure["robot"], failure["cycle"]
    draw_believed_map(ax, episode, robot)
    end = min(episode.n_cycles,
              int(np.searchsorted(episode.times, episode.outcome_times[robot] - 1e-9)))
    window = int(round(OutcomeConfig().deadlock_window / episode.dt)) + 1
    path = episode.states[robot, :end + 1, :2]
    ax.plot(path[:, 0], path[:, 1], color="tab:blue", lw=1.2, zorder=3)
    ax.plot(path[-window:, 0], path[-window:, 1], color="darkorange", lw=3, zorder=3)
    ax.plot(*path[0], marker="o", color="tab:blue", ms=6, zorder=5)
    seen = failure["evidence"]
    person = (seen.get("goal_person") if failure["class"] == "goal-occupied"
              else seen.get("person", seen.get("pedestrian")))
    for j, radius in enumerate(episode.ped_radii):
        trace = on_stage(episode, episode.ped_positions[:end + 1, j])
        colour = "darkred" if j == person else "tab:red"
        ax.plot(trace[:, 0], trace[:, 1], color=colour, lw=0.8, alpha=0.5, zorder=2)
        if np.all(np.isfinite(trace[min(k, len(trace) - 1)])):
            ax.add_patch(Circle(episode.ped_positions[k, j], radius, color=colour, alpha=0.8,
                                zorder=3))
    draw_believed_people(ax, episode, robot, k)
    _footprint(ax, episode.states[robot, k, :3], episode.footprint(robot), "tab:blue", 0.6)
    goal = episode.goals[robot, k]
    ax.plot(goal[0], goal[1], marker="x", color="tab:green", ms=9, mew=2, zorder=5)
    ends = failure["evidence"].get("gap_ends")
    if ends is not None:
        (x0, y0), (x1, y1) = ends
        ax.plot([x0, x1], [y0, y1], color="magenta", lw=2, zorder=5)
    if failure["outcome"] == "collision":
        ax.plot(*episode.states[robot, end, :2], marker="*", color="black", ms=14, zorder=6)
        if person is not None and 0 <= int(person) < len(episode.ped_radii):
            # where the touched person was at the contact: one who appeared there is not on
            # stage at the stuck cycle and would otherwise not be drawn at all
            ax.add_patch(Circle(episode.ped_positions[end, int(person)],
                                episode.ped_radii[int(person)], fill=False, ls="--", lw=1.5,
                                color="darkred", zorder=6))
    _limits(episode, ax)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ended = seconds(episode.outcome_times[robot])
    ax.set_title(f"{label}\n{failure['outcome']} at {ended} s, "
                 f"stuck cycle t = {seconds(failure['time'])} s", fontsize=9)


def draw_evidence(ax, failure: dict) -> None:
    """The run's evidence as text in an axes of its own, beside the scene and never over it."""
    ax.axis("off")
    ax.set_title("evidence", fontsize=9, loc="left")
    ax.text(0.0, 1.0, _text(failure["evidence"]), transform=ax.transAxes, fontsize=7.5,
            va="top", ha="left", family="monospace")


LEGEND = (Line2D([], [], color="tab:blue", lw=1.2, label="robot path"),
          Line2D([], [], color="darkorange", lw=3, label="last 10 s (stuck window)"),
          Line2D([], [], color="tab:blue", marker="o", ls="", label="start"),
          Line2D([], [], color="tab:green", marker="x", ls="", mew=2, label="goal"),
          Line2D([], [], color="tab:blue", marker="o", ls="", ms=10, alpha=0.6,
                 label="robot at stuck cycle"),
          Line2D([], [], color="tab:red", marker="o", ls="-", lw=0.8, label="people and paths"),
          Line2D([], [], color="darkred", marker="o", ls="", label="person in evidence"),
          Line2D([], [], color="darkred", marker="o", ls="", mfc="none", ms=10,
                 label="person touched, at the contact"),
          Line2D([], [], color="darkorange", marker="o", ls="", mfc="none", ms=10,
                 label="person as believed (sensed runs)"),
          Line2D([], [], color="magenta", lw=2, label="narrowest gap"),
          Line2D([], [], color="black", marker="*", ls="", ms=10, label="contact"))


ZOOM = 2.0
"""Half-width of the close-up panels around the robot at the stuck cycle, m."""


def _zoom(ax, centre) -> None:
    ax.set_xlim(centre[0] - ZOOM, centre[0] + ZOOM)
    ax.set_ylim(centre[1] - ZOOM, centre[1] + ZOOM)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def failure_figure(name: str, examples, path, *, total: int | None = None,
                   cases: str | None = None) -> Path:
    """Up to a few examples of class ``name`` into ``path``; ``examples`` is a list of
    ``(label, episode, failure dict, CostPanels or None)``; ``total``: runs in the class;
    ``cases``: the worlds or episodes the report kept (``failures --cases``), in the title.

    One row per example: the run's evidence, the whole scene, a close-up of the stuck cycle
    and, with panels, the four cost panels of the stuck cycle (close-ups too)."""
    n = len(examples)
    cols = 6 if any(e[3] is not None for e in examples) else 2
    fig, axes = plt.subplots(n, cols + 1, figsize=(3.6 * cols + 2.4, 4.6 * n + 0.9),
                             squeeze=False, layout="constrained",
                             gridspec_kw={"width_ratios": [0.55] + [1.0] * cols})
    for row, (label, episode, failure, panels) in zip(axes, examples):
        draw_evidence(row[0], failure)
        draw_scene(row[1], episode, failure, label)
        draw_scene(row[2], episode, failure, "close-up")
        centre = episode.states[failure["robot"], failure["cycle"], :2]
        _zoom(row[2], centre)
        for j, ax in enumerate(row[3:]):
            if panels is None:
                ax.axis("off")
                continue
            title, poses = panels.panels[j]
            draw_cost_panel(ax, panels, poses, grey=j == 0)
            ax.set_title(f"stuck cycle: {title}", fontsize=9)
            _zoom(ax, centre)
    fig.legend(handles=list(LEGEND), fontsize=8, loc="outside lower center", ncols=5)
    shown = f"{n} of {total}" if total is not None else f"{n}"
    among = f", of cases {cases}" if cases else ""
    fig.suptitle(f"Failure class: {name} ({shown} runs shown{among})", fontsize=12)
    path = Path(path)
    atomic_savefig(fig, path, dpi=90)
    plt.close(fig)
    return path
