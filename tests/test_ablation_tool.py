"""tools/dev/ablation.py: which extensions run where, and the leave-one-out table from two
folders of benchmark tables (made here as small files, no benchmark run)."""

import csv


def write_table(folder, outcomes, times):
    folder.mkdir(parents=True)
    with open(folder / "crowdnav.csv", "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, ["episode", "variant", "outcome", "time_to_goal"])
        writer.writeheader()
        for k, (outcome, time) in enumerate(zip(outcomes, times)):
            writer.writerow({"episode": k, "variant": "ds-mpepc", "outcome": outcome,
                             "time_to_goal": time if outcome == "success" else ""})


def test_an_extension_runs_only_where_it_can_act(tool):
    ablation = tool("ablation")
    assert ablation.applies("defaults", "barn") and ablation.applies("defaults", "scenarios")
    assert not ablation.applies("dodge", "barn") and ablation.applies("dodge", "circle")
    assert ablation.applies("dock-follow", "scenarios")
    assert not ablation.applies("dock-follow", "circle")
    assert not ablation.applies("ladder", "scenarios")
    assert all(pairs and all("=" in p for p in pairs) for pairs in ablation.EXTENSIONS.values())


def test_the_table_counts_what_each_extension_wins_and_costs(tool, tmp_path):
    """Off, the ladder loses case 1 and wins case 2 (one collision each way), and the shared
    success (case 0) arrives 0.5 s later; an extension never run has no row, and the scenarios
    (no cases to pair) are left out."""
    ablation = tool("ablation")
    write_table(tmp_path / "defaults" / "circle", ["success", "success", "collision"],
                [10.0, 11.0, ""])
    write_table(tmp_path / "ladder" / "circle", ["success", "collision", "success"],
                [10.5, "", 12.0])
    rows = ablation.report(tmp_path, {"circle": [], "scenarios": []})
    assert len(rows) == 1
    row = rows[0]
    assert (row["extension"], row["lost_off"], row["won_off"]) == ("ladder", ["1"], ["2"])
    assert row["collisions"] == (1, 1) and row["shared_time"] == (10.0, 10.5)
    text = ablation.markdown(rows, ["circle"])
    assert text.splitlines()[2] == "| ladder | 1 / 1, +0.50 s | 1 / 1 | +0 |"
