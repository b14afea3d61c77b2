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
import hashlib
import itertools
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..sim.metrics import episode_metrics
from ..sim.scenario import load_scenario
from ..sim.simulate import simulate
from ..viz import figures
from .orca import check_variants, simulate_orca
from .params import configure, solver_of
from .results import ResultTable, keep_failure
from .runner import mean, outcome_rates, plan_time_summary, run_all


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
    preset: str = "product"
    """``product`` or ``paper`` (:data:`~dsmpepc_nlp.bench.params.PRESETS`)."""
    sensing: str = "oracle"
    """What the robot senses (``--sensing``): a built-in profile or a profile file
    (:mod:`dsmpepc_nlp.sim.sensing`); ``oracle``, the truth, by default."""
    time_budget: float | str | None = "auto"
    """Each plan's time budget (``--time-budget``; ``SolverConfig.time_budget``)."""

    def meta(self) -> dict:
        meta = {"benchmark": "sweep", "variant": self.variant, "solver": self.solver,
                "n_samples": self.n_samples, "duration": self.duration,
                "start_noise": self.start_noise, "preset": self.preset}
        if self.time_budget != "auto":
            meta["time_budget"] = "none" if self.time_budget is None else self.time_budget
        return meta if self.sensing == "oracle" else dict(meta, sensing=self.sensing)


def _key_text(params: dict) -> str:
    return json.dumps({k: float(v) for k, v in sorted(params.items())}, sort_keys=True)


def run_one(run: dict, settings: SweepSettings, out_dir=None) -> dict:
    """One run; its row. Exceptions become ``status = "failed"`` with the message. An
    unsuccessful run's episode is kept in ``out_dir`` (:func:`~.results.keep_failure`)."""
    row = {"key": _key_text(run["params"]), **{k: float(v) for k, v in run["params"].items()},
           "scenario": run["scenario"], "seed": run["seed"]}
    if "variant" in run:
        row["variant"] = run["variant"]
    started = time.perf_counter()
    try:
        variant = run.get("variant", settings.variant)
        config = configure(run["params"], "ds-mpepc" if variant == "orca" else variant,
                           settings.preset)
        scenario = load_scenario(run["scenario"])
        if settings.duration is not None:
            scenario = dataclasses.replace(scenario,
                                           duration=min(scenario.duration, settings.duration))
        if settings.start_noise is not None:
            scenario = dataclasses.replace(scenario, start_noise=settings.start_noise)
        solver = solver_of(settings)
        rng = np.random.default_rng(run["seed"])
        if variant == "orca":
            episode = simulate_orca(scenario, config, rng, record_trajectories=False,
                                    sensing=settings.sensing)
        else:
            episode = simulate(scenario, config, solver, rng, record_trajectories=False,
                               sensing=settings.sensing)
        metrics = episode_metrics(episode)
        outcomes = [m["outcome"] for m in metrics]
        times = [m["time_to_goal"] for m in metrics if m["outcome"] == "success"]
        row.update(
            status="ok", outcomes=",".join(outcomes),
            **outcome_rates(outcomes, ("success", "collision", "deadlock", "timeout")),
            time_to_goal=float(np.mean(times)) if times else None,
            path_length=float(np.mean([m["path_length"] for m in metrics])),
            min_static_clearance=float(min(m["min_static_clearance"] for m in metrics)),
            min_dynamic_clearance=float(min(m["min_dynamic_clearance"] for m in metrics)),
            plan_time_median=float(np.nanmedian([m["plan_time_median"] for m in metrics])),
            plan_time_p95=float(np.nanpercentile([m["plan_time_p95"] for m in metrics], 95)),
            plan_time_p99=float(np.nanpercentile([m["plan_time_p99"] for m in metrics], 99)),
            plan_time_max=float(np.nanmax([m["plan_time_max"] for m in metrics])),
            episode_file=keep_failure(episode, out_dir, _stem(run, variant)))
    except Exception as exc:
        row.update(status="failed", message=f"{type(exc).__name__}: {exc}")
    row["wall_time"] = time.perf_counter() - started
    return row


def _stem(run: dict, variant: str) -> str:
    """File stem of a run's kept episode: variant, scenario, seed (and the parameters' hash)."""
    stem = f"{variant}-{Path(run['scenario']).stem}-seed{run['seed']}"
    if run["params"]:
        stem += "-" + hashlib.sha1(_key_text(run["params"]).encode()).hexdigest()[:10]
    return stem


def _describe(row) -> str:
    return f"{Path(row['scenario']).stem} seed {row['seed']}: {row.get('outcomes', row['status'])}"


