"""The exact-cost polish: a pattern search on the exact cost around the best candidates.

After the solves, the best distinct candidates (solved or screened, by exact cost) are each
walked on a grid: a round costs the 24 neighbours of the walk's point (a step along one
variable, or along all four at once) in one exact batch, keeps the best if it is better, and
halves the step. It reaches basins next to the candidates that the solves stopped short of, and
the exact optimum where the smooth one is near, not at, it
(docs/experiments/2026-11-23-a-polish-of-half-the-size.md). The candidates after those (scouts)
walk a round or two, and the cheapest of them walk on: the exact best often lies next to a
candidate ranked below the first few (docs/experiments/2026-11-29-scouts-in-the-polish.md).

A walk depends only on its seed and every row is costed as it would be alone, so a walk ends
the same wherever its rounds run: ahead, on the thread the solves leave idle
(:meth:`Polish.ahead`), or at the end, its walks shared out over the threads
(:meth:`Polish.finish`). :attr:`Polish.last` says where this cycle's rounds ran.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import threading
import time

import numpy as np

from ...core.solver_config import SolverConfig
from ..plan import StartRecord
from . import threads

NEIGHBOURS = np.array([d for d in itertools.product((-1.0, 0.0, 1.0), repeat=4)
                       if sum(map(abs, d)) in (1, 4)])
"""The 24 neighbours of a point on the 4-D grid: the 8 steps along one variable and the 16
corners (a step along all four). The other 56 grid neighbours (two or three variables at once)
bought nothing the cross-check could see for 2.4 times the exact trajectories
(docs/experiments/2026-11-23-a-polish-of-half-the-size.md)."""


STAGE = "the polish"
"""The stage a deadline cuts when the polish's walks stop short of their rounds."""


@dataclasses.dataclass
class Walk:
    """One pattern search: from ``seed``, at ``z`` of exact ``cost`` after ``rounds`` rounds,
    next ``step`` (per variable)."""

    seed: StartRecord
    z: np.ndarray
    cost: float
    step: np.ndarray
    rounds: int = 0


