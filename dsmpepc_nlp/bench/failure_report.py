"""``dsmpepc failures OUT_DIR``: classify every unsuccessful run of a benchmark's ``--out``.

Reads every result table in the folder (``<stem>.json`` written by
:class:`~dsmpepc_nlp.bench.results.ResultTable`), takes the rows that did not succeed, loads the
episode each kept (the row's ``episode_file``, :func:`~dsmpepc_nlp.bench.results.keep_failure`)
and classifies each robot that did not succeed (:func:`~dsmpepc_nlp.bench.failures.classify`).
A row without an episode (a run that raised, a table from before episodes were kept) is
counted as ``unclassified`` with the reason. Writes ``failures.json`` and ``failures.md`` into the
folder and one figure per class, ``failures-<class>.png``, with up to ``--figures`` examples
(their scene and the cost panels of the stuck cycle).
"""

from __future__ import annotations

import json
import math
from collections import Counter
from pathlib import Path

import numpy as np

from ..core import options
from ..core.config import RobotState
from ..core.errors import InputError, seconds
from ..core.files import atomic_write_text
from ..core.jsonio import dumps, json_clean
from ..sim.episode import Episode
from ..sim.panels import cost_panels
from ..solve.behaviours.stall import StallMonitor
from ..viz import figures
from .escape import escapes
from .failures import CLASSES, classify
from .results import TABLE_FORMAT, parse_indices

REPORT = "failures"
"""Stem of the report files the command writes into the folder."""
PANEL_SAMPLES = 1024
"""Samples per cost panel: a quarter of ``run --panels``'s, enough to see the cost's shape."""


EARLY = 1.0
"""s: in its first second a robot that starts at rest covers at most 0.75 m (1.5 m/s^2), so a
contact by then came from where the person stood when the run began (``early_contacts``)."""
ESCAPES = ("forward", "rung", "full", "none", "not searched")
"""The escape search's answers (:func:`.escape.escapes`), narrowest way out first."""


def unsuccessful(row: dict) -> bool:
    """Whether a result row is a run that did not succeed (any of its robots)."""
    if row.get("status") == "failed":
        return True
    if "outcomes" in row:
        return any(o != "success" for o in str(row["outcomes"]).split(","))
    return row.get("outcome", "success") != "success"


def read_tables(out_dir) -> list:
    """``(stem, key fields, rows)`` of every result table in ``out_dir``; InputError when it
    is not a folder or holds none."""
    folder = Path(out_dir)
    if not folder.is_dir():
        raise InputError(f"failures OUT_DIR {str(folder)!r}: not a folder")
    tables = []
    for path in sorted(folder.glob("*.json")):
        if path.stem == REPORT:
            continue
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise InputError(f"table {str(path)!r}: cannot read ({exc})") from None
        if isinstance(data, dict) and data.get("format") == TABLE_FORMAT \
                and isinstance(data.get("rows"), list):
            tables.append((path.stem, list(data.get("key_fields", [])), data["rows"]))
    if not tables:
        raise InputError(f"failures OUT_DIR {str(folder)!r}: no benchmark table (a <name>.json "
                         "written by 'dsmpepc benchmark') in it")
    return tables


CASE_FIELDS = ("world", "episode")
"""The row field that numbers a benchmark's cases (BARN's worlds, the crowds' episodes), which
``--cases`` selects by."""


def selected(stem: str, rows: list, cases) -> list:
    """The ``rows`` of table ``stem`` whose case (:data:`CASE_FIELDS`) is in ``cases`` (all of
    them when None); InputError when a row has no such field."""
    if cases is None:
        return rows
    kept = []
    for row in rows:
        field = next((f for f in CASE_FIELDS if row.get(f) is not None), None)
        if field is None:
            raise InputError(f"failures --cases: table {stem!r} numbers its runs by none of "
                             f"{', '.join(CASE_FIELDS)} (its fields: {', '.join(row)}); "
                             "--cases selects BARN worlds and crowd episodes only")
        if int(row[field]) in cases:
            kept.append(row)
    return kept


def _ranges(cases) -> str:
    """Sorted ints as ``--cases`` writes them: ``0-5,10``."""
    spans, values = [], sorted(cases)
    for value in values:
        if spans and value == spans[-1][1] + 1:
            spans[-1][1] = value
        else:
            spans.append([value, value])
    return ",".join(str(a) if a == b else f"{a}-{b}" for a, b in spans)


