"""``dsmpepc table ROOT``: the product's defaults and the paper preset side by side, from their
benchmark folders.

Reads a folder ``ROOT`` that holds, for each benchmark, the ``--out`` folder of a run with the
product's defaults and one with ``--preset paper``: ``ROOT/<name>-product`` and
``ROOT/<name>-paper`` (any ``<name>``; the commands in docs/results.md, "How to make the tables",
make them). Prints one markdown table of the navigation benchmarks (``dsmpepc benchmark barn``,
``crowd``, ``crowdnav``: DS-MPEPC's rows) with, for each preset: success, collision (at fault /
struck), timeout, deadlock, mean time to goal and path length of the successes, plan time
(median over runs of each run's median, 95th percentile of their 95th percentiles), the failure
classes (``<out>/failures.json``, written by ``dsmpepc failures OUT``) and the cases only that
preset wins, with the two-sided sign test (``dsmpepc paired``, :mod:`.paired`). Where a folder
was classified with ``--escape``, a second table: the collisions no way out existed from, the
goals never free and the success they leave a robot that drove the same way. Then a table of
the built-in scenarios (``dsmpepc benchmark scenarios``), run by run::

    dsmpepc table ROOT
    dsmpepc table ROOT --json

Every figure is computed by the package's own summaries (``crowd_rows.summarise``,
``barn.summarise``, ``runner.plan_time_summary``); nothing is typed in by hand. A benchmark
run in parts (BARN's even and odd worlds) is made one folder first by ``dsmpepc merge``
(:mod:`.merge_tables`).
"""

from __future__ import annotations

import json
import math
from collections import Counter
from pathlib import Path

from ..core.errors import InputError
from ..core.jsonio import json_clean
from . import barn, crowd_rows
from .failure_report import REPORT
from .failures import CLASSES
from .merge_tables import one_table
from .paired import compare, load
from .runner import mean

PRESETS = ("product", "paper")
ORDER = ("barn", "crowdnav", "crowd")
"""The benchmarks' order in the table (by their table's stem): BARN, CrowdNav, ETH/UCY."""
VARIANT = "ds-mpepc"


def pairs(root) -> list:
    """``[(name, {preset: folder})]`` of every ``<name>-product`` with its ``<name>-paper``;
    InputError when ``root`` is not a folder or holds no such pair."""
    root = Path(root)
    if not root.is_dir():
        raise InputError(f"table ROOT {str(root)!r}: not a folder; expected a folder of "
                         "<name>-product and <name>-paper --out folders")
    found = []
    for product in sorted(root.glob("*-product")):
        name = product.name[: -len("-product")]
        paper = root / f"{name}-paper"
        if product.is_dir() and paper.is_dir():
            found.append((name, {"product": product, "paper": paper}))
    if not found:
        raise InputError(f"table ROOT {str(root)!r}: no <name>-product folder with its "
                         "<name>-paper beside it; expected the --out folders of a benchmark "
                         "run with the product's defaults and with --preset paper")
    return found


def table(folder: Path) -> tuple:
    """``(stem, meta, rows)`` of the one benchmark table in ``folder``."""
    stem, data = one_table(folder, "table")
    return stem, data.get("meta", {}), data["rows"]


def report_of(folder: Path) -> dict | None:
    """``dsmpepc failures``'s report of ``folder`` (``failures.json``); None when the folder
    was not classified."""
    path = folder / f"{REPORT}.json"
    if not path.exists():
        return None
    try:
        report = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"report {str(path)!r}: cannot read ({exc}); remake it with "
                         f"dsmpepc failures {str(folder)!r}") from None
    if not isinstance(report, dict) or not isinstance(report.get("failures"), list):
        raise InputError(f"report {str(path)!r}: no 'failures' list; expected the "
                         f"failures.json of dsmpepc failures {str(folder)!r}")
    return report


def classes(report: dict | None, key: str, cases: set) -> dict | None:
    """Counts per failure class of a folder's ``report`` over ``cases`` (the ``key`` values
    both presets ran); None when the folder was not classified."""
    if report is None:
        return None
    shared = {f"{key}={case}" for case in cases}      # a label holds e.g. "episode=12"
    counts = Counter(f["class"] for f in report["failures"] if shared & set(f["label"].split()))
    return {name: counts[name] for name in CLASSES if counts[name]}


