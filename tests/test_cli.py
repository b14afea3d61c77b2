"""The command line: JSON on stdout, progress on stderr, files written, status 2 on bad input."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from dsmpepc_nlp.cli import main
from dsmpepc_nlp.sim.episode import Episode

TINY = {
    "name": "tiny",
    "duration": 9.0,    # the goal beyond the docking reach (5 m): the first plans are sampled
    "robots": [{"name": "a", "start": [0.0, 0.0, 0.0], "goal": {"position": [5.5, 0.3]}}],
    "pedestrians": [{"start": [3.0, 3.0], "velocity": [-0.4, 0.0]}],
}


@pytest.fixture
def tiny(tmp_path):
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY))
    return str(path)


def test_list_json_names_the_six_builtins(capsys):
    assert main(["list", "--json"]) == 0
    items = json.loads(capsys.readouterr().out)
    assert {i["name"] for i in items} == {"t-corridor", "narrow-corridor", "circle-4",
                                          "circle-10", "hall", "l-corridor"}


def test_run_json_prints_outcomes_and_metrics_and_writes_files(tiny, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["run", tiny, "--solver", "sampling", "--out", str(out), "--json",
                 "--samples", "2"])
    captured = capsys.readouterr()
    assert code == 0
    result = json.loads(captured.out)  # stdout is exactly one JSON object
    assert result["outcomes"] == ["success"]
    assert result["metrics"][0]["outcome"] == "success"
    assert result["metrics"][0]["path_length"] > 2.2
    assert result["variant"] == "ds-mpepc" and result["solver"] == "sampling"
    assert "tiny ds-mpepc sampling" in captured.err  # progress went to stderr
    episode = Episode.load(result["files"]["episode"])
    assert episode.outcomes == ["success"] and len(episode.samples) >= 1
    assert (out / "tiny-ds-mpepc-sampling-seed0.png").is_file()


def test_run_human_output_says_where_the_figures_went(tiny, tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["run", tiny, "--solver", "sampling", "--out", str(out), "--variant", "mpepc",
                 "--samples", "0"]) == 0
    text = capsys.readouterr().out
    assert "outcome" in text and "success" in text
    assert f"figure: {out / 'tiny-mpepc-sampling-seed0.png'}" in text


def test_the_same_seed_gives_the_same_run(tiny, tmp_path, capsys):
    results = []
    for folder in ("a", "b"):
        main(["run", tiny, "--solver", "sampling", "--out", str(tmp_path / folder), "--json",
              "--samples", "0"])
        results.append(json.loads(capsys.readouterr().out))
    a, b = (Episode.load(r["files"]["episode"]) for r in results)
    assert np.array_equal(a.states, b.states)


def test_compare_json_is_keyed_by_variant_and_writes_a_figure(tiny, tmp_path, capsys):
    out = tmp_path / "cmp"
    assert main(["compare", tiny, "--solver", "sampling", "--out", str(out), "--json",
                 "--variants", "mpepc", "pc-only"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert set(result) == {"mpepc", "pc-only"}
    for variant, run in result.items():
        assert run["variant"] == variant and len(run["outcomes"]) == 1
    figure = result["mpepc"]["files"]["compare_figure"]
    assert figure.endswith(".png") and (out / figure.split("/")[-1]).is_file()


def test_compare_human_prints_a_table(tiny, tmp_path, capsys):
    assert main(["compare", tiny, "--solver", "sampling", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert text.count("success") == 2 and "mpepc" in text and "figure:" in text


@pytest.mark.parametrize("argv, words", [
    (["run", "no-such-scenario"], "not a built-in"),
    (["run", "t-corridor", "--seed", "-3"], "--seed"),
    (["run", "t-corridor", "--variant", "fast"], "--variant"),
    (["run", "t-corridor", "--solver", "cplex"], "--solver"),
    (["compare", "t-corridor", "--variants", "mpepc", "nope"], "nope"),
    (["compare", "t-corridor", "--variants", "mpepc", "mpepc"], "repeats"),
    (["frobnicate"], "invalid choice"),
    (["crosscheck", "t-corridor", "--solver", "sampling"], "must be nlp or fast"),
    (["bench", "--cycles", "0"], "--cycles"),
    ([], "required"),
])
def test_bad_input_exits_2_with_one_line(argv, words, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err and err.startswith("dsmpepc")


def test_a_broken_scenario_file_exits_2_naming_the_field(tmp_path, capsys):
    bad = dict(TINY, duration=-1)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(bad))
    assert main(["run", str(path), "--solver", "sampling", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml" in err and "duration" in err and err.count("\n") == 1


def test_run_draws_the_cost_panels_of_a_cycle(tiny, tmp_path, capsys):
    assert main(["run", tiny, "--solver", "sampling", "--out", str(tmp_path), "--json",
                 "--samples", "0", "--panels", "0.4"]) == 0
    files = json.loads(capsys.readouterr().out)["files"]
    assert files["panels"].endswith(".png") and Path(files["panels"]).is_file()
    assert main(["run", tiny, "--solver", "sampling", "--panels", "-1"]) == 2


@pytest.mark.parametrize("option, value, allowed", [
    ("--samples", "-5", ">= 1"),
    ("--workers", "-1", ">= 1"),
    ("--workers", "0", ">= 1"),
    ("--start-noise", "-1", ">= 0"),
    ("--start-noise", "nan", ">= 0"),
    ("--start-noise", "inf", ">= 0"),
])
def test_benchmark_options_are_checked_before_anything_runs_or_is_stored(
        option, value, allowed, tiny, tmp_path, capsys):
    out = tmp_path / "never"
    argv = ["benchmark", "scenarios", "--scenarios", tiny, "--variants", "mpepc",
            "--solver", "sampling", "--out", str(out), option, value]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and option in err and value in err and allowed in err
    assert not out.exists()


@pytest.mark.parametrize("argv, option", [
    (["sweep", "--param", "s_ttc=1", "--scenarios", "t-corridor", "--samples", "0"],
     "--samples"),
    (["benchmark", "barn", "--data", ".", "--v-limit", "nan"], "--v-limit"),
    (["benchmark", "barn", "--data", ".", "--workers", "-1"], "--workers"),
    (["benchmark", "crowd", "--data", ".", "--scene", "eth", "--episodes", "0"], "--episodes"),
    (["benchmark", "crowd", "--data", ".", "--scene", "eth", "--duration", "-3"], "--duration"),
])
def test_every_benchmark_checks_its_numbers(argv, option, tmp_path, capsys):
    assert main(argv + ["--out", str(tmp_path / "never")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"argument {option}" in err
    assert not (tmp_path / "never").exists()


def test_the_text_summary_prints_nested_results_as_lines_not_json():
    from dsmpepc_nlp.bench.summary import summary_text

    text = summary_text({"runs": 4, "variants": {"circle-4": {"runs": 4, "success_rate": 0.5,
                                                              "time": float("nan")}}})
    assert text.splitlines() == ["runs: 4", "variants:", "  circle-4:", "    runs: 4",
                                 "    success_rate: 0.5", "    time: nan"]
    assert '"' not in text and "\\" not in text


def test_a_resumed_benchmark_with_nothing_left_rewrites_the_csv(tiny, tmp_path, capsys):
    out = tmp_path / "s"
    argv = ["benchmark", "scenarios", "--scenarios", tiny, "--variants", "mpepc",
            "--solver", "sampling", "--samples", "16", "--workers", "1", "--out", str(out)]
    assert main(argv) == 0
    written = (out / "scenarios.csv").read_text()
    (out / "scenarios.csv").unlink()
    assert main(argv + ["--resume"]) == 0
    assert "1 already done, 0 to run" in capsys.readouterr().err
    assert (out / "scenarios.csv").read_text() == written


def test_input_error_is_importable_from_the_package_root():
    from dsmpepc_nlp import InputError
    from dsmpepc_nlp.core.errors import InputError as Same

    assert InputError is Same
