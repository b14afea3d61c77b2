"""Parameter sweeps: a grid of cost parameters x scenarios x seeds, run in parallel, resumable.

Every run is ``simulate(scenario, config with the parameters, solver, default_rng(seed))``, so
a run is reproducible from its row. Runs go to worker processes (default) or to a Dask cluster
(``scheduler`` address; ``pip install "dsmpepc_nlp[sweep]"``). A run that raises is recorded with
``status = "failed"`` and the message, never dropped. The table is ``sweep.{json,csv}`` in the
output folder, rewritten atomically after every run; heatmaps of success and deadlock rate for
every pair of swept parameters are ``sweep_<p>_<q>.png``.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import multiprocessing
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.config import PlannerConfig, SolverConfig
from .results import ResultTable, atomic_savefig

SECTIONS = ("robot", "control_law", "horizon", "bounds", "cost", "smoothing", "docking")
"""PlannerConfig parts a parameter may name as ``part.field``; a bare name is a ``cost`` field."""


def _resolve_name(name: str) -> tuple:
    section, _, field = name.rpartition(".")
    section = section or "cost"
    if section not in SECTIONS:
        raise ValueError(f"--param {name!r}: section {section!r} must be one of "
                         f"{', '.join(SECTIONS)}")
    kind = type(getattr(PlannerConfig(), section))
    fields = [f.name for f in dataclasses.fields(kind)]
    if field not in fields:
        raise ValueError(f"--param {name!r}: {kind.__name__} has no field {field!r} "
                         f"(fields: {', '.join(fields)})")
    return section, field


def parse_params(specs) -> dict:
    """``["s_ttc=0.25,0.5,1", "robot.v_limit=1,1.5"]`` -> ``{name: [values]}`` (floats).

    ValueError naming the parameter on an unknown field, a missing ``=``, a repeated name or a
    value that is not a number.
    """
    params: dict = {}
    for spec in specs:
        name, sep, values = str(spec).partition("=")
        name = name.strip()
        if not sep or not name or not values.strip():
            raise ValueError(f"--param {spec!r}: expected NAME=V1,V2,...")
        _resolve_name(name)
        if name in params:
            raise ValueError(f"--param {name!r}: given twice")
        try:
            params[name] = [float(v) for v in values.split(",") if v.strip()]
        except ValueError:
            raise ValueError(f"--param {spec!r}: values must be numbers") from None
    return params


def expand_grid(params: dict, scenarios, seeds) -> list:
    """Every combination, as dicts ``{"params": {name: value}, "scenario": s, "seed": k}``."""
    names = list(params)
    runs = []
    for values in itertools.product(*(params[n] for n in names)):
        for scenario in scenarios:
            for seed in seeds:
                runs.append({"params": dict(zip(names, values)), "scenario": scenario,
                             "seed": int(seed)})
    return runs


def configure(params: dict, variant: str) -> PlannerConfig:
    """The variant's configuration with the parameters replaced (validated by the config)."""
    config = PlannerConfig.variant(variant)
    changes: dict = {}
    for name, value in params.items():
        section, field = _resolve_name(name)
        if section == "horizon" and field == "n_steps":
            value = int(value)
        changes.setdefault(section, {})[field] = value
    parts = {s: dataclasses.replace(getattr(config, s), **c) for s, c in changes.items()}
    return dataclasses.replace(config, **parts)


@dataclass(frozen=True)
class SweepSettings:
    """Everything a sweep run depends on besides its parameters, scenario and seed."""

    variant: str = "ds-mpepc"
    solver: str = "nlp"
    n_samples: int | None = None
    duration: float | None = None
    """Cap on every scenario's duration, s (None: the scenario's own)."""
    start_noise: float | None = None
    """Start-position noise (m, std) replacing the scenario's own, so seeds differ (None: keep)."""

    def meta(self) -> dict:
        return {"benchmark": "sweep", "variant": self.variant, "solver": self.solver,
                "n_samples": self.n_samples, "duration": self.duration,
                "start_noise": self.start_noise}


def _key_text(params: dict) -> str:
    return json.dumps({k: float(v) for k, v in sorted(params.items())}, sort_keys=True)