class Polish:
    """The polish of one configuration.

    Parameters
    ----------
    solver : SolverConfig
        Its ``polish`` settings, ``multistart.distinct`` and ``parallel.solve_threads``.
    lower, upper : ndarray, (4,)
        The z box.

    Attributes
    ----------
    last : dict
        Where the last cycle's rounds ran: ``ahead_rounds`` (rounds walked ahead, on the idle
        thread), ``threads`` (``(thread name, walks)`` of each group of the final rounds).
    """

    def __init__(self, solver: SolverConfig, lower, upper):
        self.solver, self.settings = solver, solver.polish
        self.lower, self.upper = np.asarray(lower, float), np.asarray(upper, float)
        self.span = self.upper - self.lower
        self.first_step = solver.polish.step * self.span
        self.last = {"ahead_rounds": 0, "threads": []}
        self.deadline = None
        self._lock = threading.Lock()

    def distinct(self, a, b) -> bool:
        """True when two z differ by more than ``MultistartSettings.distinct`` of the box (max
        norm): the starts solved from and the polish's seeds are kept that far apart."""
        return bool(np.max(np.abs(a - b) / self.span) > self.solver.multistart.distinct)

    def seeds(self, records, scouts: bool = False) -> tuple:
        """``(seeds, best)``: the best distinct candidates the polish starts from, cheapest
        first (at most ``polish_starts``, with ``scouts`` also ``polish_scouts`` more, none
        trailing the best by more than ``polish_margin``), and the best exact cost of all."""
        finite = sorted((r for r in records if math.isfinite(r.exact_cost)),
                        key=lambda r: r.exact_cost)
        if not finite:
            return [], math.inf
        count = self.settings.starts + (self.settings.scouts if scouts else 0)
        seeds = []
        for record in finite:       # cheapest first
            if (len(seeds) == count
                    or record.exact_cost > finite[0].exact_cost + self.settings.margin):
                break
            if all(self.distinct(record.z, s.z) for s in seeds):
                seeds.append(record)
        return seeds, finite[0].exact_cost

    def walk(self, seed, walks: dict) -> Walk:
        """The pattern search from ``seed``: the one already (partly) run ahead, else new."""
        key = (seed.name, seed.z.tobytes(), seed.exact_cost)
        if key not in walks:
            walks[key] = Walk(seed, seed.z.copy(), seed.exact_cost, self.first_step)
        return walks[key]

    def round(self, walks, evaluator, one_thread=False) -> None:
        """One round of each walk, all in one exact batch: the 24 neighbours at its step,
        the best kept if better, the step halved."""
        z = np.array([w.z for w in walks])
        step = np.array([w.step for w in walks])
        trial = np.clip(z[:, None, :] + NEIGHBOURS * step[:, None, :], self.lower, self.upper)
        costs = evaluator.totals(trial.reshape(-1, 4), one_thread)
        costs = np.where(np.isfinite(costs), costs, np.inf).reshape(len(z), -1)
        for walk, row, trials in zip(walks, costs, trial):
            best = int(np.argmin(row))
            if row[best] < walk.cost:
                walk.z, walk.cost = trials[best], float(row[best])
            walk.step = walk.step / 2
            walk.rounds += 1

    def ahead(self, records, evaluator, walks: dict, busy) -> None:
        """Polish ahead (on a thread the solves left idle): walk from each seed of
        ``records`` (the screened starts and the solves finished so far) one after another,
        a round at a time, while ``busy()``. Walks are kept in ``walks``; the final polish
        continues those whose seed is still a seed and drops the others."""
        seeds, _ = self.seeds(records)
        for seed in seeds:
            walk = self.walk(seed, walks)
            while walk.rounds < self.settings.rounds:
                if not busy() or not self.in_time():
                    return
                self.round([walk], evaluator, one_thread=True)
                self.last["ahead_rounds"] += 1

    def run(self, records, evaluator, walks: dict | None = None) -> StartRecord | None:
        """The polish of ``records``: every seed's walk to ``polish_rounds`` (continuing the
        walks run ahead where their seed is still a seed); the record ``polish`` of the best
        walk, or None when it finds nothing better than every candidate (or is off)."""
        rounds = self.settings.rounds
        seeds, best = self.seeds(records, scouts=True)
        if rounds == 0 or not seeds or not self.in_time():
            return None
        started = time.perf_counter()
        walks = [self.walk(seed, {} if walks is None else walks) for seed in seeds]
        walks = walks[:self.settings.starts] + self.scout(walks[self.settings.starts:],
                                                          evaluator)
        self.finish(walks, evaluator)
        winner = min(walks, key=lambda w: w.cost)       # the first of equals, as argmin
        if not winner.cost < best:
            return None
        origin = winner.seed
        return StartRecord("polish", origin.z, winner.z, f"polished '{origin.name}'",
                           any(r.success for r in records), rounds,
                           time.perf_counter() - started, math.nan, winner.cost)

    def scout(self, scouts, evaluator) -> list:
        """The scouts' first ``scout_rounds`` rounds, all of them in one exact batch a round
        (shared over the cores as any batch is); the ``promoted`` cheapest after them, in
        their seeds' order, to be walked to the end with the other walks."""
        if not scouts:
            return []
        first = min(self.settings.scout_rounds, self.settings.rounds)
        while (active := [w for w in scouts if w.rounds < first]) and self.in_time():
            self.round(active, evaluator)       # (some may have run ahead)
        order = sorted(range(len(scouts)), key=lambda k: scouts[k].cost)
        return [scouts[k] for k in sorted(order[:self.settings.promoted])]

    def finish(self, walks, evaluator) -> None:
        """Every walk's remaining rounds. With several walks left and ``solve_threads``
        above 1, the walks are shared out over the threads (most rounds left first, each to
        the least loaded thread), each thread running its own walks' rounds on its core: a
        round of 24 rows is too small to share one batch over the cores
        (docs/experiments/2026-11-23-what-a-compiled-call-spends.md), two walks side by side
        are not."""
        rounds = self.settings.rounds
        left = [w for w in walks if w.rounds < rounds]
        n_threads = min(self.solver.parallel.solve_threads, len(left))
        if n_threads <= 1:
            self._walk_to_the_end(left, evaluator)
            return
        groups, loads = [[] for _ in range(n_threads)], [0] * n_threads
        for walk in sorted(left, key=lambda w: w.rounds):
            lightest = loads.index(min(loads))
            groups[lightest].append(walk)
            loads[lightest] += rounds - walk.rounds
        others = [threads.pool(n_threads - 1, "walks").submit(self._walk_to_the_end, group,
                                                              evaluator, True)
                  for group in groups[1:]]
        try:
            self._walk_to_the_end(groups[0], evaluator, True)
        finally:
            for future in others:
                future.result()

    def _walk_to_the_end(self, walks, evaluator, one_thread=False) -> None:
        """Rounds of ``walks`` (in one exact batch each) until every one has had its
        ``polish_rounds``."""
        if walks:
            with self._lock:
                self.last["threads"].append((threading.current_thread().name, len(walks)))
        while True:
            active = [w for w in walks if w.rounds < self.settings.rounds]
            if not active or not self.in_time():
                return
            self.round(active, evaluator, one_thread)

    def reset(self, deadline=None) -> None:
        """A new cycle: forget where the last one's rounds ran; walk until ``deadline`` (a
        :class:`~dsmpepc_nlp.core.deadline.Deadline`, None: every round)."""
        self.last = {"ahead_rounds": 0, "threads": []}
        self.deadline = deadline

    def in_time(self) -> bool:
        """True while the cycle's deadline leaves time for another round (:data:`STAGE` is
        recorded as cut once it does not)."""
        return self.deadline is None or self.deadline.check(STAGE)
