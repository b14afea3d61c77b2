"""The claim map: where does DS-MPEPC resolve a deadlock that MPEPC falls into?

Runs the generated scenario families (:mod:`dsmpepc_nlp.sim.families`) cell by cell for the
planner variants (``mpepc``, ``ds-mpepc``, ``pc-only``, ``terminal-only``) and solvers
(``sampling``, ``nlp``), every cell with several seeds (each seed its own 0.1 m start
perturbation). The cells are written as scenario files under ``OUT/scenarios/`` (a user opens
any of them with ``dsmpepc run FILE``), every run is a row of the resumable table
``OUT/claims.{json,csv}`` (run through :func:`~dsmpepc_nlp.bench.runner.run_all`), and the
per-cell summary ``OUT/claims_cells.{json,csv}`` gives each cell's rates per variant and a
verdict comparing DS-MPEPC with MPEPC:

``claim``       DS-MPEPC succeeds in most seeds, MPEPC fails in most, mostly by deadlock;
``ds-mpepc``    DS-MPEPC succeeds in most seeds, MPEPC fails in most, but not mostly by deadlock;
``both pass``   both succeed in most seeds;
``both fail``   neither does;
``mpepc``       MPEPC succeeds in most seeds, DS-MPEPC does not.

The figure ``OUT/claims_<solver>.png`` draws the rates against the geometry, one column per
family; ``OUT/example-*.png`` shows, in the paper's style, one run (cell and seed) where the
variants' outcomes differ, re-simulated with its trajectories.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.config import PlannerConfig, SolverConfig
from ..core.files import atomic_write_text
from ..core.jsonio import dumps
from ..sim import families
from ..sim.scenario import load_scenario
from ..sim.simulate import simulate
from ..viz import figures
from .results import ResultTable, rows_to_csv
from .runner import mean, run_all
from .sweep import SweepSettings, run_one

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

    def meta(self) -> dict:
        return {"benchmark": "claims", "n_samples": self.n_samples, "duration": self.duration}


def run_cell(cell: tuple, variant: str, solver: str, seed: int, path: str,
             settings: ClaimSettings) -> dict:
    """One run of a cell (its scenario file at ``path``); the row, failures recorded in it."""
    name, x, y = cell
    family = families.family(name)
    sweep_settings = SweepSettings(variant=variant, solver=solver, n_samples=settings.n_samples,
                                   duration=settings.duration)
    row = run_one({"params": {}, "variant": variant, "scenario": path, "seed": int(seed)},
                  sweep_settings)
    row.pop("key", None)
    row.update(scenario=Path(path).stem, family=name, axis=family.axis, x=x, axis2=family.axis2,
               y=y, solver=solver)
    return row


def _describe(row) -> str:
    return f"{row['scenario']} {row['variant']} {row['solver']}: " \
           f"{row.get('outcomes', row['status'])}"


def run_claims(cells, variants, solvers, seeds, settings: ClaimSettings, out_dir, *,
               workers=None, resume=False, overwrite=False, progress=True,
               examples=True) -> dict:
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
        Re-run one differing run with its trajectories and draw it (paper style).
    """
    out = Path(out_dir)
    paths = {cell: str(families.save(*cell, out / "scenarios")) for cell in cells}
    meta = dict(settings.meta(), variants=list(variants), solvers=list(solvers))
    table = ResultTable(out, "claims", ("scenario", "variant", "solver", "seed"), meta,
                        resume=resume, overwrite=overwrite)
    tasks = [(cell, v, s, int(k), paths[cell], settings)
             for cell in cells for s in solvers for v in variants for k in seeds]
    run_all(run_cell, tasks, table, label="claims",
            key=lambda t: (Path(t[4]).stem, t[1], t[2], t[3]), workers=workers,
            progress=progress, describe=_describe)
    wanted = {(Path(t[4]).stem, t[1], t[2], t[3]) for t in tasks}
    rows = [r for r in table.rows if (r["scenario"], r["variant"], r["solver"], r["seed"])
            in wanted]
    summary_rows = cell_summary(rows)
    atomic_write_text(out / "claims_cells.json", dumps({"cells": summary_rows}))
    atomic_write_text(out / "claims_cells.csv", rows_to_csv(summary_rows))
    claim_map_figure = figures("claims").claim_map_figure
    drawn = [str(claim_map_figure([r for r in summary_rows if r["solver"] == s],
                                    out / f"claims_{s}.png", title=f"claim map ({s})"))
               for s in solvers]
    summary = {"runs": len(rows), "failed": sum(r["status"] != "ok" for r in rows),
               "verdicts": verdict_counts(summary_rows), "claim_cells": list(dict.fromkeys(
                   f"{r['scenario']} ({r['solver']})" for r in summary_rows
                   if r.get("verdict") == "claim")),
               "table": str(table.csv_path), "cells_table": str(out / "claims_cells.csv"),
               "figures": drawn}
    if examples:
        example = pick_example(rows)
        if example is not None:
            summary["example"] = str(draw_example(example, paths, variants, settings, out))
    return summary


def cell_summary(rows) -> list:
    """One row per (cell, solver, variant): seeds, failed runs and the mean rates over the
    seeds; the ``mpepc`` and ``ds-mpepc`` rows of a cell carry the cell's ``verdict``."""
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["family"], r["x"], r["y"], r["solver"], r["variant"]), []).append(r)
    out = []
    for (name, x, y, solver, variant), group in sorted(groups.items(), key=lambda kv: (
            kv[0][0], kv[0][3], kv[0][2], kv[0][1], kv[0][4])):
        ok = [r for r in group if r["status"] == "ok"]
        out.append({"family": name, "axis": group[0]["axis"], "x": x, "axis2": group[0]["axis2"],
                    "y": y, "scenario": group[0]["scenario"], "solver": solver,
                    "variant": variant, "seeds": len(group), "failed": len(group) - len(ok),
                    **{k: mean(ok, k) for k in RATES}})
    by_cell: dict = {}
    for r in out:
        by_cell.setdefault((r["scenario"], r["solver"]), {})[r["variant"]] = r
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
    """``{solver: {family: {verdict: number of cells}}}``."""
    counts: dict = {}
    seen = set()
    for r in summary_rows:
        key = (r["scenario"], r["solver"])
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


def draw_example(example, paths, variants, settings: ClaimSettings, out: Path) -> Path:
    """Re-simulate one run for every variant with its trajectories; the side-by-side figure."""
    scenario_name, solver_name, seed = example
    path = next(p for p in paths.values() if Path(p).stem == scenario_name)
    scenario = load_scenario(path)
    if settings.duration is not None:
        scenario = dataclasses.replace(scenario, duration=min(scenario.duration,
                                                              settings.duration))
    solver = SolverConfig.named(solver_name)
    if settings.n_samples:
        solver = dataclasses.replace(solver, n_samples=settings.n_samples)
    episodes = {v: simulate(scenario, PlannerConfig.variant(v), solver,
                            np.random.default_rng(seed)) for v in variants}
    return figures().compare_figure(episodes, path=out / f"example-{scenario_name}-{solver_name}"
                                f"-seed{seed}.png")
