"""The stall monitor: a planner that stops making way escalates, a level per stalled window.

In the spirit of Nav2's recovery behaviours, but inside the cost: level ``k`` of the ladder
plans with the progress weight times ``StallConfig.gain ** k`` (a parameter of
the compiled graph, so escalating compiles nothing). docs/method.md section 7.5.
"""

from __future__ import annotations

import collections
import dataclasses
import math

from ...core.config import PlannerConfig


class StallMonitor:
    """Watches the robot's positions plan by plan and keeps the ladder's level.

    Parameters
    ----------
    config : PlannerConfig
        ``stall`` (the window, the least displacement and the ladder), ``horizon.dt`` (the
        plan period the window is counted in) and ``docking.arrival_radius`` (a robot this
        near its goal has arrived, not stalled).
    """

    def __init__(self, config: PlannerConfig):
        self.config = config
        stall = config.stall
        self.plans = max(1, round(stall.window / config.horizon.dt))
        self._positions = collections.deque(maxlen=self.plans + 1)
        self._configs = {0: config}
        self.level = 0

    def reset(self) -> None:
        """Forget the positions and go back to level 0 (a new episode)."""
        self._positions.clear()
        self.level = 0

    def update(self, state, goal) -> int:
        """Record this plan's position and return the level to plan at.

        When the window is full, a net displacement under ``min_displacement``, or progress
        toward ``goal`` (where it is now: the fall of the straight-line distance to it from the
        window's first position to its last) under ``min_progress``, with the goal farther than
        the arrival radius raises the level (at most the ladder's length) and starts a new
        window; a window with both sets the level back to 0.
        """
        stall = self.config.stall
        if stall.levels == 0:
            return 0
        self._positions.append((state.x, state.y))
        if len(self._positions) <= self.plans:
            return self.level
        (x0, y0), (x1, y1) = self._positions[0], self._positions[-1]
        before, now = math.hypot(goal[0] - x0, goal[1] - y0), math.hypot(goal[0] - x1, goal[1] - y1)
        moved = math.hypot(x1 - x0, y1 - y0) >= stall.min_displacement
        came = stall.min_progress <= 0.0 or before - now >= stall.min_progress
        if (moved and came) or now <= self.config.docking.arrival_radius:
            self.level = 0
        else:
            self.level = min(self.level + 1, stall.levels)
            self._positions.clear()
            self._positions.append((x1, y1))
        return self.level

    def replay(self, states, goals) -> int:
        """The level a planner plans the last of ``states`` at, having planned each of them in
        turn toward the matching one of ``goals`` since :meth:`reset`: the monitor reads only
        the positions and the goal, so a logged episode's plans give it back (how the failure
        report costs a stuck cycle at the level the robot planned it at)."""
        self.reset()
        for state, goal in zip(states, goals):
            self.update(state, goal)
        return self.level

    def config_for(self, level: int) -> PlannerConfig:
        """The configuration to plan with at ``level`` (kept per level: the same object every
        cycle, so what is derived from it per instance is derived once)."""
        if level not in self._configs:
            cost = self.config.cost
            gain = self.config.stall.progress_gain(level)
            self._configs[level] = dataclasses.replace(
                self.config, cost=dataclasses.replace(cost, w_progress=cost.w_progress * gain))
        return self._configs[level]

    def describe(self, level: int) -> str:
        """The level in words, for a plan's message ('' at level 0)."""
        if level == 0:
            return ""
        stall = self.config.stall
        gain = stall.progress_gain(level)
        nearer = (f" or came < {stall.min_progress:g} m nearer the goal"
                  if stall.min_progress > 0.0 else "")
        return (f"stalled (moved < {stall.min_displacement:g} m{nearer} in {stall.window:g} s): "
                f"ladder level {level}, progress weight x{gain:g}")
