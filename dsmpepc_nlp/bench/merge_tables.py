"""``dsmpepc merge FOLDER FOLDER ... --out NEW``: one benchmark folder from several runs of the
same benchmark on disjoint cases.

The tuning split and the report split are two runs of one benchmark (BARN's even and odd
worlds, ``--worlds 0-299:2`` and ``--worlds 1-299:2``); the published table counts all 300.
The runs are deterministic, so the two folders hold the rows ``--worlds 0-299`` would have
written. This writes them as one ``--out`` folder: the rows of every folder in one table (the
package's own :class:`~dsmpepc_nlp.bench.results.ResultTable`), the kept episodes of the failed
runs beside it (copied), so ``dsmpepc failures OUT`` and ``dsmpepc table`` read it as any run's
folder::

    dsmpepc merge EVEN ODD --out ALL
    dsmpepc failures ALL

Refused, with nothing written: folders of different benchmarks or settings (the tables' ``meta``
differ), a case in two folders, an ``--out`` that exists. The folder is written beside ``--out``
under a temporary name and renamed when complete.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

from ..core.errors import InputError
from .failure_report import read_tables
from .results import ResultTable


def one_table(folder, command: str) -> tuple:
    """``(stem, data)`` of the one benchmark table in ``folder`` (its JSON: rows, key fields,
    meta); InputError naming ``command``, the folder and what it holds otherwise."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{command} folder {str(folder)!r}: not a folder; expected a "
                         "benchmark's --out folder")
    try:
        tables = read_tables(folder)
    except InputError:
        tables = []
    if len(tables) != 1:
        names = ", ".join(f"{stem}.json" for stem, *_ in tables) or "none"
        raise InputError(f"{command} folder {str(folder)!r}: {len(tables)} benchmark tables "
                         f"({names}); expected one (the <name>.json a dsmpepc benchmark run "
                         "writes into its --out folder)")
    stem = tables[0][0]
    return stem, json.loads((folder / f"{stem}.json").read_text(encoding="utf-8"))


def _check(folders: list, loaded: list, out: Path) -> None:
    """InputError when the tables are of other benchmarks or settings, share a case, or
    ``out`` exists."""
    stem, first = loaded[0]
    for folder, (other_stem, data) in zip(folders[1:], loaded[1:]):
        if other_stem != stem or data.get("meta") != first.get("meta") \
                or data.get("key_fields") != first.get("key_fields"):
            raise InputError(f"merge folder {str(folder)!r}: another benchmark or other "
                             f"settings than {str(folders[0])!r} ({other_stem}.json's meta or "
                             "key fields differ); merge runs of one benchmark and settings")
    key_fields = first["key_fields"]
    seen = {}
    for folder, (_, data) in zip(folders, loaded):
        for row in data["rows"]:
            key = json.dumps([row.get(name) for name in key_fields])
            if key in seen:
                raise InputError(f"merge: case {key_fields} = {key} is in both "
                                 f"{str(seen[key])!r} and {str(folder)!r}; merge runs on "
                                 "disjoint cases")
            seen[key] = folder
    if out.exists():
        raise InputError(f"merge --out {str(out)!r}: exists; choose a new folder")


def merge(folders, out) -> Path:
    """Write the rows of ``folders`` (``--out`` folders of one benchmark, disjoint cases) into
    the new folder ``out``, their kept episodes copied beside them; the table's JSON path."""
    folders, out = [Path(f) for f in folders], Path(out)
    loaded = [one_table(f, "merge") for f in folders]
    _check(folders, loaded, out)
    stem, first = loaded[0]
    out.parent.mkdir(parents=True, exist_ok=True)
    building = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        merged = ResultTable(building, stem, first["key_fields"], first.get("meta"))
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


def run(args) -> int:
    """``dsmpepc merge``: merge the folders, say how many rows."""
    if len(args.folders) < 2:
        raise InputError(f"merge FOLDERS: {len(args.folders)} given; give two folders or more")
    path = merge(args.folders, args.out)
    rows = len(json.loads(path.read_text(encoding="utf-8"))["rows"])
    print(f"{path}: {rows} rows from {len(args.folders)} folders")
    return 0


def register(sub) -> None:
    """Add ``merge`` to the subparsers ``sub``."""
    p = sub.add_parser("merge", help="one benchmark folder from runs of the same benchmark on "
                       "disjoint cases (e.g. BARN's even and odd worlds)",
                       description="Write the rows of several --out folders of one benchmark "
                       "and settings (disjoint cases) into one new --out folder, their kept "
                       "episodes copied, as one run of all the cases would have.")
    p.add_argument("folders", nargs="+", metavar="FOLDER", help="--out folders of one benchmark")
    p.add_argument("--out", required=True, help="a new folder for the merged table")
    p.set_defaults(func=run)
