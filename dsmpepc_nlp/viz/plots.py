"""Figures and animations: views over logged episodes and over data computed elsewhere.

Nothing here runs a planner: what a figure shows is logged (an :class:`Episode`) or computed
before (:mod:`dsmpepc_nlp.sim.panels` for the paper's Fig. 2), so drawing stays cheap and a
figure can be redrawn from files.

Paper style (Figs. 1-5): the map black, pedestrians red with their recent traces (the followed
one green), robot paths blue, a plan's evaluated trajectories grey and its optimum blue. Every
function returns the figure it made (or writes a file and closes it); callers close figures they
keep. Nothing in the core package imports this module.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation
from matplotlib.colors import ListedColormap
from matplotlib.patches import Circle

from ..core.errors import InputError, seconds
from ..core.geometry import footprint_points
from ..sim.metrics import collision_kind

ROBOT_COLOURS = ("tab:blue", "tab:purple", "tab:cyan", "tab:olive", "tab:brown", "tab:pink",
                 "navy", "teal", "darkorange", "slategray")
TRACE_SECONDS = 3.0
"""Length of the pedestrian traces, s."""


def _robot_colour(i):
    return ROBOT_COLOURS[i % len(ROBOT_COLOURS)]


def draw_map(ax, grid) -> None:
    """Occupied cells black on white, in world coordinates."""
    if grid is None:
        return
    x0, y0, x1, y1 = grid.bounds
    ax.imshow(grid.occupied, origin="lower", extent=(x0, x1, y0, y1), cmap="Greys",
              vmin=0, vmax=1, interpolation="nearest", zorder=0)


STAGE_MARGIN = 10.0
"""People farther than this from every robot state and goal are off the stage, m: a replayed
recording parks pedestrians far away before and after their tracks (bench.crowd_rows.OFFSTAGE)."""


def on_stage(episode, points) -> np.ndarray:
    """``points`` (..., 2) with those off the stage (:data:`STAGE_MARGIN`) set to NaN, so
    that a line through them breaks and no limit reaches for them."""
    robots = np.concatenate([episode.states[..., :2].reshape(-1, 2), episode.goals.reshape(-1, 2)])
    low, high = robots.min(0) - STAGE_MARGIN, robots.max(0) + STAGE_MARGIN
    points = np.array(points, dtype=float)
    points[~np.all((points >= low) & (points <= high), axis=-1)] = np.nan
    return points


def _limits(episode, ax):
    grid = episode.grid
    if grid is not None:
        x0, y0, x1, y1 = grid.bounds
    else:
        pts = [episode.states[..., :2].reshape(-1, 2), episode.goals.reshape(-1, 2)]
        if episode.ped_positions.size:
            people = on_stage(episode, episode.ped_positions.reshape(-1, 2))
            pts.append(people[np.all(np.isfinite(people), axis=1)])
        pts = np.concatenate(pts)
        (x0, y0), (x1, y1) = pts.min(0) - 1.0, pts.max(0) + 1.0
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")


def _footprint(ax, pose, circles, colour, alpha=0.8, label=None):
    points = footprint_points(np.asarray(pose, dtype=float), circles[:, :2])
    return [ax.add_patch(Circle(p, r, color=colour, alpha=alpha, zorder=4,
                                label=label if n == 0 else None))
            for n, (p, r) in enumerate(zip(points, circles[:, 2]))]


def _once(seen: set, label: str):
    """``label`` the first time it is asked for, None after: one legend entry per kind."""
    if label in seen:
        return None
    seen.add(label)
    return label


def legend(ax, *, fontsize: float = 7) -> None:
    """The legend outside the axes, on the right: robots by name and colour, pedestrians and
    their paths, parked robots, goals, plans, sampled trajectories (what the figure holds)."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        box = ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                        fontsize=fontsize, frameon=False, borderaxespad=0.0)
        for handle in getattr(box, "legend_handles", None) or box.legendHandles:
            handle.set_alpha(1.0)      # faint fans and thin plans, legible in the legend
            if hasattr(handle, "set_linewidth") and hasattr(handle, "get_xdata"):
                handle.set_linewidth(max(handle.get_linewidth(), 1.2))


