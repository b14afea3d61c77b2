"""Result tables shared by the benchmark and sweep runners: atomic, keyed, resumable.

A :class:`ResultTable` is one list of flat rows kept in two files, ``<stem>.json`` (the source
of truth, read back on resume) and ``<stem>.csv`` (for spreadsheets). Both are rewritten in full
after every added row, each through a temporary file in the same folder and ``os.replace``, so an
interrupted run leaves either the previous complete table or the new one, never a partial file.
Rows are identified by a key (a tuple of the values of ``key_fields``); a resumed run skips keys
already present.

A process killed while writing (SIGKILL, power loss) can leave hidden ``.<stem>.json.*.tmp`` /
``.<stem>.csv.*.tmp`` files and a CSV one row behind the JSON. Opening a table removes those
temporary files, and resuming rewrites the CSV from the JSON, so the pair is consistent again.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from ..core.errors import InputError
from ..core.files import atomic_write_text
from ..core.jsonio import dumps, json_clean

TABLE_FORMAT = 1
"""Version of the JSON layout written by :class:`ResultTable`."""
EPISODES = "episodes"
"""Sub-folder of a benchmark's ``--out`` holding the episodes of its unsuccessful runs."""


def keep_failure(episode, out_dir, stem: str) -> str | None:
    """Save ``episode`` as ``out_dir/episodes/<stem>.npz`` when any robot did not succeed, so
    ``dsmpepc failures`` can classify it; the path relative to ``out_dir`` (the row's
    ``episode_file``), or None (all succeeded, or ``out_dir`` is None). Successes are not kept:
    a failure's file is a few hundred kB, and failures are what gets studied."""
    if out_dir is None or all(o == "success" for o in episode.outcomes):
        return None
    relative = Path(EPISODES) / f"{stem}.npz"
    episode.save(Path(out_dir) / relative)
    return relative.as_posix()


class TableExistsError(InputError, FileExistsError):
    """The output folder already holds a table and neither resume nor overwrite was asked."""


def _key_part(value):
    if isinstance(value, float) and value.is_integer():
        return int(value)
    if isinstance(value, (list, tuple)):
        return tuple(_key_part(v) for v in value)
    if isinstance(value, dict):
        return tuple(sorted((k, _key_part(v)) for k, v in value.items()))
    return value


