"""``dsmpepc merge``: one benchmark folder from runs of the same benchmark on other cases."""

import json

import pytest

from dsmpepc_nlp.bench.merge_tables import merge
from dsmpepc_nlp.bench.results import ResultTable
from dsmpepc_nlp.cli import main
from dsmpepc_nlp.core.errors import InputError

META = {"benchmark": "barn", "variant": "ds-mpepc", "solver": "nlp"}


def folder(path, worlds, meta=META):
    table = ResultTable(path, "barn", ("world", "variant", "solver"), meta)
    for world in worlds:
        failed = world % 3 == 0
        row = {"world": world, "variant": "ds-mpepc", "solver": "nlp",
               "outcome": "deadlock" if failed else "success",
               "episode_file": f"episodes/barn-{world}.npz" if failed else None}
        if failed:
            (path / "episodes").mkdir(parents=True, exist_ok=True)
            (path / row["episode_file"]).write_bytes(bytes([world]))
        table.add(row)
    return path


def test_rows_and_kept_episodes_of_both_folders_make_one_table(tmp_path):
    even = folder(tmp_path / "even", [0, 2, 4])
    odd = folder(tmp_path / "odd", [1, 3, 5])
    path = merge([even, odd], tmp_path / "all")
    data = json.loads(path.read_text())
    assert [row["world"] for row in data["rows"]] == [0, 1, 2, 3, 4, 5]
    assert data["meta"] == META
    assert (tmp_path / "all" / "episodes" / "barn-3.npz").read_bytes() == bytes([3])
    assert (tmp_path / "all" / "barn.csv").read_text().count("\n") == 7
    again = ResultTable(tmp_path / "all", "barn", ("world", "variant", "solver"), META,
                        resume=True)                      # the package reads it back
    assert len(again.rows) == 6


@pytest.mark.parametrize("case", ["overlap", "settings", "exists"])
def test_refused_with_nothing_written(tmp_path, case):
    even = folder(tmp_path / "even", [0, 2])
    other = {"overlap": lambda: folder(tmp_path / "b", [2, 3]),
             "settings": lambda: folder(tmp_path / "b", [1], {**META, "solver": "fast"}),
             "exists": lambda: folder(tmp_path / "b", [1])}[case]()
    if case == "exists":
        (tmp_path / "all").mkdir()
    with pytest.raises(InputError, match="both|settings|exists"):
        merge([even, other], tmp_path / "all")
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted(["even", "b"] + (["all"] if case == "exists" else []))
    if case == "exists":
        assert not any((tmp_path / "all").iterdir())


def test_the_command_merges_and_refuses_one_folder(tmp_path, capsys):
    even = folder(tmp_path / "even", [0, 2])
    odd = folder(tmp_path / "odd", [1])
    assert main(["merge", str(even), str(odd), "--out", str(tmp_path / "all")]) == 0
    assert "barn.json: 3 rows from 2 folders" in capsys.readouterr().out
    assert main(["merge", str(even), "--out", str(tmp_path / "one")]) == 2
    assert "give two folders or more" in capsys.readouterr().err
    assert main(["merge", str(even), str(odd), "--out", str(tmp_path / "all")]) == 2
    assert "exists; choose a new folder" in capsys.readouterr().err
    assert not (tmp_path / "one").exists()
