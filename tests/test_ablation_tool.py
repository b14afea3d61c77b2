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
    assert ablation.applies("ladder", "scenarios")         # the six scenes run every one
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


def test_the_six_scenes_pair_by_variant_scene_and_seed(tool, tmp_path):
    """A scenes' row is won only when every robot succeeds: without the extension MPEPC's hall
    is lost (success 1 -> 0.5) and nothing won; the shared rows' mean time is compared."""
    import json

    ablation = tool("ablation")
    assert ablation.applies("turn-to-goal", "scenarios") and ablation.applies("ladder",
                                                                              "scenarios")

    def scenes(folder, hall):
        folder.mkdir(parents=True)
        rows = [{"variant": "mpepc", "scenario": "hall", "seed": 0, "success_rate": hall,
                 "collision_rate": 0.0, "time_to_goal": 30.0},
                {"variant": "ds-mpepc", "scenario": "hall", "seed": 0, "success_rate": 1.0,
                 "collision_rate": 0.0, "time_to_goal": 29.0 + hall}]
        (folder / "scenarios.json").write_text(json.dumps({"meta": {}, "rows": rows}))
        (folder / "scenarios.csv").write_text("variant\n")

    scenes(tmp_path / "defaults" / "scenarios", 1.0)
    scenes(tmp_path / "turn-to-goal" / "scenarios", 0.5)
    [row] = ablation.report(tmp_path, {"scenarios": []})
    assert row["lost_off"] == ["mpepc/hall/0"] and row["won_off"] == []
    assert row["shared_time"] == (30.0, 29.5) and row["collisions"] == (0, 0)
    assert ablation.markdown([row], ["scenarios"]).splitlines()[2] == \
        "| turn-to-goal | 1 / 0, -0.50 s | 1 / 0 | +0 |"