def bound(report: dict | None) -> dict | None:
    """What ``dsmpepc failures OUT --escape`` counted: the collisions with no way out, the
    goals never free and the success they leave a robot that drove the same way
    (``bound_given_path``, over the report's ``runs``); None when it was not searched."""
    if report is None or "bound_given_path" not in report:
        return None
    return {k: report.get(k, 0) for k in ("runs", "no_way_out", "goal_never_free",
                                          "bound_given_path")}


def figures_of(stem: str, rows: list, cases: set) -> dict:
    """Rates, means and plan times of DS-MPEPC's rows of one table, on ``cases`` (the cases
    both presets ran: ``world`` for BARN, ``episode`` otherwise)."""
    rows = [r for r in rows if r.get("variant") == VARIANT and str(r[case_key(stem)]) in cases]
    if stem == "barn":
        s = barn.summarise(rows)
        s["time_to_goal"] = s["mean_time_success"]
        s["at_fault_rate"], s["struck_rate"] = s["collision_rate"], 0.0  # static worlds
    else:
        s = crowd_rows.summarise(rows)
    s["path_length"] = mean(rows, "path_length", lambda r: r["outcome"] == "success")
    s["runs"] = len(rows)
    return s


def case_key(stem: str) -> str:
    """The field that names a case of a table: ``world`` for BARN, ``episode`` otherwise."""
    return "world" if stem == "barn" else "episode"


def label(stem: str, meta: dict, runs: int) -> str:
    """A row's name: the benchmark, its scene and setting, and how many runs."""
    if stem == "barn":
        return f"BARN, {runs} worlds"
    if stem == "crowdnav":
        return f"CrowdNav {meta.get('scene')} {meta.get('setting')}, {runs}"
    return f"ETH/UCY {meta.get('scene', stem)}, {runs}"


def _check_fields(folder: Path, stem: str, rows: list) -> None:
    """InputError unless every row of a navigation table has its case, variant and outcome."""
    for row in rows:
        for field in (case_key(stem), "variant", "outcome"):
            if row.get(field) is None:
                raise InputError(f"table {str(folder / (stem + '.json'))!r}: a row without "
                                 f"{field} (its fields: {', '.join(row)}); expected the "
                                 "table of dsmpepc benchmark barn, crowd or crowdnav")


def navigation(found) -> list:
    """One entry per navigation benchmark: its label, each preset's figures, the pairing."""
    out = []
    for name, folders in found:
        loaded = {p: table(folders[p]) for p in PRESETS}
        stem, meta, _ = loaded["product"]
        if stem == "scenarios":
            continue
        for preset in PRESETS:
            _check_fields(folders[preset], loaded[preset][0], loaded[preset][2])
        rank = ORDER.index(stem) if stem in ORDER else len(ORDER)
        csvs = [load(folders[p] / f"{loaded[p][0]}.csv", VARIANT) for p in PRESETS]
        cases = set(csvs[0]) & set(csvs[1])
        paired = compare(*csvs)
        entry = {"name": name, "presets": {}}
        for preset in PRESETS:
            figures = figures_of(stem, loaded[preset][2], cases)
            report = report_of(folders[preset])
            figures["classes"] = classes(report, case_key(stem), cases)
            figures["bound"] = bound(report)
            entry["presets"][preset] = figures
        entry["label"] = label(stem, meta, len(cases))
        entry["only"] = {"product": paired["only_a"], "paper": paired["only_b"]}
        entry["p"] = paired["p"]
        out.append((rank, entry["label"], entry))
    return [entry for *_, entry in sorted(out, key=lambda t: t[:2])]


def scenarios(found) -> list:
    """Rows ``{scenario, variant, product: row, paper: row}`` of the scenario benchmarks."""
    out = []
    for _, folders in found:
        loaded = {p: table(folders[p]) for p in PRESETS}
        if loaded["product"][0] != "scenarios":
            continue
        index = {p: {(r["scenario"], r["variant"]): r for r in loaded[p][2]} for p in PRESETS}
        for key, row in sorted(index["product"].items()):
            out.append({"scenario": key[0], "variant": key[1], "product": row,
                        "paper": index["paper"].get(key)})
    return out


