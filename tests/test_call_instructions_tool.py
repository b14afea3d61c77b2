"""tools/dev/call_instructions.py: instructions a compiled call, this checkout against another
revision."""

import shutil

import pytest

# A callgrind output as valgrind writes it: names compressed to "(id)" after their first use;
# after each "calls=" line, the call site's line and its inclusive instructions.
CALLGRIND = """\
version: 1
creator: callgrind-3.19.0
events: Ir
fn=(1) Ipopt::IpoptAlgorithm::Optimize(bool)
0 500
cfn=(2) F_of_z
calls=3 0
0 300
cfn=(3) G_of_z
calls=1 0
0 700
cfn=(2)
calls=1 0
0 104
fn=(2)
0 50
cfn=(4) nlp_abc_f0
calls=4 0
0 354
"""


def test_calls_resolve_compressed_names_and_sum_the_call_sites(tool):
    ci = tool("call_instructions")
    assert ci.calls(CALLGRIND, {"F_of_z", "G_of_z"}) == {"F_of_z": (4, 404),
                                                         "G_of_z": (1, 700)}
    assert ci.calls(CALLGRIND, {"nlp_abc_f0"}) == {"nlp_abc_f0": (4, 354)}
    result = ci.per_call(CALLGRIND)
    assert result["F"] == {"calls": 4, "instructions_per_call": 101.0}
    assert result["G"] == {"calls": 1, "instructions_per_call": 700.0}


def test_an_older_revisions_names_count_too(tool):
    ci = tool("call_instructions")
    old = CALLGRIND.replace("F_of_z", "Fb").replace("G_of_z", "Gb")
    assert ci.per_call(old) == ci.per_call(CALLGRIND)
    ratios = ci.ratios({"base": ci.per_call(old), "this": {
        "F": {"calls": 2, "instructions_per_call": 90.9},
        "G": {"calls": 0, "instructions_per_call": None}}})
    assert ratios["F"] == pytest.approx(0.9) and ratios["G"] is None


def test_the_counted_run_collects_only_inside_the_compiled_calls(tool, tmp_path):
    ci = tool("call_instructions")
    args, env = ci.command(tmp_path, 5, tmp_path / "this.callgrind")
    assert args[:2] == ["valgrind", "--tool=callgrind"]
    assert {a for a in args if a.startswith("--toggle-collect=")} == {
        "--toggle-collect=F_of_z", "--toggle-collect=Fb", "--toggle-collect=G_of_z",
        "--toggle-collect=Gb"}
    assert "demo_cycles(config, 5, 0)" in args[-1] and env == {"PYTHONPATH": str(tmp_path)}
    plain, _ = ci.command(tmp_path, 5, None)
    assert plain[0] != "valgrind" and plain[-1] == args[-1]


def test_without_valgrind_it_says_so(tool, monkeypatch, capsys):
    ci = tool("call_instructions")
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(SystemExit):
        ci.main(["HEAD"])
    assert "valgrind is not installed" in capsys.readouterr().err


def test_out_keeps_both_callgrind_files(tool, monkeypatch, tmp_path):
    ci = tool("call_instructions")
    monkeypatch.setattr(shutil, "which", lambda name: "/usr/bin/valgrind")
    monkeypatch.setattr(ci.subprocess, "run", lambda *a, **k: None)

    def fake_sides(sides, cycles, folder):
        for side in sides:
            (folder / f"{side}.callgrind").write_text(CALLGRIND)
        return {side: ci.per_call(CALLGRIND) for side in sides}

    monkeypatch.setattr(ci, "run_sides", fake_sides)
    assert ci.main(["HEAD", "--out", str(tmp_path / "kept"), "--json"]) == 0
    assert sorted(p.name for p in (tmp_path / "kept").iterdir()) == ["base.callgrind",
                                                                     "this.callgrind"]