class ResultTable:
    """Rows of one benchmark or sweep, kept on disk after every row.

    Parameters
    ----------
    folder : path
        Output folder (created when needed).
    stem : str
        File stem: the table is ``folder/stem.json`` and ``folder/stem.csv``.
    key_fields : sequence of str
        Fields whose values identify a run (e.g. ``("world", "variant", "solver")``).
    meta : dict, optional
        JSON-able description of the run (stored next to the rows; checked on resume).
    resume : bool
        Keep the rows already on disk and skip their keys. When False and the folder already
        holds a table, :class:`TableExistsError` (an InputError and a FileExistsError) is
        raised unless ``overwrite`` is True.
    overwrite : bool
        Start from an empty table even when one exists.

    Raises
    ------
    InputError
        On resume, when the stored table is unreadable or its ``meta`` differs from ``meta``
        (other settings than the ones a resumed run would use).
    """

    def __init__(self, folder, stem: str, key_fields, meta=None, *, resume=False,
                 overwrite=False):
        self.folder = Path(folder)
        self.stem = stem
        self.key_fields = tuple(key_fields)
        self.meta = json_clean(dict(meta or {}))
        self.rows: list[dict] = []
        self._remove_temporaries()
        existing = self.json_path.exists()
        if existing and resume and not overwrite:
            self._load()
            self.write()  # the CSV from the JSON: one row behind after a kill between the two
        elif existing and not overwrite:
            raise TableExistsError(
                f"{self.json_path}: results already exist; pass resume (--resume) to continue "
                "the run and skip what is done, or overwrite (--overwrite) to start over")
        self._keys = {self.key(row) for row in self.rows}

    @property
    def json_path(self) -> Path:
        return self.folder / f"{self.stem}.json"

    @property
    def csv_path(self) -> Path:
        return self.folder / f"{self.stem}.csv"

    def _remove_temporaries(self) -> None:
        """Delete the temporary files an interrupted :meth:`write` of this table left."""
        if not self.folder.is_dir():
            return
        for name in (self.json_path.name, self.csv_path.name):
            for leftover in self.folder.glob(f".{name}.*.tmp"):
                leftover.unlink(missing_ok=True)

    def _load(self) -> None:
        path = self.json_path
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise InputError(f"result table {str(path)!r}: cannot read ({exc})") from None
        if not isinstance(data, dict) or data.get("format") != TABLE_FORMAT \
                or not isinstance(data.get("rows"), list):
            raise InputError(f"result table {str(path)!r}: not a table written by this version "
                             f"(expected format {TABLE_FORMAT} with a list of rows)")
        stored = data.get("meta", {})
        if stored != self.meta:
            changed = sorted(k for k in set(stored) | set(self.meta)
                             if stored.get(k) != self.meta.get(k))
            raise InputError(f"result table {str(path)!r}: was written with other settings "
                             f"({', '.join(changed)}); resume with the same settings or write "
                             "to another folder")
        self.rows = list(data["rows"])

    def key(self, row: dict) -> tuple:
        """The identity of a row: the values of ``key_fields``."""
        return tuple(_key_part(row.get(name)) for name in self.key_fields)

    def done(self, key_or_row) -> bool:
        """Whether a run with this key (tuple or row dict) is already in the table."""
        key = self.key(key_or_row) if isinstance(key_or_row, dict) else tuple(
            _key_part(k) for k in key_or_row)
        return key in self._keys

    def add(self, row: dict) -> None:
        """Append a row (replacing one with the same key) and rewrite both files atomically."""
        row = json_clean(dict(row))
        key = self.key(row)
        if key in self._keys:
            self.rows = [r for r in self.rows if self.key(r) != key]
        self.rows.append(row)
        self._keys.add(key)
        self.write()

    def write(self) -> None:
        """Rewrite ``stem.json`` and ``stem.csv`` atomically from :attr:`rows`."""
        atomic_write_text(self.json_path, dumps(
            {"format": TABLE_FORMAT, "meta": self.meta, "key_fields": list(self.key_fields),
             "rows": self.rows}))
        atomic_write_text(self.csv_path, rows_to_csv(self.rows))


def rows_to_csv(rows) -> str:
    """CSV text of flat rows; the columns are the union of the keys, in first-seen order."""
    columns: list[str] = []
    for row in rows:
        for name in row:
            if name not in columns:
                columns.append(name)
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if v is None else json.dumps(v) if isinstance(v, (list, dict))
                             else v) for k, v in row.items()})
    return out.getvalue()


def parse_indices(text: str, name: str = "indices") -> list[int]:
    """``"0-5,10,20-22"`` or ``"0-299:6"`` (a step) -> sorted unique ints; ValueError otherwise."""
    out: set[int] = set()
    for part in str(text).replace(" ", "").split(","):
        if not part:
            continue
        try:
            span, _, step = part.partition(":")
            step_n = int(step) if step else 1
            if "-" in span[1:]:
                low, high = span.split("-", 1) if not span.startswith("-") else (span, span)
                lo, hi = int(low), int(high)
            else:
                lo = hi = int(span)
            if step_n < 1 or hi < lo or lo < 0:
                raise ValueError
        except ValueError:
            raise InputError(f"{name} = {text!r}: part {part!r} must be N, A-B or A-B:STEP "
                             "with 0 <= A <= B and STEP >= 1") from None
        out.update(range(lo, hi + 1, step_n))
    if not out:
        raise InputError(f"{name} = {text!r}: no index given")
    return sorted(out)