def _num(value, digits=2, scale=1.0) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) \
        else f"{value * scale:.{digits}f}"


def _classes(counts) -> str:
    if counts is None:
        return "not classified"
    return ", ".join(f"{k} {v}" for k, v in counts.items()) or "none"


def _navigation_lines(nav: list) -> list:
    """The first table: one line per benchmark and preset."""
    lines = ["| benchmark | preset | success | collision (at fault / struck) | timeout | "
             "deadlock | time to goal s | path m | plan ms median / p95 | failure classes | "
             "only this preset wins |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for entry in nav:
        for preset in PRESETS:
            s = entry["presets"][preset]
            only = entry["only"][preset]
            lines.append(
                f"| {entry['label'] if preset == 'product' else ''} | {preset} | "
                f"{_num(s['success_rate'], 3)} | {_num(s['collision_rate'], 3)} "
                f"({_num(s['at_fault_rate'], 3)} / {_num(s['struck_rate'], 3)}) | "
                f"{_num(s['timeout_rate'], 3)} | {_num(s['deadlock_rate'], 3)} | "
                f"{_num(s['time_to_goal'])} | {_num(s['path_length'])} | "
                f"{_num(s['plan_time_median'], 0, 1e3)} / {_num(s['plan_time_p95'], 0, 1e3)} | "
                f"{_classes(s['classes'])} | {len(only)}"
                + (f" (p = {entry['p']:.2g})" if preset == "paper" else "") + " |")
    return lines


def markdown(nav: list, scen: list) -> str:
    """The two tables as markdown."""
    lines = _navigation_lines(nav)
    bounds = [(entry["label"], preset, entry["presets"][preset]) for entry in nav
              for preset in PRESETS if entry["presets"][preset]["bound"]]
    if bounds:
        lines += ["", "| benchmark | preset | success | collisions with no way out | goals never "
                  "free | success at most, given the path |", "|---|---|---|---|---|---|"]
        for name, preset, s in bounds:
            b = s["bound"]
            lines.append(f"| {name} | {preset} | {_num(s['success_rate'], 3)} | "
                         f"{b['no_way_out']} | {b['goal_never_free']} | "
                         f"{_num(b['bound_given_path'], 3)} ({b['runs']} runs) |")
    if scen:
        lines += ["", "| scenario | variant | product | paper |", "|---|---|---|---|"]
        for r in scen:
            lines.append(f"| {r['scenario']} | {r['variant']} | {_run(r['product'])} | "
                         f"{_run(r['paper'])} |")
    return "\n".join(lines)


def _run(row) -> str:
    """One scenario run: its robots' outcomes and mean time to goal."""
    if row is None:
        return "not run"
    outcomes = str(row.get("outcomes", "")).split(",")
    won = outcomes.count("success")
    text = f"{won} of {len(outcomes)} robot" + "s" * (len(outcomes) > 1)
    others = sorted({o for o in outcomes if o != "success"})
    if others:
        text += f" ({', '.join(others)})"
    if won and row.get("time_to_goal") is not None:
        text += f", {row['time_to_goal']:.2f} s"
    if row.get("path_length") is not None:
        text += f", {row['path_length']:.2f} m"
    return text


def run(args) -> int:
    """``dsmpepc table``: print the tables of ``args.root``."""
    found = pairs(args.root)
    nav, scen = navigation(found), scenarios(found)
    if args.json:
        print(json.dumps(json_clean({"navigation": nav, "scenarios": scen}), allow_nan=False,
                         default=str))
    else:
        print(markdown(nav, scen))
    return 0


def register(sub) -> None:
    """Add ``table`` to the subparsers ``sub``."""
    p = sub.add_parser("table", help="the published tables: the product's defaults and the "
                       "paper preset side by side, from their benchmark folders",
                       description="Print the markdown tables of docs/results.md from a folder "
                       "of <name>-product and <name>-paper benchmark --out folders: each "
                       "preset's rates, times, plan times, failure classes and the cases only "
                       "it wins, with the sign test.")
    p.add_argument("root", metavar="ROOT",
                   help="folder of <name>-product and <name>-paper --out folders")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
