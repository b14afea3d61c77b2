"""One runner for every benchmark: a process pool (or Dask), a resumable table, one progress bar.

BARN worlds, crowd crossings, parameter sweeps and scenario comparisons are all "many
independent runs, each a row". :func:`run_all` is the one loop over them: it skips the rows the
:class:`~dsmpepc_nlp.bench.results.ResultTable` already holds (resume), runs the rest in
``spawn`` worker processes (or inline with one worker, or on a Dask cluster), adds every row to
the table the moment it arrives (so an interrupted run loses at most the runs in flight) and
advances one progress bar. :func:`outcome_rates` and :func:`mean` are the summaries the
benchmarks share.
"""

from __future__ import annotations

import io
import math
import multiprocessing
import os
import sys

import numpy as np

from ..core.errors import MissingExtra
from ..core.progress import bar, say

RATE_OUTCOMES = ("success", "collision", "timeout", "deadlock", "error")
"""Outcomes whose share :func:`outcome_rates` reports (``error``: the run raised)."""


def worker_count(workers: int | None, n_tasks: int) -> int:
    """Processes to start: ``workers`` (default: the number of cores), at most one per task."""
    return max(1, min(workers or os.cpu_count() or 1, n_tasks or 1))


def _call(item):
    run, task = item
    return run(*task)


def _processes(run, tasks, workers):
    if workers == 1:
        yield from (run(*task) for task in tasks)
        return
    pool = multiprocessing.get_context("spawn").Pool(workers)
    try:
        yield from pool.imap_unordered(_call, [(run, task) for task in tasks])
    finally:
        pool.terminate()


def _dask(run, tasks, scheduler):
    try:
        from distributed import Client, as_completed
    except ImportError as exc:
        raise MissingExtra('--scheduler needs Dask: pip install "dsmpepc_nlp[sweep]"') from exc
    with Client(scheduler) as client:
        futures = [client.submit(run, *task, pure=False) for task in tasks]
        for future in as_completed(futures):
            yield future.result()


def run_all(run, tasks, table, *, label: str, key=None, workers=None, scheduler=None,
            progress=True, describe=None) -> int:
    """Run ``run(*task)`` for every task whose key is not in ``table``; each row into ``table``.

    Parameters
    ----------
    run : callable
        A module-level function (worker processes import it) returning one row (a dict); it
        should record its own failures in the row rather than raise.
    tasks : list of tuple
        Arguments of every run.
    table : ResultTable
        Rows already there are skipped (their key, ``key(task)``, is done); new rows are added
        as they arrive, so the table on disk is complete up to the runs in flight.
    label : str
        Name of the benchmark in the status line and on the bar.
    key : callable, optional
        ``key(task)``: the table key of a task's row. Without it every task runs.
    workers : int, optional
        Worker processes (default: cores); 1 runs inline.
    scheduler : str, optional
        Address of a Dask scheduler to run on instead of local processes.
    progress : True, file or None
        Where the status line and the bar go: True for stderr, a stream, or None (or False)
        for nowhere. The bar itself shows only on a terminal.
    describe : callable, optional
        ``describe(row)``: a short note shown on the bar after each run.

    Returns
    -------
    int
        Number of runs executed (not skipped).
    """
    todo = [t for t in tasks if key is None or not table.done(key(t))]
    n_workers = worker_count(workers, len(todo))
    where = f"Dask at {scheduler}" if scheduler else f"{n_workers} process(es)"
    stream = sys.stderr if progress is True else progress or None
    if stream is not None:
        say(f"{label}: {len(tasks)} runs, {len(tasks) - len(todo)} already done, "
            f"{len(todo)} to run on {where}", stream)
    if not todo:
        table.write()  # a finished table still gets both files, consistent with each other
        return 0
    rows = _dask(run, todo, scheduler) if scheduler else _processes(run, todo, n_workers)
    shown = bar(len(todo), label, stream=io.StringIO() if stream is None else stream)
    try:
        for row in rows:
            table.add(row)
            if describe is not None:
                shown.set_postfix_str(describe(row)[:40], refresh=False)
            shown.update(1)
    finally:
        shown.close()
    return len(todo)


def outcome_rates(outcomes, names=RATE_OUTCOMES) -> dict:
    """``{"<name>_rate": share}`` of each outcome name in ``outcomes`` (NaN when empty)."""
    outcomes = list(outcomes)
    n = len(outcomes)
    return {f"{name}_rate": outcomes.count(name) / n if n else math.nan for name in names}


def mean(rows, key: str, pick=None) -> float:
    """Mean of ``row[key]`` over the rows (that ``pick(row)``) where it is not None; NaN if none."""
    values = [r[key] for r in rows if (pick is None or pick(r)) and r.get(key) is not None]
    return float(np.mean(values)) if values else math.nan


def plan_time_summary(rows) -> dict:
    """``plan_time_median``: the median over rows of each row's median plan time;
    ``plan_time_p95`` and ``plan_time_p99``: the 95th and 99th percentiles over rows of each
    row's own; ``plan_time_max``: the longest plan of all (s; NaN without plans, and for p99
    and max with rows written before they were recorded); ``plans_out_of_time``: the plans
    whose time budget ran out, summed. Rows are episodes, runs or worlds."""
    out = {}
    for key, q in (("plan_time_median", 50), ("plan_time_p95", 95), ("plan_time_p99", 99),
                   ("plan_time_max", 100)):
        values = _known(rows, key)
        out[key] = float(np.percentile(values, q)) if values else math.nan
    counts = _known(rows, "plans_out_of_time")
    out["plans_out_of_time"] = float(np.sum(counts)) if counts else math.nan
    return out


def _known(rows, key: str) -> list:
    """``row[key]`` of the rows where it is a number (not missing, None or NaN)."""
    values = []
    for row in rows:
        try:
            value = float(row.get(key))
        except (TypeError, ValueError):
            continue
        if not math.isnan(value):
            values.append(value)
    return values
