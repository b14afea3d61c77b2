"""The exact cost of a cycle's z, and of the trajectories the law cannot make: one door, one
object per plan.

:class:`Evaluator` is built once per cycle and every stage of a plan goes through it: docking's
straight trajectory, the NLP's screen, verdicts and polish, the planner's choice and the
sampler. Behind it, side by side, are the two engines of :func:`evaluate_batch`: the compiled
kernel (:mod:`.exact`) when it is loaded and the z lie inside the reach the cycle's culling
rests on, and the numpy reference (:func:`~dsmpepc_nlp.core.exact_cost.evaluate`) otherwise;
they agree to 1e-9 (held by tests). The behaviours' trajectories that no z makes (reverses,
dodges, turns in place, a brake, docking's turn-then-law splices) are costed through
:meth:`Evaluator.evaluate_trajectories` (the kernel as given, else the numpy reference), and the
last resort's gaps are measured through :meth:`Evaluator.geometry` and
:meth:`Evaluator.circle_gaps` (tests/test_one_door.py holds every stage to this door).

The evaluator keeps every batch it costs for the cycle, so a z costed once is never costed
again: the plan's chosen z is read back from the batch that found it (a screen, a verdict or a
polish round), not rolled out and costed a second time for the plan's breakdown. The kernel
costs each row as it would be alone, so a row read back is the row a fresh evaluation gives,
to the bit.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass

import numpy as np

from ...core.control_law import Trajectory, rollout, stacked
from ...core.exact_cost import CostBreakdown, Geometry, circle_gaps, evaluate, exact_geometry
from ...core.solver_config import ParallelSettings, SolverConfig
from . import loader as exact
from .cycle import Cycle


@dataclass(frozen=True)
class Evaluation:
    """Exact rollouts and costs of a batch of z."""

    z: np.ndarray
    trajectories: Trajectory
    costs: CostBreakdown

    def best(self) -> int | None:
        """Index of the lowest finite exact cost, or None when nothing is finite."""
        total = np.where(np.isfinite(self.costs.total), self.costs.total, np.inf)
        if not np.any(np.isfinite(total)):
            return None
        return int(np.argmin(total))

    def __getitem__(self, index) -> Evaluation:
        """The rows ``index`` (an array of indices or a slice) as an Evaluation."""
        return Evaluation(self.z[index], self.trajectories[index], self.costs[index])


def evaluate_batch(z, cycle: Cycle, compiled: bool | None = None,
                   pair_budget: int = ParallelSettings.pair_budget,
                   parallel_rows: int = ParallelSettings.parallel_rows) -> Evaluation:
    """Roll out and cost every row of ``z`` (n, 4) exactly, once: the engines behind
    :class:`Evaluator` (which a plan uses; this function keeps nothing).

    ``compiled`` (default: when available) runs the compiled kernel on the cycle's arrays;
    False runs the numpy reference in chunks of at most ``pair_budget`` (trajectory, pose,
    footprint circle, obstacle circle) tuples (:attr:`ParallelSettings.pair_budget`); the kernel
    uses every core from ``parallel_rows`` rows on (:attr:`ParallelSettings.parallel_rows`).
    """
    return _Batch.cost(_as_batch(z), cycle, compiled, pair_budget, parallel_rows).evaluation()


class Evaluator:
    """The exact cost of one cycle's z (see the module's docstring).

    Parameters
    ----------
    cycle : Cycle
    solver : SolverConfig, optional
        ``parallel_rows`` and ``pair_budget`` are read.
    compiled : bool, optional
        None (default): the compiled kernel when it is loaded; False: the numpy reference.

    Attributes
    ----------
    rows_costed : int
        Rows (z) rolled out and costed so far (a row read back is not counted again).
    batches : list of (int, bool)
        Each batch of z costed: its rows, and whether it ran on the calling thread alone
        (``one_thread``).
    read_back : int
        Calls of :meth:`evaluate` answered from a batch costed before.
    trajectories_costed : int
        Trajectories costed by :meth:`evaluate_trajectories` (not in ``rows_costed`` nor
        ``batches``, which count z only).
    trajectories_measured : int
        Trajectories measured by :meth:`geometry` and :meth:`circle_gaps`.
    """

    def __init__(self, cycle: Cycle, solver: SolverConfig | None = None,
                 compiled: bool | None = None):
        solver = SolverConfig() if solver is None else solver
        self.cycle = cycle
        self.parallel_rows = solver.parallel.parallel_rows
        self.pair_budget = solver.parallel.pair_budget
        self.compiled = compiled
        self.rows_costed = self.read_back = 0
        self.trajectories_costed = self.trajectories_measured = 0
        self.batches = []
        self._batches = []
        self._lock = threading.Lock()       # a plan's stages cost batches from two threads

    def totals(self, z, one_thread: bool = False) -> np.ndarray:
        """The exact total cost of every row of ``z`` (n, 4), costed now. ``one_thread``: on
        the calling thread whatever the batch's size (for batches run beside a solve)."""
        return self._cost(_as_batch(z), one_thread).total.copy()

    def evaluate(self, z) -> Evaluation:
        """Rollouts and exact costs of every row of ``z`` (n, 4); rows all costed in one
        earlier batch are read back from it, not costed again."""
        z = _as_batch(z)
        with self._lock:
            batches = list(self._batches)
        for batch in reversed(batches):
            rows = batch.rows_of(z)
            if rows is not None:
                with self._lock:
                    self.read_back += 1
                return batch.evaluation(rows)
        return self._cost(z, False).evaluation()

    def evaluate_within(self, z, deadline=None, chunk: int = 512, stage: str = "") -> Evaluation:
        """:meth:`evaluate` of the rows of ``z`` costed before ``deadline`` (a
        :class:`~dsmpepc_nlp.core.deadline.Deadline`; None: every row, in one batch): a first
        chunk of ``chunk`` rows always, then, while time is left, as many rows as the first
        chunk's pace says fit in four fifths of it (at least ``chunk``), so that a plan with
        time to spare costs two batches, not many (``stage`` is recorded as cut when rows are
        left). Each row costs what it would alone. The compiled kernel only: the numpy path
        costs every row in one batch."""
        z = _as_batch(z)
        if deadline is None or not math.isfinite(deadline.seconds) or len(z) <= chunk \
                or exact.kernel() is None:
            return self.evaluate(z)
        began = time.perf_counter()
        parts = [self._cost(z[:chunk], False)]
        pace = (time.perf_counter() - began) / chunk        # seconds a row
        first = chunk
        while first < len(z) and deadline.check(stage):
            fits = int(0.8 * deadline.left() / pace) if pace > 0.0 else len(z)
            rows = max(chunk, fits)
            parts.append(self._cost(z[first:first + rows], False))
            first += rows
        if any(part._raw is None for part in parts):    # a chunk out of the kernel's reach
            return self.evaluate(np.vstack([part.z for part in parts]))
        return _Batch.joined(parts).evaluation()

    def evaluate_trajectories(self, trajectories: Trajectory) -> CostBreakdown:
        """The exact cost of ``trajectories`` (a batch, or one: the breakdown is batched like
        them) that no z of the law makes, on the cycle's world, goal and config: the compiled
        kernel costs them as given (:func:`.loader.cost_given`) when they are on the cycle's
        horizon and never faster than ``v_limit`` either way (:func:`.loader.given_in_reach`),
        else the numpy reference. Never kept for reading back; counted in
        ``trajectories_costed``."""
        cycle = self.cycle
        single = trajectories.poses.ndim == 2
        batch = stacked([trajectories]) if single else trajectories
        module = exact.kernel() if self.compiled is not False else None
        kernel = np.zeros(len(batch.z), bool) if module is None \
            else exact.given_in_reach(batch, cycle)
        parts = []
        if np.any(kernel):
            parts.append((kernel, exact.cost_given(batch[kernel], cycle, module,
                                                   self.parallel_rows)))
        if not np.all(kernel):
            parts.append((~kernel, evaluate(batch[~kernel], cycle.world, cycle.goal,
                                            cycle.config)))
        costs = parts[0][1] if len(parts) == 1 else _scattered(len(batch.z), parts)
        self._count("trajectories_costed", trajectories.poses)
        return costs[0] if single else costs

    def geometry(self, trajectories: Trajectory) -> Geometry:
        """The exact geometry of a batch of ``trajectories`` in the cycle's world with its
        config (what the cost is assembled from: the last resort's gaps); counted in
        ``trajectories_measured``."""
        cycle = self.cycle
        measured = exact_geometry(trajectories, cycle.world, cycle.goal, cycle.config)
        self._count("trajectories_measured", trajectories.poses)
        return measured

    def circle_gaps(self, points: np.ndarray, times: np.ndarray) -> tuple:
        """:func:`~dsmpepc_nlp.core.exact_cost.circle_gaps` of footprint centres ``points``
        (n, s, C, 2) at ``times`` (s,) against the cycle's people predicted as the cost predicts
        them: ``(rel, gap)``; counted in ``trajectories_measured`` (n)."""
        gaps = circle_gaps(self.cycle.world, self.cycle.config, points, times)
        self._count("trajectories_measured", points)
        return gaps

    def _count(self, counter: str, batch: np.ndarray) -> None:
        """Add ``batch``'s trajectories (its first axis; 1 for a single trajectory's poses)."""
        with self._lock:
            setattr(self, counter, getattr(self, counter) + (len(batch) if batch.ndim > 2 else 1))

    def times_costed(self, z) -> int:
        """How many times the row ``z`` (4,) was rolled out and costed in this cycle."""
        z = _as_batch(z)
        with self._lock:
            return sum(batch.rows_of(z) is not None for batch in self._batches)

    def _cost(self, z: np.ndarray, one_thread: bool) -> _Batch:
        rows = len(z) + 1 if one_thread else self.parallel_rows
        batch = _Batch.cost(z, self.cycle, self.compiled, self.pair_budget, rows)
        with self._lock:
            self._batches.append(batch)
            self.batches.append((len(z), one_thread))
            self.rows_costed += len(z)
        return batch