def run_sweep(params: dict, scenarios, seeds, settings: SweepSettings, out_dir, *,
              workers=None, scheduler=None, resume=False, overwrite=False,
              progress=True) -> dict:
    """Run the grid into ``out_dir``; a summary. ``progress``: True (stderr), a
    stream or None (nowhere)."""
    if not params:
        raise InputError("--param: give at least one NAME=V1,V2,...")
    if not scenarios:
        raise InputError("--scenarios: give at least one scenario")
    for name in scenarios:  # a bad name fails here, not as N failed rows
        load_scenario(name)
    meta = dict(settings.meta(), params={k: list(v) for k, v in params.items()})
    table = ResultTable(out_dir, "sweep", ("key", "scenario", "seed"), meta, resume=resume,
                        overwrite=overwrite)
    runs = expand_grid(params, scenarios, seeds)
    run_all(run_one, [(r, settings, str(out_dir)) for r in runs], table, label="sweep",
            key=lambda task: (_key_text(task[0]["params"]), task[0]["scenario"],
                              task[0]["seed"]),
            workers=workers, scheduler=scheduler, progress=progress, describe=_describe)
    keys = {(_key_text(r["params"]), r["scenario"], r["seed"]) for r in runs}
    rows = [r for r in table.rows if (r["key"], r["scenario"], r["seed"]) in keys]
    figures = plot_heatmaps(rows, list(params), Path(out_dir))
    ok = [r for r in rows if r["status"] == "ok"]
    return {"runs": len(rows), "failed": len(rows) - len(ok),
            "success_rate": mean(ok, "success_rate"), "deadlock_rate": mean(ok, "deadlock_rate"),
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
    pairs = list(itertools.combinations(names, 2)) or [(names[0], "scenario")]
    paths = []
    for x_name, y_name in pairs:
        grids = [(value, *rate_grid(rows, x_name, y_name, value))
                 for value in ("success_rate", "deadlock_rate")]
        paths.append(figures("results").heatmap_figure(x_name, y_name, grids,
                                    Path(out_dir) / f"sweep_{x_name}_{y_name}.png"))
    return paths


def run_scenarios(variants, scenarios, seeds, settings: SweepSettings, out_dir, *,
                  workers=None, scheduler=None, resume=False, overwrite=False,
                  progress=True, params=None) -> dict:
    """Planner variants (``orca`` included) side by side on scenarios x seeds, each with the
    configuration fields ``params`` (``{name: value}``, ``--set``) replaced.

    The table is ``scenarios.{json,csv}`` keyed by (variant, scenario, seed); the summary has,
    per variant and scenario, the rates over seeds and robots and the plan times
    (:func:`~dsmpepc_nlp.bench.runner.plan_time_summary` over the runs). ``progress``: True
    (stderr), a stream or None (nowhere).
    """
    check_variants(variants)
    for name in scenarios:
        load_scenario(name)
    params = dict(params or {})
    meta = dict(settings.meta(), benchmark="scenarios")
    meta.pop("variant")
    if params:
        meta["overrides"] = params
    table = ResultTable(out_dir, "scenarios", ("variant", "scenario", "seed"), meta,
                        resume=resume, overwrite=overwrite)
    runs = [{"params": params, "variant": v, "scenario": s, "seed": int(k)}
            for v in variants for s in scenarios for k in seeds]
    run_all(run_one, [(r, settings, str(out_dir)) for r in runs], table,
            label="scenarios",
            key=lambda task: (task[0]["variant"], task[0]["scenario"], task[0]["seed"]),
            workers=workers, scheduler=scheduler, progress=progress, describe=_describe)
    summary: dict = {"runs": len(runs), "variants": {}}
    wanted = set(int(k) for k in seeds)
    for v in variants:
        per = {}
        for name in scenarios:
            rows = [r for r in table.rows if r["variant"] == v and r["scenario"] == name
                    and r["seed"] in wanted]
            ok = [r for r in rows if r["status"] == "ok"]
            per[Path(name).stem] = {
                "runs": len(rows), "failed": len(rows) - len(ok),
                **{k: mean(ok, k) for k in ("success_rate", "collision_rate", "deadlock_rate",
                                            "timeout_rate", "time_to_goal")},
                "min_dynamic_clearance": min((r["min_dynamic_clearance"] for r in ok
                                              if r.get("min_dynamic_clearance") is not None),
                                             default=math.nan),
                **plan_time_summary(ok)}
        summary["variants"][v] = per
    summary["table"] = str(table.csv_path)
    return summary
