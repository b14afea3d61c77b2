"""tools/dev/crowd_compare.py: one replay driven by several planners, side by side."""

import numpy as np
import pytest
from test_crowds import write_recording


def test_a_variant_drives_the_benchmarks_own_draw(tmp_path, tool):
    """The tool's run of a replay is the benchmark's: the same draw, the same states."""
    from dsmpepc_nlp.bench import crowds

    write_recording(tmp_path / "data" / "toy" / "test" / "toy.txt")
    settings = crowds.CrowdSettings(data=str(tmp_path / "data"), scene="toy")
    episodes = tool("crowd_compare").run(settings, 1, 0, ["cv"])
    alone, draw = crowds.simulate_episode(settings, "cv", 1, 0)
    assert list(episodes) == ["cv"]
    assert np.array_equal(episodes["cv"].states, alone.states)
    assert np.allclose(episodes["cv"].states[0, 0, :2], draw["start"])


def test_the_lines_and_the_figure(tmp_path, capsys, tool):
    """A line a variant (outcome, time, nearest gap, path) and one figure."""
    write_recording(tmp_path / "data" / "toy" / "test" / "toy.txt")
    out = tmp_path / "compare.png"
    assert tool("crowd_compare").main(["--data", str(tmp_path / "data"), "--scene", "toy",
                                       "--episode", "1", "--variants", "cv", "--out",
                                       str(out)]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].startswith("cv: ") and "nearest gap to a person" in printed[0]
    assert printed[-1] == f"figure: {out}" and out.stat().st_size > 10_000


def test_a_bad_set_is_a_usage_error(tmp_path, tool):
    with pytest.raises(SystemExit):
        tool("crowd_compare").main(["--data", str(tmp_path), "--scene", "toy", "--episode",
                                    "0", "--set", "stall.passive"])
