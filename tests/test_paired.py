"""``dsmpepc paired``: two benchmark tables compared case by case, with the sign test."""

import csv
import json

import pytest

from dsmpepc_nlp.bench import paired
from dsmpepc_nlp.cli import build_parser, main
from dsmpepc_nlp.core.errors import InputError


def write(path, outcomes, key="episode", times=None):
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, [key, "variant", "outcome", "time_to_goal"])
        writer.writeheader()
        for i, outcome in enumerate(outcomes):
            time = "" if outcome != "success" else (times or {}).get(i, 10.0)
            writer.writerow({key: i, "variant": "ds-mpepc", "outcome": outcome,
                             "time_to_goal": time})
    return str(path)


def test_discordant_cases_and_the_sign_test(tmp_path, capsys):
    a = write(tmp_path / "a.csv", ["success", "collision", "timeout", "success", "timeout"])
    b = write(tmp_path / "b.csv", ["success", "success", "success", "deadlock", "success"],
              times={1: 13.0, 2: 13.0, 4: 13.0})
    assert main(["paired", a, b, "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["cases"] == 5 and result["only_a"] == ["3"]
    assert result["only_b"] == ["1", "2", "4"]
    assert result["success_a"] == pytest.approx(0.4) and result["success_b"] == pytest.approx(0.8)
    assert result["p"] == pytest.approx(0.625)           # 1 against 3 of 4: 2 * 5/16
    assert result["collisions_a"] == 1 and result["collisions_b"] == 0
    assert result["time_a"] == pytest.approx(10.0) and result["time_b"] == pytest.approx(12.25)
    assert result["shared"] == 1 and result["sooner_b"] == result["later_b"] == 0


def test_the_shared_successes_time_counts_only_cases_both_win(tmp_path, capsys):
    a = write(tmp_path / "a.csv", ["success", "success", "success", "timeout"],
              times={0: 10.0, 1: 12.0, 2: 9.0})
    b = write(tmp_path / "b.csv", ["success", "success", "collision", "success"],
              times={0: 8.0, 1: 13.0, 3: 30.0})
    result = paired.compare(paired.load(a, None), paired.load(b, None))
    assert result["shared"] == 2 and result["sooner_b"] == 1 and result["later_b"] == 1
    assert result["shared_time_a"] == pytest.approx(11.0)
    assert result["shared_time_b"] == pytest.approx(10.5)
    assert result["time_b"] == pytest.approx(17.0)              # all of B's successes
    assert main(["paired", a, b]) == 0
    assert "2 shared successes: mean time A 11.00 s, B 10.50 s; B sooner in 1, later in 1" in \
        capsys.readouterr().out


def test_the_sign_test_is_exact_and_symmetric():
    assert paired.sign_test(0, 0) == 1.0
    assert paired.sign_test(2, 10) == pytest.approx(0.0386, abs=1e-4)
    assert paired.sign_test(10, 2) == paired.sign_test(2, 10)
    assert paired.sign_test(0, 9) == pytest.approx(2 / 2 ** 9)


def test_barn_tables_pair_by_world_and_only_shared_cases_count(tmp_path):
    a = paired.load(write(tmp_path / "a.csv", ["success"] * 4, key="world"), None)
    b = paired.load(write(tmp_path / "b.csv", ["success", "deadlock"], key="world"), None)
    result = paired.compare(a, b)
    assert result["cases"] == 2 and result["only_a"] == ["1"] and result["only_b"] == []


def test_cases_keeps_one_split(tmp_path, capsys):
    """BARN's held-out split is its odd worlds: ``--cases 1-5:2`` pairs worlds 1, 3 and 5
    only; a range the package's index syntax refuses is a usage error (status 2)."""
    a = write(tmp_path / "a.csv", ["timeout", "timeout", "success", "timeout", "success",
                                   "timeout"], key="world")
    b = write(tmp_path / "b.csv", ["success"] * 6, key="world")
    assert main(["paired", a, b, "--cases", "1-5:2", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["cases"] == 3 and result["only_b"] == ["1", "3", "5"]
    assert main(["paired", a, b, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["cases"] == 6
    assert main(["paired", a, b, "--cases", "5-1"]) == 2
    assert "--cases = '5-1'" in capsys.readouterr().err


def test_variant_b_pairs_two_planners_of_one_table(tmp_path, capsys):
    """A baseline run beside the product (``--variants orca cv``) pairs with the product's own
    table: ``--variant orca --variant-b ds-mpepc``; without ``--variant-b`` both tables are
    read for ``--variant`` and the product's table, holding none, pairs nothing."""
    base = tmp_path / "base.csv"
    with open(base, "w", newline="") as handle:
        writer = csv.DictWriter(handle, ["episode", "variant", "outcome", "time_to_goal"])
        writer.writeheader()
        for i, (orca, cv) in enumerate([("success", "collision"), ("collision", "success"),
                                        ("deadlock", "collision")]):
            writer.writerow({"episode": i, "variant": "orca", "outcome": orca,
                             "time_to_goal": 9.0 if orca == "success" else ""})
            writer.writerow({"episode": i, "variant": "cv", "outcome": cv,
                             "time_to_goal": 7.0 if cv == "success" else ""})
    product = write(tmp_path / "product.csv", ["collision", "success", "success"])
    assert main(["paired", str(base), product, "--variant", "orca", "--variant-b", "ds-mpepc",
                 "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["cases"] == 3 and result["only_a"] == ["0"] and result["only_b"] == ["1", "2"]
    assert main(["paired", str(base), product, "--variant", "cv", "--variant-b", "ds-mpepc",
                 "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["only_a"] == [] and result["only_b"] == ["2"]
    with pytest.raises(InputError, match="share no case"):
        paired.run(build_parser().parse_args(["paired", str(base), product, "--variant",
                                              "orca"]))
    assert main(["paired", str(base), product, "--variant", "orca"]) == 2
    err = capsys.readouterr().err
    assert "share no case" in err and "product.csv" in err and "'orca'" in err


@pytest.mark.parametrize(("content", "said"), [
    ("", "no rows"),
    ("case,variant,outcome\n0,ds-mpepc,success\n", "no world or episode column"),
    ("episode,variant\n0,ds-mpepc\n", "no outcome column"),
    ("episode,variant,outcome,time_to_goal\n0,ds-mpepc,success,soon\n",
     "episode 0: time_to_goal = 'soon'; expected a number"),
])
def test_a_bad_table_is_named_with_its_field_and_value(tmp_path, capsys, content, said):
    bad = tmp_path / "bad.csv"
    bad.write_text(content)
    good = write(tmp_path / "good.csv", ["success"])
    assert main(["paired", str(bad), good]) == 2
    err = capsys.readouterr().err
    assert err.startswith("dsmpepc: error: table ") and str(bad) in err and said in err
    assert main(["paired", str(tmp_path / "missing.csv"), good]) == 2
    assert "cannot read" in capsys.readouterr().err
