"""tools/dev/bench_pairs.py: this checkout's plan time against another revision, alternated."""

import json
import math

import pytest


def run(median, p95=50.0, us=9.0):
    """A bench object as ``dsmpepc bench --json`` writes it (the fields the tool reads)."""
    return {"default": {"median_ms": median, "p95_ms": p95, "overhead_ms": 9.0,
                        "solver_ms": median - 9.0},
            "fast": {"median_ms": median / 2, "overhead_ms": 5.0, "solver_ms": median / 2 - 5},
            "sampling": {"median_ms": 150.0}, "exact_us_per_trajectory": us}


def test_pairs_ratios_and_medians(tool):
    pairs = tool("bench_pairs")
    summary = pairs.summarise([run(10.0), run(20.0), run(30.0)],
                              [run(11.0), run(18.0), run(36.0)])
    row = summary["default median, ms"]
    assert row["base_median"] == 20.0 and row["this_median"] == 18.0
    assert row["ratio_of_medians"] == pytest.approx(0.9)
    assert row["pairs"] == 3
    assert row["pairs_ratio_median"] == pytest.approx(1.1)      # 1.1, 0.9, 1.2
    assert row["pairs_ratio_min"] == pytest.approx(0.9)
    assert row["pairs_ratio_max"] == pytest.approx(1.2)
    assert summary["sampler median, ms"]["pairs_ratio_median"] == pytest.approx(1.0)
    assert "default median, ms" in pairs.table(summary)


def test_a_figure_an_older_version_lacks_is_nan_not_an_error(tool):
    pairs = tool("bench_pairs")
    old = run(10.0)
    del old["default"]["overhead_ms"]
    row = pairs.summarise([old], [run(10.0)])["default outside the solves, ms"]
    assert math.isnan(row["base_median"]) and row["pairs"] == 0
    with pytest.raises(ValueError):
        pairs.summarise([run(1.0)], [])


def test_sides_alternate_and_the_worktree_is_removed(tool, monkeypatch, tmp_path, capsys):
    pairs = tool("bench_pairs")
    calls, git = [], []

    def fake_bench(source, cycles, out, cwd, mode="bench"):
        side = "this" if source == pairs.REPO else "base"
        calls.append((side, out.name))
        return run(20.0 if side == "base" else 22.0)

    monkeypatch.setattr(pairs, "bench", fake_bench)
    monkeypatch.setattr(pairs.subprocess, "run", lambda args, **kw: git.append(args[3:5]))
    assert pairs.main(["HEAD~1", "--pairs", "3", "--out", str(tmp_path), "--json"]) == 0
    assert calls == [("base", "base-warmup.json"), ("this", "this-warmup.json"),
                     ("base", "base-0.json"), ("this", "this-0.json"),
                     ("this", "this-1.json"), ("base", "base-1.json"),
                     ("base", "base-2.json"), ("this", "this-2.json")]
    assert [g[0] for g in git] == ["worktree", "worktree"] and git[-1][1] == "remove"
    result = json.loads(capsys.readouterr().out)
    assert result["figures"]["default median, ms"]["pairs_ratio_median"] == pytest.approx(1.1)

    def failing_bench(source, cycles, out, cwd, mode="bench"):
        raise SystemExit("bench failed")

    git.clear()
    monkeypatch.setattr(pairs, "bench", failing_bench)
    with pytest.raises(SystemExit):
        pairs.main(["HEAD~1", "--pairs", "1", "--out", str(tmp_path)])
    assert git[-1][1] == "remove"


def test_the_iteration_program_times_ipopt_on_this_checkout(tool, tmp_path):
    """``--iterations``: the same program on both sides; here, on this checkout, two cycles."""
    pairs = tool("bench_pairs")
    result = pairs.bench(pairs.REPO, 2, tmp_path / "run.json", tmp_path, mode="iterations")
    assert json.loads((tmp_path / "run.json").read_text()) == result
    assert 0.0 < result["default"]["ms_per_iteration"] < 1e3
    assert result["default"]["iterations"] >= 1.0
    summary = pairs.summarise([result], [result], pairs.ITERATION_FIGURES)
    assert summary["default ms an iteration"]["pairs_ratio_median"] == pytest.approx(1.0)


def test_the_fresh_program_times_a_new_process_on_this_checkout(tool, tmp_path):
    """``--fresh``: the import and the first plan of a new interpreter, its whole wall time
    added by the parent (which includes both parts)."""
    pairs = tool("bench_pairs")
    result = pairs.bench(pairs.REPO, 1, tmp_path / "run.json", tmp_path, mode="fresh")
    assert json.loads((tmp_path / "run.json").read_text()) == result
    fresh = result["fresh"]
    assert fresh["import_ms"] > 0 and fresh["plan_ms"] > 0
    assert fresh["first_plan_ms"] == pytest.approx(fresh["import_ms"] + fresh["plan_ms"])
    assert fresh["process_ms"] > fresh["first_plan_ms"]
    summary = pairs.summarise([result], [result], pairs.FRESH_FIGURES)
    assert summary["first plan, ms"]["pairs_ratio_median"] == pytest.approx(1.0)


def test_iterations_and_fresh_together_are_refused(tool):
    with pytest.raises(SystemExit):
        tool("bench_pairs").main(["HEAD", "--iterations", "--fresh"])
