"""tools/dev/nav_rebuild.py: a moving goal's navigation function, the map's window kept or not."""


def test_a_kept_window_gives_the_values_of_a_build_from_nothing(capsys, tool):
    assert tool("nav_rebuild").main(["--goals", "3"]) == 0
    out = capsys.readouterr().out
    assert "hall, 3 goals" in out and "values the same: True" in out
