"""One benchmark folder from several runs of the same benchmark on disjoint cases.

The tuning split and the report split are two runs of one benchmark (BARN's even and odd
worlds, ``--worlds 0-299:2`` and ``--worlds 1-299:2``); the published table counts all 300.
The runs are deterministic, so the two folders hold the rows ``--worlds 0-299`` would have
written. This writes them as one ``--out`` folder: the rows of every folder in one table (the
package's own ``ResultTable``), the kept episodes of the failed runs beside it (copied), so
``dsmpepc failures OUT`` and ``tools/results_table.py`` read it as any run's folder::

    python tools/merge_tables.py EVEN ODD --out ALL
    dsmpepc failures ALL

Refused, with nothing written: folders of different benchmarks or settings (the tables' ``meta``
differ), a case in two folders, an ``--out`` that exists. The folder is written beside ``--out``
under a temporary name and renamed when complete.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

from dsmpepc_nlp.bench.failure_report import read_tables
from dsmpepc_nlp.bench.results import ResultTable


def _one_table(folder: Path) -> tuple:
    """``(stem, data)`` of the one table in ``folder`` (its JSON, rows and meta)."""
    tables = read_tables(folder)
    if len(tables) != 1:
        raise SystemExit(f"{folder}: {len(tables)} benchmark tables, expected one")
    stem = tables[0][0]
    return stem, json.loads((folder / f"{stem}.json").read_text(encoding="utf-8"))


def merge(folders, out) -> Path:
    """Write the rows of ``folders`` (``--out`` folders of one benchmark, disjoint cases) into
    the new folder ``out``, their kept episodes copied beside them; the table's JSON path."""
    folders, out = [Path(f) for f in folders], Path(out)
    loaded = [_one_table(f) for f in folders]
    stem, first = loaded[0]
    for folder, (other_stem, data) in zip(folders[1:], loaded[1:]):
        if other_stem != stem or data["meta"] != first["meta"] \
                or data["key_fields"] != first["key_fields"]:
            raise SystemExit(f"{folder}: another benchmark or other settings than {folders[0]} "
                             f"({other_stem}.json's meta or key fields differ)")
    key_fields = first["key_fields"]
    seen = {}
    for folder, (_, data) in zip(folders, loaded):
        for row in data["rows"]:
            key = json.dumps([row.get(name) for name in key_fields])
            if key in seen:
                raise SystemExit(f"case {key_fields} = {key} is in both {seen[key]} and "
                                 f"{folder}")
            seen[key] = folder
    if out.exists():
        raise SystemExit(f"{out}: exists; choose a new folder")
    out.parent.mkdir(parents=True, exist_ok=True)
    building = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        merged = ResultTable(building, stem, key_fields, first["meta"])
        for folder, (_, data) in zip(folders, loaded):
            for row in data["rows"]:
                if row.get("episode_file"):
                    target = building / row["episode_file"]
                    target.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copyfile(folder / row["episode_file"], target)
            merged.rows.extend(data["rows"])
        try:
            merged.rows.sort(key=merged.key)
        except TypeError:                     # keys of mixed types: keep the folders' order
            pass
        merged.write()
        building.rename(out)
    except BaseException:
        shutil.rmtree(building, ignore_errors=True)
        raise
    return out / f"{stem}.json"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", nargs="+", help="--out folders of one benchmark")
    parser.add_argument("--out", required=True, help="a new folder for the merged table")
    args = parser.parse_args(argv)
    if len(args.folders) < 2:
        parser.error("give two folders or more")
    path = merge(args.folders, args.out)
    rows = len(json.loads(path.read_text(encoding="utf-8"))["rows"])
    print(f"{path}: {rows} rows from {len(args.folders)} folders")
    return 0


if __name__ == "__main__":
    sys.exit(main())
