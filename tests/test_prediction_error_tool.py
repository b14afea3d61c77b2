"""tools/dev/prediction_error.py: the constant-velocity prediction's error by look-ahead."""


import numpy as np


def test_a_straight_walker_is_predicted_exactly_and_a_turn_is_not(tmp_path, tool):
    folder = tmp_path / "toy" / "test"
    folder.mkdir(parents=True)
    rows = []
    for k in range(12):                      # 0.4 s a step: ped 1 straight at 1 m/s,
        t = 0.4 * k                          # ped 2 turns by 90 degrees after 2 s
        rows.append((10 * k, 1, t, 0.0))
        rows.append((10 * k, 2, min(t, 2.0), max(t - 2.0, 0.0)))
    (folder / "toy.txt").write_text("".join(f"{f:.1f}\t{p:.1f}\t{x:.3f}\t{y:.3f}\n"
                                            for f, p, x, y in rows))
    found = tool("prediction_error").errors(tmp_path, "toy", horizon=2.0)
    assert sorted(found) == [0.4, 0.8, 1.2, 1.6, 2.0]
    for error in found.values():
        assert error.shape[1] == 2
        assert np.min(np.abs(error).sum(axis=1)) < 1e-9      # the straight walker: exact
        assert np.max(np.linalg.norm(error, axis=1)) > 0.1   # the turn: off