_COMPARE_ALL = 65_536
"""Row pairs up to which a look-up compares every row of a batch at once; above, the batch's
rows are indexed by their bytes (a sampler's thousands of rows against a screen's hundreds)."""


def _scattered(n: int, parts) -> CostBreakdown:
    """One breakdown of ``n`` rows from ``parts``: ``(rows, breakdown)`` pairs, ``rows`` a
    boolean mask or a slice, each breakdown holding its rows in order."""
    def place(read):
        first = np.asarray(read(parts[0][1]))
        out = np.empty((n, *first.shape[1:]), dtype=first.dtype)
        for rows, costs in parts:
            out[rows] = read(costs)
        return out

    terms = {name: place(lambda c, name=name: c.terms[name]) for name in parts[0][1].terms}
    return CostBreakdown(place(lambda c: c.total), terms, place(lambda c: c.survivability),
                         place(lambda c: c.min_distance), place(lambda c: c.ttg),
                         place(lambda c: c.ttc_terminal))


def _as_batch(z) -> np.ndarray:
    return np.atleast_2d(np.asarray(z, dtype=float))


class _Batch:
    """One costed batch: the kernel's raw outputs, or the numpy reference's Evaluation."""

    def __init__(self, z, raw=None, module=None, evaluation=None):
        self.z, self._raw, self._module, self._evaluation = z, raw, module, evaluation
        self._index = None

    @classmethod
    def cost(cls, z, cycle, compiled, pair_budget, parallel_rows) -> _Batch:
        module = exact.kernel() if compiled is not False else None
        if module is not None and z.shape[1:] == (4,) and exact.inside_reach(z, cycle):
            raw = exact.kernel_pass(z, cycle, module, parallel_rows)
            return cls(raw[0], raw=raw, module=module)
        return cls(z, evaluation=_evaluate_numpy(z, cycle, pair_budget))

    @classmethod
    def joined(cls, parts) -> _Batch:
        """One batch of the kernel's ``parts`` (costed by the same module), in order."""
        raw = tuple(np.concatenate(arrays) for arrays in zip(*(p._raw for p in parts)))
        return cls(raw[0], raw=raw, module=parts[0]._module)

    @property
    def total(self) -> np.ndarray:
        if self._raw is not None:
            return self._raw[-1][:, self._module.OUT.index("total")]
        return self._evaluation.costs.total

    def evaluation(self, rows=None) -> Evaluation:
        """The batch (or its ``rows``, an index array) as an Evaluation."""
        if self._evaluation is not None:
            return self._evaluation if rows is None else self._evaluation[rows]
        raw = self._raw if rows is None else tuple(a[rows] for a in self._raw)
        trajectories, costs = exact.as_breakdown(raw, self._module)
        evaluation = Evaluation(raw[0], trajectories, costs)
        if rows is None:
            self._evaluation = evaluation
        return evaluation

    def rows_of(self, z: np.ndarray):
        """Indices of the rows of ``z`` in this batch (the first match of each), or None
        when one of them is not in it (a batch of more rows than this one is never looked
        for: it is costed anew)."""
        if len(self.z) == 0 or len(z) > len(self.z) or z.shape[1:] != self.z.shape[1:]:
            return None
        if len(z) * len(self.z) <= _COMPARE_ALL:        # a plan's choice: one row, any batch
            same = np.all(self.z[None, :, :] == z[:, None, :], axis=2)
            return np.argmax(same, axis=1) if np.all(np.any(same, axis=1)) else None
        if self._index is None:
            self._index = {}
            for i, row in enumerate(self.z):
                self._index.setdefault(row.tobytes(), i)
        rows = [self._index.get(row.tobytes()) for row in z]
        return None if None in rows else np.array(rows)


def _evaluate_numpy(z, cycle: Cycle, pair_budget: int) -> Evaluation:
    """The numpy reference of :func:`evaluate_batch`, in chunks of at most ``pair_budget``."""
    state, world, goal, config = cycle.state, cycle.world, cycle.goal, cycle.config
    trajectories = rollout(z, state, config)
    circles = max(1, len(world.stacked_obstacles()[1]))
    per_row = (config.horizon.n_steps + 1) * len(config.robot.footprint) * circles
    chunk = max(1, pair_budget // per_row)
    if len(z) <= chunk:
        return Evaluation(z, trajectories, evaluate(trajectories, world, goal, config))
    parts = [(slice(i, i + chunk), evaluate(trajectories[i:i + chunk], world, goal, config))
             for i in range(0, len(z), chunk)]
    return Evaluation(z, trajectories, _scattered(len(z), parts))
