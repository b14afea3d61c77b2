"""``dsmpepc table``: the product and the paper preset side by side, from their folders."""

import json

import pytest

from dsmpepc_nlp.bench import results_table as table
from dsmpepc_nlp.bench.results import ResultTable
from dsmpepc_nlp.cli import main
from dsmpepc_nlp.core.errors import InputError


def crowd_row(episode, outcome, kind=None, time=None, path=None, plan=0.02):
    return {"episode": episode, "seed": 0, "variant": "ds-mpepc", "outcome": outcome,
            "collision_kind": kind, "time": time or 20.0, "time_to_goal": time,
            "path_length": path or 5.0, "spl": 0.0, "discomfort": 0.0, "min_distance": 0.3,
            "jerk": 0.0, "plan_time_median": plan, "plan_time_p95": 2 * plan}


def folder(root, name, rows, failures=None):
    table = ResultTable(root / name, "crowdnav", ("variant", "episode", "seed"),
                        {"benchmark": "crowdnav", "scene": "circle", "setting": "invisible"})
    for row in rows:
        table.add(row)
    if failures is not None:
        report = {"counts": {}, "failures": [
            {"class": name, "label": f"crowdnav variant=ds-mpepc episode={episode} seed=0"}
            for episode, name in failures]}
        (root / name / "failures.json").write_text(json.dumps(report))


def test_each_preset_is_summarised_on_the_cases_both_ran(tmp_path):
    folder(tmp_path, "ci-product", [
        crowd_row(0, "success", time=10.0, path=8.0, plan=0.010),
        crowd_row(1, "success", time=12.0, path=9.0, plan=0.030),
        crowd_row(2, "collision", "struck"),
        crowd_row(3, "success", time=11.0),
        crowd_row(4, "timeout")],                          # the paper preset never ran it
        failures=[(2, "struck-stopped"), (4, "slow")])
    folder(tmp_path, "ci-paper", [
        crowd_row(0, "success", time=14.0, path=10.0),
        crowd_row(1, "deadlock"),
        crowd_row(2, "collision", "at-fault"),
        crowd_row(3, "deadlock")],
        failures=[(1, "stalled-near-goal-person"), (2, "at-fault"), (3, "oscillating")])
    [entry] = table.navigation(table.pairs(tmp_path))
    product, paper = entry["presets"]["product"], entry["presets"]["paper"]
    assert entry["label"] == "CrowdNav circle invisible, 4"
    assert product["runs"] == paper["runs"] == 4
    assert product["success_rate"] == 0.75 and product["timeout_rate"] == 0.0
    assert product["struck_rate"] == 0.25 and product["at_fault_rate"] == 0.0
    assert paper["success_rate"] == 0.25 and paper["deadlock_rate"] == 0.5
    assert paper["at_fault_rate"] == 0.25
    assert product["time_to_goal"] == pytest.approx(11.0)        # successes only
    assert product["path_length"] == pytest.approx((8.0 + 9.0 + 5.0) / 3)
    assert product["plan_time_median"] == pytest.approx(0.02)
    assert product["classes"] == {"struck-stopped": 1}           # episode 4 is not shared
    assert paper["classes"] == {"at-fault": 1, "stalled-near-goal-person": 1,
                                "oscillating": 1}
    assert entry["only"] == {"product": ["1", "3"], "paper": []}
    assert entry["p"] == pytest.approx(0.5)


def test_the_markdown_has_a_line_per_preset_and_says_what_was_not_classified(tmp_path):
    folder(tmp_path, "ci-product", [crowd_row(0, "success", time=10.0)])
    folder(tmp_path, "ci-paper", [crowd_row(0, "timeout")])
    text = table.markdown(table.navigation(table.pairs(tmp_path)), [])
    product, paper = text.splitlines()[2:4]
    assert product.startswith("| CrowdNav circle invisible, 1 | product | 1.000 |")
    assert "| not classified | 1 |" in product
    assert paper.startswith("|  | paper | 0.000 |") and paper.endswith("| 0 (p = 1) |")


def test_a_folder_searched_for_ways_out_gets_a_line_of_the_bound_table(tmp_path):
    folder(tmp_path, "ci-product", [crowd_row(0, "success", time=10.0), crowd_row(1, "timeout")])
    folder(tmp_path, "ci-paper", [crowd_row(0, "timeout"), crowd_row(1, "timeout")])
    report = {"runs": 2, "no_way_out": 0, "goal_never_free": 1, "bound_given_path": 0.5,
              "failures": []}
    (tmp_path / "ci-product" / "failures.json").write_text(json.dumps(report))
    text = table.markdown(table.navigation(table.pairs(tmp_path)), [])
    assert "| success at most, given the path |" in text
    assert "| CrowdNav circle invisible, 2 | product | 0.500 | 0 | 1 | 0.500 (2 runs) |" in text
    assert "| paper | 0.000 | 0 |" not in text                   # not searched: no line


def test_a_product_folder_without_its_paper_folder_is_refused(tmp_path):
    folder(tmp_path, "ci-product", [crowd_row(0, "success", time=10.0)])
    with pytest.raises(InputError, match="no <name>-product folder with its <name>-paper"):
        table.pairs(tmp_path)


def test_the_command_prints_the_markdown_or_one_json_object(tmp_path, capsys):
    folder(tmp_path, "ci-product", [crowd_row(0, "success", time=10.0), crowd_row(1, "timeout")])
    folder(tmp_path, "ci-paper", [crowd_row(0, "timeout"), crowd_row(1, "timeout")])
    assert main(["table", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "| CrowdNav circle invisible, 2 | product | 0.500 |" in text
    assert main(["table", str(tmp_path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    [entry] = data["navigation"]
    assert entry["only"] == {"product": ["0"], "paper": []} and data["scenarios"] == []
    assert entry["presets"]["paper"]["time_to_goal"] is None     # no success: null, not NaN


def test_bad_folders_exit_2_naming_the_folder(tmp_path, capsys):
    assert main(["table", str(tmp_path / "none")]) == 2
    assert "not a folder" in capsys.readouterr().err
    folder(tmp_path, "ci-product", [crowd_row(0, "success", time=10.0)])
    (tmp_path / "ci-paper").mkdir()
    assert main(["table", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "ci-paper" in err and "0 benchmark tables" in err and "expected one" in err