def classify_folder(out_dir, escape: bool = False, cases=None) -> dict:
    """The report of ``out_dir``: runs, counts per class, each failure with its evidence; with
    ``escape``, every collision also searched for a way out (:mod:`.escape`), counted in
    ``escapes``; with ``cases`` (ints), only the runs of those worlds or episodes
    (:func:`selected`), named in the report's ``cases``."""
    folder = Path(out_dir)
    failures, unclassified, n_rows, n_failed = [], [], 0, 0
    for stem, keys, rows in read_tables(folder):
        for row in selected(stem, rows, cases):
            n_rows += 1
            if not unsuccessful(row):
                continue
            n_failed += 1
            label = f"{stem} " + " ".join(f"{k}={row.get(k)}" for k in keys)
            name = row.get("episode_file")
            if not name:
                reason = row.get("message") or "no episode file in the row"
                unclassified.append({"table": stem, "label": label, "reason": reason})
                continue
            try:
                episode = Episode.load(folder / name)
            except InputError as exc:
                unclassified.append({"table": stem, "label": label, "reason": str(exc)})
                continue
            for robot, outcome in enumerate(episode.outcomes):
                if outcome != "success":
                    failure = classify(episode, robot).to_dict()
                    failure["evidence"]["stall_level"] = stuck_config(
                        episode, robot, failure["cycle"])[1]
                    if escape and outcome == "collision":
                        failure["evidence"].update(escapes(episode, robot))
                    if "goal_free_at" in row:  # a replay's draw: when the goal first freed
                        failure["evidence"]["goal_free_at"] = row["goal_free_at"]
                    failures.append({"table": stem, "label": label, "episode_file": name,
                                     **failure})
    counts = Counter(f["class"] for f in failures)
    report = {"out": str(folder), "runs": n_rows, "unsuccessful_runs": n_failed}
    if cases is not None:
        if not n_rows:
            raise InputError(f"failures --cases: no run of {str(folder)!r} is among the cases "
                             "given")
        report["cases"] = _ranges(cases)
    if escape:
        found = Counter(str(f["evidence"]["escape"]).split(":")[0] for f in failures
                        if "escape" in f["evidence"])
        report["escapes"] = {name: found[name] for name in ESCAPES if found[name]}
    report.update(_early_contacts(failures))
    never = sum("goal_free_at" in f["evidence"] and f["evidence"]["goal_free_at"] is None
                for f in failures)
    if never:
        report["goal_never_free"] = never
    searched = all(not str(f["evidence"].get("escape", "")).startswith("not searched")
                   for f in failures)
    if escape and n_rows and searched:     # where people react no search, so no bound
        report.update(_bound_given_path(failures, never, n_rows))
    return {**report,
            "counts": {name: counts[name] for name in CLASSES if counts[name]},
            "unclassified": len(unclassified), "failures": failures,
            "unclassified_runs": unclassified}


def _early_contacts(failures) -> dict:
    """``early_contacts``: the collisions within :data:`EARLY` of the start, with the range of
    the touched people's gaps to the robot then (``start_gap``, m); {} without such a one."""
    early = [f["evidence"] for f in failures if f["outcome"] == "collision"
             and f["evidence"].get("contact_time", math.inf) <= EARLY + 1e-9]
    if not early:
        return {}
    gaps = [e["start_gap"] for e in early if "start_gap" in e]
    return {"early_contacts": {"within": EARLY, "collisions": len(early),
                               "start_gap": [min(gaps), max(gaps)] if gaps else None}}


def _early_line(report: dict) -> str:
    """The early contacts in words ('' without any)."""
    early = report.get("early_contacts")
    if not early:
        return ""
    gaps = early["start_gap"]
    where = "" if gaps is None else (f", the person touched standing {gaps[0]:.2f}-"
                                     f"{gaps[1]:.2f} m from the robot (between bodies) then")
    return (f"{early['collisions']} of the collisions came within {early['within']:g} s of the "
            f"start{where}.")