def run_one(run: dict, settings: SweepSettings) -> dict:
    """One run; its row. Exceptions become ``status = "failed"`` with the message."""
    row = {"key": _key_text(run["params"]), **{k: float(v) for k, v in run["params"].items()},
           "scenario": run["scenario"], "seed": run["seed"]}
    if "variant" in run:
        row["variant"] = run["variant"]
    started = time.perf_counter()
    try:
        from ..sim.metrics import episode_metrics
        from ..sim.scenario import load_scenario
        from ..sim.simulate import simulate

        variant = run.get("variant", settings.variant)
        config = configure(run["params"], "ds-mpepc" if variant == "orca" else variant)
        scenario = load_scenario(run["scenario"])
        if settings.duration is not None:
            scenario = dataclasses.replace(scenario,
                                           duration=min(scenario.duration, settings.duration))
        if settings.start_noise is not None:
            scenario = dataclasses.replace(scenario, start_noise=settings.start_noise)
        solver = SolverConfig.named(settings.solver)
        if settings.n_samples:
            solver = dataclasses.replace(solver, n_samples=settings.n_samples)
        rng = np.random.default_rng(run["seed"])
        if variant == "orca":
            from .orca import simulate_orca

            episode = simulate_orca(scenario, config, rng, record_trajectories=False)
        else:
            episode = simulate(scenario, config, solver, rng, record_trajectories=False)
        metrics = episode_metrics(episode)
        outcomes = [m["outcome"] for m in metrics]
        n = len(outcomes)
        times = [m["time_to_goal"] for m in metrics if m["outcome"] == "success"]
        row.update(
            status="ok", outcomes=",".join(outcomes),
            success_rate=outcomes.count("success") / n,
            collision_rate=outcomes.count("collision") / n,
            deadlock_rate=outcomes.count("deadlock") / n,
            timeout_rate=outcomes.count("timeout") / n,
            time_to_goal=float(np.mean(times)) if times else None,
            path_length=float(np.mean([m["path_length"] for m in metrics])),
            min_static_clearance=float(min(m["min_static_clearance"] for m in metrics)),
            min_dynamic_clearance=float(min(m["min_dynamic_clearance"] for m in metrics)),
            plan_time_median=float(np.nanmedian([m["plan_time_median"] for m in metrics])))
    except Exception as exc:
        row.update(status="failed", message=f"{type(exc).__name__}: {exc}")
    row["wall_time"] = time.perf_counter() - started
    return row


def _task(args):
    return run_one(*args)


class ProgressBar:
    """A one-line text bar on a stream (stderr), redrawn in place."""

    def __init__(self, total: int, stream=sys.stderr, width: int = 30):
        self.total, self.stream, self.width = total, stream, width
        self.done = 0
        self.started = time.perf_counter()

    def update(self, note: str = "") -> None:
        self.done += 1
        if self.stream is None:
            return
        filled = int(self.width * self.done / max(self.total, 1))
        elapsed = time.perf_counter() - self.started
        self.stream.write(f"\r[{'#' * filled}{'.' * (self.width - filled)}] "
                          f"{self.done}/{self.total} {elapsed:.0f} s {note[:40]:<40}")
        if self.done >= self.total:
            self.stream.write("\n")
        self.stream.flush()


def _run_processes(tasks, workers):
    if workers == 1:
        yield from map(_task, tasks)
        return
    pool = multiprocessing.get_context("spawn").Pool(workers)
    try:
        yield from pool.imap_unordered(_task, tasks)
    finally:
        pool.terminate()


def _run_dask(tasks, scheduler):
    try:
        from distributed import Client, as_completed
    except ImportError as exc:
        raise ImportError('--scheduler needs Dask: pip install "dsmpepc_nlp[sweep]"') from exc
    with Client(scheduler) as client:
        futures = [client.submit(run_one, *task, pure=False) for task in tasks]
        for future in as_completed(futures):
            yield future.result()


def _execute(todo, table, bar, workers, scheduler) -> None:
    if not todo:
        return
    results = _run_dask(todo, scheduler) if scheduler else _run_processes(
        todo, max(1, min(workers or os.cpu_count() or 1, len(todo))))
    for row in results:
        table.add(row)
        bar.update(f"{Path(row['scenario']).stem} seed {row['seed']}: "
                   f"{row.get('outcomes', row['status'])}")


def run_sweep(params: dict, scenarios, seeds, settings: SweepSettings, out_dir, *,
              workers=None, scheduler=None, resume=False, overwrite=False,
              progress=True) -> dict:
    """Run the grid into ``out_dir``; a summary. ``progress``: True (stderr), a stream or None."""
    progress = sys.stderr if progress is True else progress or None
    if not params:
        raise ValueError("--param: give at least one NAME=V1,V2,...")
    if not scenarios:
        raise ValueError("--scenarios: give at least one scenario")
    from ..sim.scenario import load_scenario

    for name in scenarios:  # a bad name fails here, not as N failed rows
        load_scenario(name)
    meta = dict(settings.meta(), params={k: list(v) for k, v in params.items()})
    table = ResultTable(out_dir, "sweep", ("key", "scenario", "seed"), meta, resume=resume,
                        overwrite=overwrite)
    runs = expand_grid(params, scenarios, seeds)
    todo = [(r, settings) for r in runs
            if not table.done((_key_text(r["params"]), r["scenario"], r["seed"]))]
    bar = ProgressBar(len(todo), progress)
    if progress:
        where = f"Dask at {scheduler}" if scheduler else \
            f"{max(1, min(workers or os.cpu_count() or 1, len(todo) or 1))} process(es)"
        print(f"sweep: {len(runs)} runs, {len(runs) - len(todo)} already done, "
              f"{len(todo)} on {where}", file=progress, flush=True)
    _execute(todo, table, bar, workers, scheduler)
    keys = {(_key_text(r["params"]), r["scenario"], r["seed"]) for r in runs}
    rows = [r for r in table.rows if (r["key"], r["scenario"], r["seed"]) in keys]
    figures = plot_heatmaps(rows, list(params), Path(out_dir))
    ok = [r for r in rows if r["status"] == "ok"]
    return {"runs": len(rows), "failed": len(rows) - len(ok),
            "success_rate": float(np.mean([r["success_rate"] for r in ok])) if ok else math.nan,
            "deadlock_rate": float(np.mean([r["deadlock_rate"] for r in ok])) if ok
            else math.nan,
            "table": str(table.csv_path), "figures": [str(f) for f in figures]}


