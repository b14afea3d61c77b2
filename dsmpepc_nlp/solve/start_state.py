"""The start of a plan: the state as a caller may give it, and whether the robot's footprint
already overlaps the map or an obstacle there (a plan from such a start says so)."""

from __future__ import annotations

import numpy as np

from ..core.config import PlannerConfig, RobotState
from ..core.errors import InputError
from ..core.geometry import body_to_world


def as_state(state) -> RobotState:
    """``state`` as a :class:`RobotState`: one already, or ``(x, y, phi[, v, omega])``."""
    if isinstance(state, RobotState):
        return state
    try:
        values = np.asarray(state, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        values = None
    if values is None or values.size not in (3, 5) or np.ndim(state) != 1:
        shown = repr(state) if np.size(state) <= 10 else f"an array of shape {np.shape(state)}"
        raise InputError(f"state = {shown}: must be a RobotState or (x, y, phi[, v, omega]) "
                         "in m, m, rad, m/s, rad/s")
    return RobotState(*(float(v) for v in values))


def start_overlap(state: RobotState, world, config: PlannerConfig) -> str:
    """Words naming the deepest overlap of the footprint at ``state`` with the map or a
    dynamic obstacle (distance, which one), or "" when the start is free."""
    circles = np.array(config.robot.footprint, dtype=float)
    centers = np.stack(body_to_world(state.pose, circles[:, 0], circles[:, 1]), axis=1)
    worst, words = 0.0, ""
    static = np.asarray(world.static_distance(centers)) - circles[:, 2]
    if static.size and float(static.min()) < worst:
        i = int(np.argmin(static))
        worst = float(static[i])
        x, y = (float(c) for c in centers[i])
        words = f"the map's occupied cells, around ({x:.2f}, {y:.2f}) m"
    obstacles, radii, _, owner = world.stacked_obstacles()
    if len(radii):
        gaps = (np.linalg.norm(centers[:, None, :] - obstacles[None], axis=-1)
                - circles[:, 2, None] - radii[None])
        i, k = np.unravel_index(int(np.argmin(gaps)), gaps.shape)
        if float(gaps[i, k]) < worst:
            worst = float(gaps[i, k])
            kind = world.obstacles[int(owner[k])].kind
            x, y = (float(c) for c in obstacles[k])
            words = f"obstacle {int(owner[k])} (a {kind} at ({x:.2f}, {y:.2f}) m)"
    if not words:
        return ""
    return (f"start in collision: the footprint at ({state.x:.2f}, {state.y:.2f}) m overlaps "
            f"{words} by {-worst:.3f} m")


__all__ = ["as_state", "start_overlap"]