def outcome_caption(episode) -> str:
    """Each robot's outcome, a collision told apart as at-fault or struck, with its time."""
    words = []
    for i, (name, outcome) in enumerate(zip(episode.meta["robots"], episode.outcomes)):
        kind = collision_kind(episode, i) if outcome == "collision" else None
        when = episode.outcome_times[i] if i < len(episode.outcome_times) else None
        at = f" at t = {seconds(when)} s" if when is not None and np.isfinite(when) else ""
        words.append(f"{name}: {outcome}{f' ({kind})' if kind else ''}{at}")
    return "outcome: " + "; ".join(words)


def _robot_named(name) -> str:
    """``robot NAME``, or the name alone where it already says robot (a replay's one robot)."""
    name = str(name)
    return name if name.lower().startswith("robot") else f"robot {name}"


def _axes_labels(ax) -> None:
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def draw_cycle(ax, episode, cycle: int, *, samples: bool = True, title: bool = True,
               full_paths: bool = False) -> None:
    """One moment of an episode: map, pedestrians with traces (``full_paths``: their whole
    paths so far), robots, paths so far, plans; every kind labelled for :func:`legend`."""
    draw_map(ax, episode.grid)
    k = int(np.clip(cycle, 0, episode.n_cycles))
    dt = episode.dt
    seen = set()
    followed = {int(f[0]) for f in episode.meta["follow"] if f is not None}
    first = 0 if full_paths else max(0, k - int(round(TRACE_SECONDS / dt)))
    trace_words = "path" if full_paths else f"last {TRACE_SECONDS:g} s"
    for j, radius in enumerate(episode.ped_radii):
        colour = "tab:green" if j in followed else "tab:red"
        kind = "followed pedestrian" if j in followed else "pedestrian"
        trace = on_stage(episode, episode.ped_positions[first:k + 1, j])
        ax.plot(trace[:, 0], trace[:, 1], color=colour, lw=1, alpha=0.6, zorder=2,
                label=_once(seen, f"{kind} ({trace_words})"))
        if np.all(np.isfinite(trace[-1])):
            ax.add_patch(Circle(trace[-1], radius, color=colour, alpha=0.8, zorder=3,
                                label=_once(seen, kind)))
    for parked in episode.meta["parked"]:
        _footprint(ax, parked["pose"], np.asarray(parked["footprint"]), "dimgray",
                   label=_once(seen, "parked robot"))
    for i in range(episode.n_robots):
        colour = _robot_colour(i)
        name = episode.meta["robots"][i]
        if samples and (i, k) in episode.samples:
            poses, _ = episode.samples[(i, k)]
            for p in poses:
                ax.plot(p[:, 0], p[:, 1], color="0.6", lw=0.4, alpha=0.5, zorder=1,
                        label=_once(seen, "sampled trajectories"))
        path = episode.states[i, :k + 1]
        ax.plot(path[:, 0], path[:, 1], color=colour, lw=1.5, zorder=3,
                label=f"{_robot_named(name)} (path)")
        if episode.plan_poses is not None and k < episode.n_cycles and episode.active[i, k]:
            plan = episode.plan_poses[i, k]
            ax.plot(plan[:, 0], plan[:, 1], color=colour, lw=1.0, ls="--", zorder=3,
                    label=_once(seen, "current plan (dashed)"))
        _footprint(ax, episode.states[i, k, :3], episode.footprint(i), colour)
        goal = episode.goals[i, k]
        ax.plot(goal[0], goal[1], marker="x", color=colour, ms=7, mew=2, zorder=5, ls="none",
                label=_once(seen, "goal (x, robot's colour)"))
    _limits(episode, ax)
    _axes_labels(ax)
    if title:
        ax.set_title(f"{episode.meta['scenario']} ({episode.meta['variant']}), "
                     f"t = {seconds(episode.times[k])} s", fontsize=9)


def episode_figure(episode, *, cycle: int | None = None, path=None):
    """The paper-style frame of an episode (default: its last state, every recorded sample)."""
    fig, ax = plt.subplots(figsize=(8.5, 6))
    k = episode.n_cycles if cycle is None else cycle
    draw_cycle(ax, episode, k, samples=False, full_paths=True)
    draw_belief(ax, episode, k)
    label = "sampled trajectories (recorded cycles)"
    for poses, _ in episode.samples.values():  # every recorded evaluation, grey
        for p in poses:
            ax.plot(p[:, 0], p[:, 1], color="0.7", lw=0.3, alpha=0.4, zorder=1, label=label)
            label = None
    if episode.plan_poses is not None:  # the optimum of every cycle, thin
        label = "each cycle's plan (thin)"
        for i in range(episode.n_robots):
            for p in episode.plan_poses[i][episode.active[i]]:
                ax.plot(p[:, 0], p[:, 1], color=_robot_colour(i), lw=0.3, alpha=0.3, zorder=1,
                        label=label)
                label = None
    legend(ax)
    fig.text(0.5, 0.01, outcome_caption(episode), ha="center", va="bottom", fontsize=8,
             wrap=True)
    return _finish(fig, path)