def _bound_given_path(failures, never: int, runs: int) -> dict:
    """``no_way_out``: collisions the exhaustive escape search found no way out of (from when
    the person touched set off, or :data:`~.escape.LOOKBACK` before the contact); with the runs
    whose goal was never free, no robot that had driven as this one did until then could have
    won them, so ``bound_given_path`` = 1 - (both) / ``runs`` bounds such a robot's success.
    Not a bound for a robot that drove elsewhere earlier."""
    none = sum(f["evidence"].get("escape") == "none" and f["evidence"].get("escape_exhaustive")
               is True for f in failures)
    return {"no_way_out": none, "bound_given_path": 1.0 - (none + never) / runs}


def stuck_panels(episode, failure: dict, n_samples: int = PANEL_SAMPLES):
    """The cost panels (:func:`~dsmpepc_nlp.sim.panels.cost_panels`) of the stuck cycle,
    costed at the stall ladder's level the robot planned it at (:func:`stuck_config`)."""
    robot, k = failure["robot"], failure["cycle"]
    x, y, phi, v, omega = (float(s) for s in episode.states[robot, k])
    return cost_panels(RobotState(x, y, phi, v, omega), episode.world_at(k, robot),
                       episode.goals[robot, k], stuck_config(episode, robot, k)[0],
                       n_samples=n_samples)


def stuck_config(episode, robot: int, cycle: int, config=None) -> tuple:
    """``(config, level)``: the configuration ``robot`` planned ``cycle`` with, the episode's
    (or ``config``) at the stall ladder's level then (the progress weight times
    ``stall.gain ** level``), found by replaying the stall monitor over the robot's logged
    plans up to that cycle (:meth:`~dsmpepc_nlp.solve.behaviours.stall.StallMonitor.replay`)."""
    monitor = StallMonitor(episode.config() if config is None else config)
    planned = [j for j in np.flatnonzero(episode.active[robot]) if j <= cycle]
    states = [RobotState(*(float(s) for s in episode.states[robot, j])) for j in planned]
    level = monitor.replay(states, episode.goals[robot, planned])
    return monitor.config_for(level), level


def draw_figures(report: dict, out_dir, n_examples: int, panels: bool = True) -> list:
    """``failures-<class>.png`` with up to ``n_examples`` runs of each class; the paths."""
    folder, paths = Path(out_dir), []
    for name in CLASSES:  # a figure of an earlier report whose class is gone would mislead
        (folder / f"{REPORT}-{name}.png").unlink(missing_ok=True)
    for name, total in report["counts"].items():
        examples = []
        for failure in [f for f in report["failures"] if f["class"] == name][:n_examples]:
            episode = Episode.load(folder / failure["episode_file"])
            shown = stuck_panels(episode, failure) if panels else None
            examples.append((failure["label"], episode, failure, shown))
        if examples:
            paths.append(figures("failures").failure_figure(
                name, examples, folder / f"{REPORT}-{name}.png", total=total,
                cases=report.get("cases")))
    return [str(p) for p in paths]


def markdown(report: dict) -> str:
    """The report as a short markdown page: counts, then every failure with its evidence."""
    only = f" (cases {report['cases']} only)" if "cases" in report else ""
    lines = [f"# Failures in `{report['out']}`{only}", "",
             f"{report['unsuccessful_runs']} of {report['runs']} runs did not succeed.", "",
             "| class | runs |", "|---|---|"]
    lines += [f"| {name} | {n} |" for name, n in report["counts"].items()]
    if report["unclassified"]:
        lines.append(f"| unclassified | {report['unclassified']} |")
    if "goal_never_free" in report:
        lines += ["", f"{report['goal_never_free']} of them no planner could win: a pedestrian "
                  "covered the goal from the robot's earliest possible arrival to the end "
                  "(`goal_free_at` empty)."]
    if _early_line(report):
        lines += ["", _early_line(report)]
    if "escapes" in report:
        lines += ["", "Collisions by their narrowest way out within the robot's limits, against "
                  "the logged people (`--escape`):", "", "| way out | collisions |", "|---|---|"]
        lines += [f"| {name} | {n} |" for name, n in report["escapes"].items()]
    if "bound_given_path" in report:
        lines += ["", f"No way out of {report['no_way_out']} collisions (an exhaustive search); "
                  f"with the goals never free, a robot that drove as this one did until then "
                  f"succeeds in at most {report['bound_given_path']:.3f} of the runs."]
    for name in report["counts"]:
        lines += ["", f"## {name}", ""]
        if any(Path(f).name == f"{REPORT}-{name}.png" for f in report.get("figures", [])):
            lines += [f"![{name}]({REPORT}-{name}.png)", ""]
        for f in (f for f in report["failures"] if f["class"] == name):
            evidence = ", ".join(f"{k} {_short(v)}" for k, v in f["evidence"].items()
                                 if not isinstance(v, list))
            lines.append(f"- {f['label']} (robot {f['robot']}, {f['outcome']}, stuck cycle "
                         f"t = {seconds(f['time'])} s): {evidence}")
    if report["unclassified_runs"]:
        lines += ["", "## unclassified", ""]
        lines += [f"- {u['label']}: {u['reason']}" for u in report["unclassified_runs"]]
    return "\n".join(lines) + "\n"


