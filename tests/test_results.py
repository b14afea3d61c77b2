"""Result tables: atomic writes, resume skipping done rows, strict JSON, index ranges."""

import io
import json
import os

import pytest

from dsmpepc_nlp.bench.results import ResultTable, parse_indices
from dsmpepc_nlp.core import jsonio
from dsmpepc_nlp.core.files import atomic_write_text


def test_atomic_write_leaves_old_file_and_no_temp_on_error(tmp_path, monkeypatch):
    path = tmp_path / "table.json"
    atomic_write_text(path, "old")

    def broken(src, dst):
        raise OSError("disk gone")

    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(OSError):
        atomic_write_text(path, "new")
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["table.json"]


def test_table_add_that_fails_to_serialise_leaves_no_partial_file(tmp_path):
    table = ResultTable(tmp_path, "t", ("k",))
    table.add({"k": 1, "v": 1.0})
    before = (tmp_path / "t.json").read_text()
    with pytest.raises(TypeError):
        table.add({"k": 2, "v": object()})
    assert (tmp_path / "t.json").read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv", "t.json"]


def test_resume_keeps_rows_and_skips_done_keys(tmp_path):
    table = ResultTable(tmp_path, "t", ("world", "variant"), {"a": 1})
    table.add({"world": 0, "variant": "x", "score": float("nan")})
    table.add({"world": 1, "variant": "x", "score": 0.25})
    data = json.loads((tmp_path / "t.json").read_text())
    assert data["rows"][0]["score"] is None  # strict JSON: NaN -> null
    again = ResultTable(tmp_path, "t", ("world", "variant"), {"a": 1}, resume=True)
    assert again.done((0, "x")) and again.done({"world": 1.0, "variant": "x"})
    assert not again.done((2, "x"))
    assert len(again.rows) == 2
    csv_lines = (tmp_path / "t.csv").read_text().splitlines()
    assert csv_lines[0] == "world,variant,score" and len(csv_lines) == 3


def test_existing_table_needs_resume_or_overwrite_and_same_settings(tmp_path):
    ResultTable(tmp_path, "t", ("k",), {"a": 1}).add({"k": 0})
    with pytest.raises(FileExistsError, match="--resume"):
        ResultTable(tmp_path, "t", ("k",), {"a": 1})
    with pytest.raises(ValueError, match="other settings .*a"):
        ResultTable(tmp_path, "t", ("k",), {"a": 2}, resume=True)
    assert ResultTable(tmp_path, "t", ("k",), {"a": 2}, overwrite=True).rows == []


def test_unreadable_table_on_resume_names_the_file(tmp_path):
    (tmp_path / "t.json").write_text("{not json")
    with pytest.raises(ValueError, match="t.json"):
        ResultTable(tmp_path, "t", ("k",), resume=True)


def test_parse_indices():
    assert parse_indices("0-3,7") == [0, 1, 2, 3, 7]
    assert parse_indices("0-299:6")[:3] == [0, 6, 12] and len(parse_indices("0-299:6")) == 50
    for bad in ("3-1", "a", "1-2:0"):
        with pytest.raises(ValueError, match="must be"):
            parse_indices(bad)
    with pytest.raises(ValueError, match="no index"):
        parse_indices(",")


def test_json_clean_handles_numpy():
    import numpy as np

    assert jsonio.json_clean({"a": np.float64("inf"), "b": [np.int64(3)]}) == {"a": None,
                                                                                "b": [3]}


def test_atomic_writes_get_ordinary_permissions(tmp_path):
    import os
    import stat

    from dsmpepc_nlp.core.files import atomic_write_text

    path = atomic_write_text(tmp_path / "table.csv", "a,b\n")
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~mask


def _killed_mid_write(folder):
    """The state a SIGKILL between the JSON and the CSV write leaves: two rows in the JSON, one
    in the CSV, and the hidden temporary files of the interrupted writes."""
    table = ResultTable(folder, "t", ("k",), {"a": 1})
    table.add({"k": 0, "x": 1.0})
    one_row_csv = (folder / "t.csv").read_text()
    table.add({"k": 1, "x": 2.0})
    (folder / "t.csv").write_text(one_row_csv)
    (folder / ".t.json.abc123.tmp").write_text('{"format": 1, "ro')
    (folder / ".t.csv.def456.tmp").write_text("k,x\n0,")
    (folder / ".other.json.zzz.tmp").write_text("not ours")


