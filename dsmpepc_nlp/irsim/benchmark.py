"""``dsmpepc benchmark irsim``: IR-SIM worlds x seeds through the benchmarks' one runner.

Every (world file, seed) is one run of :func:`~.runner.run_world` under IR-SIM's own judgement
(its arrive and collision flags, the time limit), one row of ``OUT/irsim.{csv,json}``
(:class:`~dsmpepc_nlp.bench.results.ResultTable`: resumable, written after every row), run by
:func:`~dsmpepc_nlp.bench.runner.run_all` on local processes or a Dask cluster. An
unsuccessful run keeps its episode (the product's :class:`~dsmpepc_nlp.sim.episode.Episode`,
:mod:`.episode`) in ``OUT/episodes/``, so ``dsmpepc failures OUT`` classifies it as it does our
own simulator's. A world written by ``dsmpepc irsim-export barn`` (``custom.barn_world``) also
gets its BARN index as ``world`` and the challenge's score.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path

from ..bench import barn
from ..bench.results import ResultTable, keep_failure
from ..bench.runner import mean, outcome_rates, plan_time_summary, run_all
from ..core.errors import InputError
from .loading import require_irsim
from .runner import run_world

KEY_FIELDS = ("scenario", "seed", "variant", "solver")
"""A row's identity: the world file's stem, the seed, the planner."""
METRIC_COLUMNS = ("path_length", "shortest_path_length", "spl", "min_static_clearance",
                  "min_dynamic_clearance", "collision_kind", "collided_with",
                  "plan_time_median", "plan_time_p95", "plan_time_p99", "plan_time_max",
                  "plans_out_of_time", "nlp_plans", "fallback_plans", "cycles")
"""The run's metrics (:meth:`~.record.EpisodeLog.metrics`) copied into its row."""


@dataclass(frozen=True)
class IrsimSettings:
    """Everything a run depends on besides the world and the seed (stored with the table)."""

    variant: str = "ds-mpepc"
    solver: str = "nlp"
    sensing: str = "oracle"
    max_time: float | None = None
    """Time limit, s; None: each world's ``custom.max_time``, else 60 s."""
    time_budget: float | str | None = "auto"
    """Each plan's time budget (``--time-budget``; ``SolverConfig.time_budget``)."""

    def meta(self) -> dict:
        meta = {"benchmark": "irsim", "variant": self.variant, "solver": self.solver,
                "sensing": self.sensing, "max_time": self.max_time}
        if self.time_budget != "auto":
            meta["time_budget"] = "none" if self.time_budget is None else self.time_budget
        return meta


def _natural(path: Path) -> tuple:
    """Sort key: ``barn-9`` before ``barn-10``."""
    return tuple(int(part) if part.isdigit() else part for part in re.split(r"(\d+)", path.name))


def world_paths(specs) -> list[Path]:
    """The world files of ``--worlds``: each a YAML file, or a folder of them (its ``*.yaml``
    and ``*.yml``, in natural order); InputError for a missing one, an empty folder, or two
    worlds of the same stem (a row is keyed by the stem)."""
    found = []
    for spec in specs:
        path = Path(spec)
        if path.is_dir():
            inside = sorted((p for p in path.iterdir() if p.suffix in (".yaml", ".yml")
                             and p.is_file()), key=_natural)
            if not inside:
                raise InputError(f"--worlds {spec!r}: a folder without IR-SIM world files "
                                 "(*.yaml)")
            found += inside
        elif path.is_file():
            found.append(path)
        else:
            raise InputError(f"--worlds {spec!r}: no such file or folder")
    stems: dict = {}
    for path in found:
        if path.stem in stems and stems[path.stem] != path.resolve():
            raise InputError(f"--worlds: {stems[path.stem]} and {path} have the same name "
                             f"{path.stem!r}; a table keys its rows by the world's name")
        stems[path.stem] = path.resolve()
    return [Path(p) for p in dict.fromkeys(stems.values())]


def run_case(path: str, seed: int, settings: IrsimSettings, out_dir=None) -> dict:
    """One run's row (never raises: an exception becomes ``outcome = error`` with its message);
    an unsuccessful run's episode is kept in ``out_dir``."""
    stem = Path(path).stem
    row = {"scenario": stem, "seed": int(seed), "variant": settings.variant,
           "solver": settings.solver, "sensing": settings.sensing}
    started = time.perf_counter()
    try:
        summary = run_world(path, sensing=settings.sensing, variant=settings.variant,
                            solver=settings.solver, seed=int(seed), max_time=settings.max_time,
                            save=False, episode=True, progress=False,
                            time_budget=settings.time_budget)
        m, custom = summary["metrics"][0], summary["_custom"]
        if isinstance(custom.get("barn_world"), int):
            row["world"] = custom["barn_world"]
        success = m["outcome"] == "success"
        row.update(outcome=m["outcome"], time=m["outcome_time"],
                   **{key: m[key] for key in METRIC_COLUMNS})
        reference = custom.get("reference_path_length")
        if isinstance(reference, (int, float)) and reference > 0:
            row.update(score=barn.score(success, m["outcome_time"], float(reference)),
                       score_2020=barn.score(success, m["outcome_time"], float(reference), 4.0),
                       reference_path_length=float(reference))
        row["episode_file"] = keep_failure(summary["_episode"], out_dir,
                                           f"{stem}-{settings.variant}-{settings.solver}-"
                                           f"{settings.sensing}-seed{seed}")
    except Exception as exc:  # recorded, not dropped: the table says what failed
        row.update(outcome="error", message=f"{type(exc).__name__}: {exc}")
    row["world_file"] = str(path)
    row["wall_time"] = time.perf_counter() - started
    return row


def summarise(rows) -> dict:
    """Rates and means over the rows (``error`` rows count as failures)."""
    summary = {"runs": len(rows), **outcome_rates(r["outcome"] for r in rows),
               "mean_time_success": mean(rows, "time", lambda r: r["outcome"] == "success"),
               "mean_path_length_success": mean(rows, "path_length",
                                                lambda r: r["outcome"] == "success"),
               **plan_time_summary(rows)}
    if rows and all("score" in r for r in rows):
        summary["mean_score"] = mean(rows, "score")
    return summary


def run_benchmark(settings: IrsimSettings, paths, seeds, out_dir, *, workers=None,
                  scheduler=None, resume=False, overwrite=False, progress=True) -> tuple:
    """Run every world of ``paths`` with every seed into ``out_dir/irsim.{csv,json}``; the rows
    of this run (in world, then seed order) and their summary."""
    require_irsim()                  # one line when IR-SIM is missing, before any table
    paths = [Path(p) for p in paths]
    table = ResultTable(out_dir, "irsim", KEY_FIELDS, settings.meta(), resume=resume,
                        overwrite=overwrite)
    tasks = [(str(p), int(s), settings, str(out_dir)) for p in paths for s in seeds]
    run_all(run_case, tasks, table, label="irsim",
            key=lambda task: (Path(task[0]).stem, task[1], settings.variant, settings.solver),
            workers=workers, scheduler=scheduler, progress=progress,
            describe=lambda row: f"{row['scenario']} seed {row['seed']}: {row['outcome']}")
    order = {(p.stem, int(s)): k for k, (p, s) in enumerate((p, s) for p in paths
                                                             for s in seeds)}
    rows = [r for r in table.rows if (r["scenario"], r["seed"]) in order
            and r["variant"] == settings.variant and r["solver"] == settings.solver]
    rows.sort(key=lambda r: order[(r["scenario"], r["seed"])])
    return rows, summarise(rows)