def draw_believed_map(ax, episode, robot: int = 0) -> None:
    """Under a profile with a lidar, robot ``robot``'s local map at the end of the run: its
    occupied cells in translucent orange over the true map the frame draws."""
    grid = episode.believed_grid(robot)
    if grid is None or not grid.occupied.any():
        return
    x0, y0, x1, y1 = grid.bounds
    shown = np.ma.masked_where(~grid.occupied, grid.occupied.astype(float))
    ax.imshow(shown, origin="lower", extent=(x0, x1, y0, y1),
              cmap=ListedColormap(["darkorange"]), vmin=0, vmax=1, alpha=0.55,
              interpolation="nearest", zorder=1)
    ax.plot([], [], color="darkorange", lw=6, alpha=0.55, label="believed map (end of run)")


def draw_believed_people(ax, episode, robot: int, cycle: int) -> None:
    """Under a sensing profile, the people robot ``robot`` planned with at ``cycle`` (its last
    plan up to then): dashed orange circles, as wide as the planner drew them, each with a
    line to where it believed the person would be 1 s later."""
    people = getattr(episode, "believed_people", None)
    if people is None or people.shape[1] == 0:
        return
    k = min(max(cycle, 0), people.shape[1] - 1)
    while k > 0 and not np.isfinite(episode.believed_states[robot, k, 0]):
        k -= 1
    label = "people as believed (dashed; line: 1 s ahead)"
    for x, y, vx, vy, radius in people[robot, k]:
        if not np.isfinite(x):
            continue
        ax.add_patch(Circle((x, y), radius, fill=False, ls="--", lw=1.2, color="darkorange",
                            zorder=5, label=label))
        ax.plot([x, x + vx], [y, y + vy], color="darkorange", lw=1.0, zorder=5)
        label = None


def draw_belief(ax, episode, cycle: int) -> None:
    """Under a sensing profile, where each robot believed it was at every plan up to
    ``cycle`` (dashed, in the robot's colour) beside the true path the frame draws, the
    first robot's believed map and the people it planned with at ``cycle``."""
    believed = getattr(episode, "believed_states", None)
    if believed is None:
        return
    draw_believed_map(ax, episode, 0)
    draw_believed_people(ax, episode, 0, cycle)
    label = f"believed path ({episode.meta.get('sensing', {}).get('name', 'sensed')})"
    for i in range(episode.n_robots):
        path = believed[i, :cycle]
        path = path[np.isfinite(path[:, 0])]
        if len(path):
            ax.plot(path[:, 0], path[:, 1], color=_robot_colour(i), lw=1.0, ls="--",
                    alpha=0.8, zorder=4, label=label)
            label = None


def _finish(fig, path):
    if path is None:
        return fig
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def compare_figure(episodes: dict, *, path=None):
    """Side by side: the final frame of each named episode (e.g. MPEPC vs DS-MPEPC)."""
    n = len(episodes)
    fig, axes = plt.subplots(1, n, figsize=(5.5 * n, 5), squeeze=False, layout="constrained")
    for ax, (name, episode) in zip(axes[0], episodes.items()):
        draw_cycle(ax, episode, episode.n_cycles, samples=False, title=False, full_paths=True)
        draw_belief(ax, episode, episode.n_cycles)
        outcomes = outcome_caption(episode).removeprefix("outcome: ")
        ax.set_title(f"{name}: {outcomes}", fontsize=8, wrap=True)
    # One frame for every panel (each drew its own round what it holds), so the runs of one
    # scene compare place for place.
    xs = np.array([ax.get_xlim() for ax in axes[0]])
    ys = np.array([ax.get_ylim() for ax in axes[0]])
    for ax in axes[0]:
        ax.set_xlim(xs[:, 0].min(), xs[:, 1].max())
        ax.set_ylim(ys[:, 0].min(), ys[:, 1].max())
    legend(axes[0, -1])
    # Height from the scene's aspect ratio, so a long corridor is not framed by blank space.
    (x0, x1), (y0, y1) = axes[0, 0].get_xlim(), axes[0, 0].get_ylim()
    aspect = abs(y1 - y0) / max(abs(x1 - x0), 1e-9)
    fig.set_size_inches(5.5 * n, min(9.0, max(2.5, 5.0 * aspect + 1.2)))
    fig.suptitle(next(iter(episodes.values())).meta["scenario"])
    return _finish(fig, path)