def rate_grid(rows, x_name: str, y_name: str, value: str) -> tuple:
    """Mean of ``value`` over the ok rows for each (x, y) pair: (xs, ys, grid[y, x]).

    ``y_name = "scenario"`` puts scenarios on the second axis. Failed runs are left out; a
    cell with only failed runs is NaN.
    """
    ok = [r for r in rows if r["status"] == "ok"]
    xs = sorted({r[x_name] for r in rows})
    ys = sorted({r[y_name] for r in rows}, key=str)
    grid = np.full((len(ys), len(xs)), np.nan)
    for j, y in enumerate(ys):
        for i, x in enumerate(xs):
            values = [r[value] for r in ok if r[x_name] == x and r[y_name] == y]
            if values:
                grid[j, i] = float(np.mean(values))
    return xs, ys, grid


def plot_heatmaps(rows, names, out_dir) -> list:
    """Success and deadlock rate per parameter pair (or parameter x scenario), PNG files."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pairs = list(itertools.combinations(names, 2)) or [(names[0], "scenario")]
    paths = []
    for x_name, y_name in pairs:
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.8))
        for ax, value, cmap in ((axes[0], "success_rate", "viridis"),
                                (axes[1], "deadlock_rate", "magma")):
            xs, ys, grid = rate_grid(rows, x_name, y_name, value)
            image = ax.imshow(grid, origin="lower", vmin=0, vmax=1, cmap=cmap, aspect="auto")
            ax.set_xticks(range(len(xs)), [f"{x:g}" for x in xs])
            ax.set_yticks(range(len(ys)), [f"{y:g}" if isinstance(y, float) else
                                           Path(str(y)).stem for y in ys])
            ax.set_xlabel(x_name)
            ax.set_ylabel(y_name)
            ax.set_title(value.replace("_", " "))
            for j in range(len(ys)):
                for i in range(len(xs)):
                    if np.isfinite(grid[j, i]):
                        ax.text(i, j, f"{grid[j, i]:.2f}", ha="center", va="center",
                                color="white" if grid[j, i] < 0.6 else "black", fontsize=8)
            fig.colorbar(image, ax=ax, fraction=0.046)
        fig.tight_layout()
        path = out_dir / f"sweep_{x_name}_{y_name}.png"
        try:
            paths.append(atomic_savefig(fig, path, dpi=110))
        finally:
            plt.close(fig)
    return paths


def run_scenarios(variants, scenarios, seeds, settings: SweepSettings, out_dir, *,
                  workers=None, scheduler=None, resume=False, overwrite=False,
                  progress=True) -> dict:
    """Planner variants (``orca`` included) side by side on scenarios x seeds.

    The table is ``scenarios.{json,csv}`` keyed by (variant, scenario, seed); the summary has,
    per variant and scenario, the rates over seeds and robots.
    """
    from .orca import check_variants
    from ..sim.scenario import load_scenario

    progress = sys.stderr if progress is True else progress or None
    check_variants(variants)
    for name in scenarios:
        load_scenario(name)
    meta = dict(settings.meta(), benchmark="scenarios")
    meta.pop("variant")
    table = ResultTable(out_dir, "scenarios", ("variant", "scenario", "seed"), meta,
                        resume=resume, overwrite=overwrite)
    runs = [{"params": {}, "variant": v, "scenario": s, "seed": int(k)}
            for v in variants for s in scenarios for k in seeds]
    todo = [(r, settings) for r in runs if not table.done((r["variant"], r["scenario"],
                                                          r["seed"]))]
    if progress:
        print(f"scenarios: {len(runs)} runs, {len(runs) - len(todo)} already done",
              file=progress, flush=True)
    _execute(todo, table, ProgressBar(len(todo), progress), workers, scheduler)
    summary: dict = {"runs": len(runs), "variants": {}}
    for v in variants:
        per = {}
        for name in scenarios:
            rows = [r for r in table.rows if r["variant"] == v and r["scenario"] == name
                    and r["seed"] in set(int(k) for k in seeds)]
            ok = [r for r in rows if r["status"] == "ok"]

            def mean(key, rows=ok):
                values = [r[key] for r in rows if r.get(key) is not None]
                return float(np.mean(values)) if values else math.nan

            per[Path(name).stem] = {
                "runs": len(rows), "failed": len(rows) - len(ok),
                **{k: mean(k) for k in ("success_rate", "collision_rate", "deadlock_rate",
                                        "timeout_rate", "time_to_goal")},
                "min_dynamic_clearance": min((r["min_dynamic_clearance"] for r in ok
                                              if r.get("min_dynamic_clearance") is not None),
                                             default=math.nan)}
        summary["variants"][v] = per
    summary["table"] = str(table.csv_path)
    return summary