def _short(value) -> str:
    return f"{value:.3g}" if isinstance(value, float) else str(value)


def add_arguments(p) -> None:
    p.add_argument("out_dir", metavar="OUT_DIR", help="a benchmark's --out folder")
    p.add_argument("--figures", type=options.nonnegative, default=3, metavar="N",
                   help="examples per class in its figure (0: no figures; default 3)")
    p.add_argument("--no-panels", action="store_true",
                   help="leave out the cost panels of the stuck cycle (faster)")
    p.add_argument("--escape", action="store_true",
                   help="also search every collision for a way out within the robot's limits "
                   "against the logged people (valid where they do not react to the robot: "
                   "CrowdNav invisible, ETH/UCY, the scenarios; seconds per collision)")
    p.add_argument("--cases", metavar="RANGE", default=None,
                   help="only the runs of these BARN worlds or crowd episodes, e.g. 50-199 or "
                   "1-299:2 (the report and its figures then say so)")
    p.add_argument("--json", action="store_true", help="print the report as one JSON object")


def run(args) -> int:
    cases = None if args.cases is None else set(parse_indices(args.cases, "--cases"))
    report = classify_folder(args.out_dir, escape=args.escape, cases=cases)
    report["figures"] = draw_figures(report, args.out_dir, args.figures,
                                     panels=not args.no_panels) if args.figures else []
    folder = Path(args.out_dir)
    atomic_write_text(folder / f"{REPORT}.json", dumps(json_clean(report)))
    atomic_write_text(folder / f"{REPORT}.md", markdown(report))
    if args.json:
        print(json.dumps(json_clean(report), allow_nan=False))
        return 0
    only = f" (cases {report['cases']})" if "cases" in report else ""
    print(f"{report['unsuccessful_runs']} of {report['runs']} runs{only} did not succeed")
    width = max((len(n) for n in report["counts"]), default=12)
    for name, n in report["counts"].items():
        print(f"  {name:{width}s} {n}")
    if report["unclassified"]:
        print(f"  {'unclassified':{width}s} {report['unclassified']}")
    if _early_line(report):
        print(_early_line(report))
    if "goal_never_free" in report:
        print(f"goal never free (no planner could win): {report['goal_never_free']}")
    if "escapes" in report:
        found = ", ".join(f"{k} {n}" for k, n in report["escapes"].items())
        print("collisions by their narrowest way out (forward only, the rung's reverse, a full-"
              f"speed reverse, none): {found}")
        print(f"success bound given the path (no way out {report['no_way_out']}, goal never "
              f"free {report.get('goal_never_free', 0)}): {report['bound_given_path']:.3f}")
    print(f"report: {folder / (REPORT + '.json')}, {folder / (REPORT + '.md')}")
    for path in report["figures"]:
        print(f"figure: {path}")
    return 0


def register(sub) -> None:
    """Add ``failures`` to the subparsers ``sub``."""
    p = sub.add_parser("failures", help="classify every unsuccessful run of a benchmark's "
                       "--out folder (counts, report, a figure per class)",
                       description="Classify why each unsuccessful run of a benchmark table "
                       "failed, from its kept episode: counts per class, failures.json, "
                       "failures.md and a figure per class.")
    add_arguments(p)
    p.set_defaults(func=run)