def cost_panels(panels, *, path=None):
    """The paper's Fig. 2 for one planning cycle: four panels of trajectories over the scene.

    ``panels`` is a :class:`~dsmpepc_nlp.sim.panels.CostPanels` (computed by
    :func:`dsmpepc_nlp.sim.panels.cost_panels`): the first panel's trajectories grey, the
    others blue; obstacles, the robot and the goal in every panel.
    """
    fig, axes = plt.subplots(1, len(panels.panels), figsize=(16, 4.5))
    for k, (ax, (title, poses)) in enumerate(zip(axes, panels.panels)):
        draw_cost_panel(ax, panels, poses, grey=k == 0)
        ax.set_title(title, fontsize=10)
    return _finish(fig, path)


def draw_cost_panel(ax, panels, poses, *, grey: bool = False) -> None:
    """One panel of :func:`cost_panels`: the scene around the robot and ``poses`` (grey or
    blue)."""
    state, world, goal, reach = panels.state, panels.world, panels.goal, panels.reach
    draw_map(ax, world.grid)
    for obstacle in world.obstacles:
        colour = "tab:red" if obstacle.kind == "pedestrian" else "dimgray"
        for c, r in zip(obstacle.centers, obstacle.radii):
            ax.add_patch(Circle(c, r, color=colour, alpha=0.8, zorder=3))
    for p in poses:
        ax.plot(p[:, 0], p[:, 1], color="0.5" if grey else "tab:blue", lw=0.6, alpha=0.6,
                zorder=2)
    _footprint(ax, state.pose, panels.footprint, "tab:blue")
    ax.plot(*goal, marker="x", color="tab:green", ms=8, mew=2)
    ax.set_xlim(state.x - reach, state.x + reach)
    ax.set_ylim(state.y - reach, state.y + reach)
    ax.set_aspect("equal")
    _axes_labels(ax)


def animate(episode, path, *, fps: int | None = None, stride: int = 1):
    """Write an animation of the episode: GIF (PillowWriter) or MP4 (needs ffmpeg on PATH).

    Returns the path written. ``stride`` skips cycles; ``fps`` defaults to real time.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".mp4":
        if shutil.which("ffmpeg") is None:
            raise RuntimeError("MP4 needs ffmpeg on PATH; write a .gif instead")
        writer = animation.FFMpegWriter(fps=fps or round(1 / (episode.dt * stride)))
    elif suffix == ".gif":
        writer = animation.PillowWriter(fps=fps or round(1 / (episode.dt * stride)))
    else:
        raise InputError(f"animation path {str(path)!r}: must end in .gif or .mp4")
    frames = list(range(0, episode.n_cycles + 1, stride))
    if frames[-1] != episode.n_cycles:
        frames.append(episode.n_cycles)
    fig, ax = plt.subplots(figsize=(6, 5))

    def draw(k):
        ax.clear()
        draw_cycle(ax, episode, k)
        draw_belief(ax, episode, k)
        return []

    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
    try:
        anim = animation.FuncAnimation(fig, draw, frames=frames, blit=False)
        anim.save(str(tmp), writer=writer)
        tmp.replace(path)
    finally:
        plt.close(fig)
        tmp.unlink(missing_ok=True)
    return path


def crosscheck_figure(gaps, *, label: str = "exact cost: NLP - sampling", path=None):
    """Histogram of the per-cycle gaps of a cross-check (negative: the NLP found lower)."""
    gaps = np.asarray(gaps, dtype=float)
    finite = gaps[np.isfinite(gaps)]
    fig, ax = plt.subplots(figsize=(6, 4))
    if finite.size:
        ax.hist(finite, bins=min(50, max(5, finite.size // 3)), color="tab:blue")
    ax.axvline(0.0, color="k", lw=1)
    ax.set_xlabel(label)
    ax.set_ylabel("cycles")
    ax.set_title(f"{finite.size} cycles, {np.sum(finite > 1e-6)} where the NLP is worse, "
                 f"{gaps.size - finite.size} non-finite", fontsize=9)
    return _finish(fig, path)