def test_opening_a_table_removes_the_temporaries_a_killed_write_left(tmp_path):
    _killed_mid_write(tmp_path)
    ResultTable(tmp_path, "t", ("k",), {"a": 1}, resume=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".other.json.zzz.tmp", "t.csv",
                                                          "t.json"]


def test_resume_makes_the_csv_agree_with_the_json(tmp_path):
    _killed_mid_write(tmp_path)
    table = ResultTable(tmp_path, "t", ("k",), {"a": 1}, resume=True)
    assert len(table.rows) == 2
    assert (tmp_path / "t.csv").read_text().splitlines() == ["k,x", "0,1.0", "1,2.0"]


def test_a_resumed_run_with_nothing_left_rewrites_the_csv(tmp_path):
    from dsmpepc_nlp.bench.runner import run_all

    table = ResultTable(tmp_path, "t", ("k",))
    table.add({"k": 0, "x": 1.0})
    (tmp_path / "t.csv").unlink()
    assert run_all(dict, [((("k", 0),),)], table, label="t", key=lambda task: (0,),
                   progress=None) == 0
    assert (tmp_path / "t.csv").read_text().splitlines() == ["k,x", "0,1.0"]


def test_run_all_adds_one_row_per_task_and_skips_done_keys(tmp_path):
    from dsmpepc_nlp.bench.runner import run_all

    table = ResultTable(tmp_path, "t", ("k",))
    table.add({"k": 1, "x": "old"})
    tasks = [((("k", k), ("x", "new")),) for k in range(3)]
    ran = run_all(dict, tasks, table, label="t", key=lambda task: (task[0][0][1],),
                  workers=1, progress=None)
    assert ran == 2
    assert sorted((r["k"], r["x"]) for r in table.rows) == [(0, "new"), (1, "old"), (2, "new")]
    assert json.loads((tmp_path / "t.json").read_text())["rows"] == table.rows


def test_an_existing_table_is_an_input_error_naming_both_options(tmp_path):
    from dsmpepc_nlp.core.errors import InputError

    ResultTable(tmp_path, "t", ("k",)).add({"k": 0})
    with pytest.raises(InputError, match="--resume.*--overwrite"):
        ResultTable(tmp_path, "t", ("k",))


def test_run_all_in_worker_processes_gives_the_same_rows(tmp_path):
    from dsmpepc_nlp.bench.runner import run_all

    tasks = [((("k", k), ("square", k * k)),) for k in range(4)]
    inline, pooled = ResultTable(tmp_path / "a", "t", ("k",)), ResultTable(tmp_path / "b", "t",
                                                                            ("k",))
    run_all(dict, tasks, inline, label="t", workers=1, progress=None)
    assert run_all(dict, tasks, pooled, label="t", workers=2, progress=None) == 4
    assert sorted(r["k"] for r in pooled.rows) == [0, 1, 2, 3]
    assert sorted(pooled.rows, key=lambda r: r["k"]) == inline.rows


def test_outcome_rates_and_mean():
    from dsmpepc_nlp.bench.runner import mean, outcome_rates

    rates = outcome_rates(["success", "success", "collision", "error"])
    assert rates == {"success_rate": 0.5, "collision_rate": 0.25, "timeout_rate": 0.0,
                     "deadlock_rate": 0.0, "error_rate": 0.25}
    assert all(v != v for v in outcome_rates([]).values())  # NaN without rows
    rows = [{"t": 1.0, "o": "a"}, {"t": None, "o": "a"}, {"t": 3.0, "o": "b"}]
    assert mean(rows, "t") == 2.0 and mean(rows, "t", lambda r: r["o"] == "b") == 3.0
    assert mean(rows, "t", lambda r: False) != mean(rows, "t", lambda r: False)  # NaN


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_shows_a_bar_on_a_terminal_and_nothing_elsewhere():
    from dsmpepc_nlp.core.progress import EpisodeProgress, bar

    for stream, shown in ((_Terminal(), True), (io.StringIO(), False)):
        progress = bar(3, "runs", stream=stream)
        for _ in range(3):
            progress.update(1)
        progress.close()
        assert ("3/3" in stream.getvalue()) is shown
    quiet = io.StringIO()
    episode = EpisodeProgress("tiny", stream=quiet)
    episode(0, 0.2, 5, 1)
    episode.done("success")
    assert quiet.getvalue().startswith("[tiny] success (") and quiet.getvalue().count("\n") == 1
