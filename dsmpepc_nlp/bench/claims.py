"""The claim map: where does DS-MPEPC resolve a deadlock that MPEPC falls into?

Runs the generated scenario families (:mod:`dsmpepc_nlp.sim.families`) cell by cell for the
planner variants (``mpepc``, ``ds-mpepc``, ``pc-only``, ``terminal-only``) and solvers
(``sampling``, ``nlp``), every cell with several seeds (each seed its own 0.1 m start
perturbation) and, when asked, several parameter settings (``--set s_ttc=0.25,0.5,1``: every
combination, as ``sweep --param`` takes them; a run's ``params`` names its setting). The cells
are written as scenario files under ``OUT/scenarios/`` (a user opens any of them with ``dsmpepc
run FILE``), every run is a row of the resumable table ``OUT/claims.{json,csv}`` (run through
:func:`~dsmpepc_nlp.bench.runner.run_all`), and the per-cell summary
``OUT/claims_cells.{json,csv}`` gives each cell's rates per variant and a verdict comparing
DS-MPEPC with MPEPC:

``claim``       DS-MPEPC succeeds in most seeds, MPEPC fails in most, mostly by deadlock;
``ds-mpepc``    DS-MPEPC succeeds in most seeds, MPEPC fails in most, but not mostly by deadlock;
``both pass``   both succeed in most seeds;
``both fail``   neither does;
``mpepc``       MPEPC succeeds in most seeds, DS-MPEPC does not.

The figure ``OUT/claims_<solver>.png`` draws the rates against the geometry, one column per
family (the first parameter setting), and with several settings
``OUT/claims_<solver>_settings.png`` each setting's success and deadlock rates;
``OUT/example-*.png`` shows, in the paper's style, one run (cell and seed) where the
variants' outcomes differ, re-simulated with its trajectories.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.files import atomic_write_text
from ..core.jsonio import dumps
from ..core.solver_config import SolverConfig
from ..sim import families
from ..sim.scenario import load_scenario
from ..sim.simulate import simulate
from ..viz import figures
from .params import configure
from .results import ResultTable, rows_to_csv
from .runner import mean, run_all
from .sweep import SweepSettings, _key_text, expand_grid, run_one

CLAIM_VARIANTS = ("mpepc", "ds-mpepc", "pc-only", "terminal-only")
CLAIM_SOLVERS = ("sampling", "nlp")
RATES = ("success_rate", "deadlock_rate", "collision_rate", "timeout_rate")
MAJORITY = 0.5
"""A variant 'passes' a cell when its success rate over the seeds is above this."""


@dataclass(frozen=True)
class ClaimSettings:
    """What every run of the map shares besides its cell, variant, solver and seed."""

    n_samples: int | None = None
    """Samples per plan of the sampling solver (None: SolverConfig's)."""
    duration: float | None = None
    """Cap on every cell's duration, s (None: the family's own)."""
    preset: str = "paper"
    """The claim map tests the paper's claims: its values, none of our extensions (``--param``
    turns one on, e.g. ``sigma_static_from_map=1``)."""

    def meta(self) -> dict:
        return {"benchmark": "claims", "n_samples": self.n_samples, "duration": self.duration,
                "preset": self.preset}


def run_cell(cell: tuple, variant: str, solver: str, seed: int, path: str,
             settings: ClaimSettings, params: dict | None = None) -> dict:
    """One run of a cell (its scenario file at ``path``) with the configuration fields
    ``params`` replaced (:func:`~dsmpepc_nlp.bench.params.configure`); the row, failures
    recorded in it."""
    name, x, y = cell
    family = families.family(name)
    sweep_settings = SweepSettings(variant=variant, solver=solver, n_samples=settings.n_samples,
                                   duration=settings.duration, preset=settings.preset)
    row = run_one({"params": dict(params or {}), "variant": variant, "scenario": path,
                   "seed": int(seed)}, sweep_settings)
    row["params"] = row.pop("key")
    row.update(scenario=Path(path).stem, family=name, axis=family.axis, x=x, axis2=family.axis2,
               y=y, solver=solver)
    return row


def settings_grid(params: dict | None) -> list:
    """Every combination of the parameter values ``{name: [values]}`` (one empty setting
    when there are none)."""
    return [run["params"] for run in expand_grid(params or {}, [None], [0])]


def _describe(row) -> str:
    setting = "" if row.get("params", "{}") == "{}" else f" {row['params']}"
    return f"{row['scenario']} {row['variant']} {row['solver']}{setting}: " \
           f"{row.get('outcomes', row['status'])}"


def _run_key(row) -> tuple:
    return (row["scenario"], row["variant"], row["solver"], row["params"], row["seed"])


def run_claims(cells, variants, solvers, seeds, settings: ClaimSettings, out_dir, *,
               workers=None, resume=False, overwrite=False, progress=True,
               examples=True, params: dict | None = None) -> dict:
    """Run the map into ``out_dir``; its summary (verdict counts, files).

    Parameters
    ----------
    cells : list of (family, x, y)
        The cells (:func:`~dsmpepc_nlp.sim.families.cells`).
    variants, solvers : sequence of str
    seeds : sequence of int
    settings : ClaimSettings
    out_dir : path
    workers, resume, overwrite, progress
        As for :func:`~dsmpepc_nlp.bench.runner.run_all` and
        :class:`~dsmpepc_nlp.bench.results.ResultTable`.
    examples : bool
        Re-run one differing run with its trajectories and draw it (paper style; the first
        parameter setting).
    params : dict, optional
        ``{field: [values]}`` as :func:`~dsmpepc_nlp.bench.params.parse_params` returns them:
        every combination is a setting, each run for every cell, variant, solver and seed.
    """
    grid = settings_grid(params)
    for setting in grid:  # a bad value fails here, not in every run
        for variant in variants:
            configure(setting, variant, settings.preset)
    out = Path(out_dir)
    paths = {cell: str(families.save(*cell, out / "scenarios")) for cell in cells}
    meta = dict(settings.meta(), variants=list(variants), solvers=list(solvers),
                params={k: list(v) for k, v in (params or {}).items()})
    table = ResultTable(out, "claims", ("scenario", "variant", "solver", "params", "seed"),
                        meta, resume=resume, overwrite=overwrite)
    tasks = [(cell, v, s, int(k), paths[cell], settings, p)
             for cell in cells for s in solvers for p in grid for v in variants for k in seeds]

    def task_key(t):
        return (Path(t[4]).stem, t[1], t[2], _key_text(t[6]), t[3])

    run_all(run_cell, tasks, table, label="claims", key=task_key, workers=workers,
            progress=progress, describe=_describe)
    wanted = {task_key(t) for t in tasks}
    rows = [r for r in table.rows if _run_key(r) in wanted]
    summary_rows = cell_summary(rows)
    atomic_write_text(out / "claims_cells.json", dumps({"cells": summary_rows}))
    atomic_write_text(out / "claims_cells.csv", rows_to_csv(summary_rows))
    claim_map_figure = figures("claims").claim_map_figure
    first = _key_text(grid[0])
    drawn = [str(claim_map_figure([r for r in summary_rows
                                   if r["solver"] == s and r["params"] == first],
                                    out / f"claims_{s}.png", title=f"claim map ({s})"))
               for s in solvers]
    if len(grid) > 1:
        setting_figure = figures("claims").setting_figure
        drawn += [str(setting_figure([r for r in summary_rows if r["solver"] == s],
                                     out / f"claims_{s}_settings.png",
                                     title=f"parameter settings ({s})")) for s in solvers]
    summary = {"runs": len(rows), "failed": sum(r["status"] != "ok" for r in rows),
               "verdicts": verdict_counts(summary_rows), "claim_cells": list(dict.fromkeys(
                   f"{r['scenario']} ({r['solver']}{_setting(r['params'])})" for r in summary_rows
                   if r.get("verdict") == "claim")),
               "table": str(table.csv_path), "cells_table": str(out / "claims_cells.csv"),
               "figures": drawn}
    if examples:
        example = pick_example([r for r in rows if r["params"] == first])
        if example is not None:
            summary["example"] = str(draw_example(example, paths, variants, settings, out,
                                                  grid[0]))
    return summary


def cell_summary(rows) -> list:
    """One row per (cell, solver, variant): seeds, failed runs and the mean rates over the
    seeds (per parameter setting, ``params``); the ``mpepc`` and ``ds-mpepc`` rows of a cell
    and setting carry its ``verdict``."""
    groups: dict = {}
    for r in rows:
        key = (r["family"], r["x"], r["y"], r["solver"], r.get("params", "{}"), r["variant"])
        groups.setdefault(key, []).append(r)
    out = []
    for (name, x, y, solver, params, variant), group in sorted(groups.items(), key=lambda kv: (
            kv[0][0], kv[0][3], kv[0][4], kv[0][2], kv[0][1], kv[0][5])):
        ok = [r for r in group if r["status"] == "ok"]
        out.append({"family": name, "axis": group[0]["axis"], "x": x, "axis2": group[0]["axis2"],
                    "y": y, "scenario": group[0]["scenario"], "solver": solver,
                    "params": params, "variant": variant, "seeds": len(group),
                    "failed": len(group) - len(ok), **{k: mean(ok, k) for k in RATES}})
    by_cell: dict = {}
    for r in out:
        by_cell.setdefault((r["scenario"], r["solver"], r["params"]), {})[r["variant"]] = r
    for variants in by_cell.values():
        verdict_ = verdict(variants.get("ds-mpepc"), variants.get("mpepc"))
        for r in variants.values():
            r["verdict"] = verdict_
    return out


def verdict(ds: dict | None, mp: dict | None) -> str | None:
    """The cell's verdict (see the module docstring) from the two variants' mean rates."""
    if ds is None or mp is None or not np.isfinite(ds["success_rate"]) \
            or not np.isfinite(mp["success_rate"]):
        return None
    ds_pass, mp_pass = ds["success_rate"] > MAJORITY, mp["success_rate"] > MAJORITY
    if ds_pass and mp_pass:
        return "both pass"
    if not ds_pass and not mp_pass:
        return "both fail"
    if mp_pass:
        return "mpepc"
    return "claim" if mp["deadlock_rate"] > MAJORITY else "ds-mpepc"


def verdict_counts(summary_rows) -> dict:
    """``{solver: {family: {verdict: number of cells}}}`` (cells times parameter settings)."""
    counts: dict = {}
    seen = set()
    for r in summary_rows:
        key = (r["scenario"], r["solver"], r.get("params", "{}"))
        if r.get("verdict") is None or key in seen:
            continue
        seen.add(key)
        per = counts.setdefault(r["solver"], {}).setdefault(r["family"], {})
        per[r["verdict"]] = per.get(r["verdict"], 0) + 1
    return counts


def pick_example(rows):
    """A run (scenario, solver, seed) where the variants' outcomes differ: a DS-MPEPC success
    beside an MPEPC deadlock first, the sampler's runs before the NLP's; None if none differs."""
    runs: dict = {}
    for r in rows:
        if r["status"] == "ok":
            runs.setdefault((r["scenario"], r["solver"], r["seed"]), {})[r["variant"]] = \
                r["outcomes"]

    def rank(item):
        (scenario, solver, seed), outcomes = item
        ds, mp = outcomes.get("ds-mpepc", ""), outcomes.get("mpepc", "")
        claim = "success" in ds and "deadlock" in mp
        return (not claim, solver != "sampling", scenario, seed)

    differing = [item for item in runs.items() if len(set(item[1].values())) > 1]
    return min(differing, key=rank)[0] if differing else None


def _setting(params: str) -> str:
    return "" if params == "{}" else f", {params}"


def draw_example(example, paths, variants, settings: ClaimSettings, out: Path,
                 params: dict | None = None) -> Path:
    """Re-simulate one run for every variant (with the fields ``params`` replaced) with its
    trajectories; the side-by-side figure."""
    scenario_name, solver_name, seed = example
    path = next(p for p in paths.values() if Path(p).stem == scenario_name)
    scenario = load_scenario(path)
    if settings.duration is not None:
        scenario = dataclasses.replace(scenario, duration=min(scenario.duration,
                                                              settings.duration))
    solver = SolverConfig.named(solver_name)
    if settings.n_samples:
        solver = dataclasses.replace(solver, n_samples=settings.n_samples)
    episodes = {v: simulate(scenario, configure(params or {}, v), solver,
                            np.random.default_rng(seed)) for v in variants}
    return figures().compare_figure(episodes, path=out / f"example-{scenario_name}-{solver_name}"
                                f"-seed{seed}.png")
