"""The failure classifier on hand-built episodes whose class is known, and the command on a tiny
benchmark folder made here (no shared data)."""

import json
import math

import numpy as np
import pytest

from dsmpepc_nlp.bench import failures
from dsmpepc_nlp.bench.crowd_rows import APPEARED, OFFSTAGE
from dsmpepc_nlp.bench.failure_report import classify_folder, stuck_config, unsuccessful
from dsmpepc_nlp.bench.failures import classify
from dsmpepc_nlp.bench.results import ResultTable, keep_failure
from dsmpepc_nlp.cli import main
from dsmpepc_nlp.core.config import PlannerConfig
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import OccupancyGrid
from dsmpepc_nlp.sim.episode import Episode, config_to_dict
from dsmpepc_nlp.solve.planner import Planner
from dsmpepc_nlp.viz.failures import _text

DT = 0.2
RADIUS = 0.3


def make_episode(xy, outcome, *, peds=None, goal=(5.0, 0.0), grid=None, ped_radius=0.3):
    """One round robot (r = 0.3) through positions ``xy`` (T, 2); pedestrians ``peds``
    (T, P, 2); the outcome decided at the last state."""
    xy = np.asarray(xy, dtype=float)
    n = len(xy)
    times = np.arange(n) * DT
    step = np.diff(xy, axis=0)
    phi = np.arctan2(step[:, 1], step[:, 0]) if n > 1 else np.zeros(0)
    moving = np.linalg.norm(step, axis=1) > 1e-12
    phi = np.where(moving, phi, 0.0)
    phi = np.append(phi, phi[-1] if phi.size else 0.0)
    speed = np.append(np.linalg.norm(step, axis=1) / DT, 0.0)
    back = np.append(np.sign(np.sum(step * np.stack([np.cos(phi[:-1]), np.sin(phi[:-1])], 1),
                                    axis=1)), 1.0)
    states = np.zeros((1, n, 5))
    states[0, :, :2], states[0, :, 2], states[0, :, 3] = xy, phi, speed * back
    states[0, :-1, 4] = np.diff(np.unwrap(phi)) / DT
    peds = np.zeros((n, 0, 2)) if peds is None else np.asarray(peds, dtype=float)
    ped_v = np.zeros_like(peds)
    ped_v[:-1] = np.diff(peds, axis=0) / DT
    ped_v[-1] = ped_v[-2] if n > 1 else 0.0
    k = n - 1
    meta = {"scenario": "hand", "map_path": None, "dt": DT, "duration": times[-1],
            "variant": "ds-mpepc", "solver": "sampling", "n_samples": 16, "robots": ["a"],
            "footprints": [[[0.0, 0.0, RADIUS]]], "goal_kinds": ["fixed"],
            "goal_tolerances": [0.25], "follow": [None], "parked": [],
            "config": config_to_dict(PlannerConfig())}
    nan = np.full((1, k), np.nan)
    return Episode(
        times=times, states=states, active=np.ones((1, k), bool),
        goals=np.tile(np.asarray(goal, dtype=float), (1, n, 1)), z=np.full((1, k, 4), np.nan),
        cost_total=nan, cost_terms=np.full((1, k, 5), np.nan), survivability=nan, ttg=nan,
        ttc_terminal=nan, status=np.zeros((1, k), int), nit=np.zeros((1, k), int),
        plan_time=np.full((1, k), 0.01), n_starts=np.ones((1, k), int), plan_poses=None,
        ped_positions=peds, ped_velocities=ped_v,
        ped_radii=np.full(peds.shape[1], ped_radius),
        grid_occupied=None if grid is None else grid.occupied,
        grid_resolution=None if grid is None else grid.resolution,
        grid_origin=None if grid is None else np.asarray(grid.origin),
        outcomes=[outcome], outcome_times=[float(times[-1])], meta=meta)


def standing(n, at=(0.0, 0.0)):
    return np.tile(np.asarray(at, dtype=float), (n, 1))


STALL = 61  # 12 s of states: longer than the 10 s stuck window


# -- collisions ----------------------------------------------------------------------------------


def test_driving_into_a_standing_person_is_at_fault():
    xy = np.stack([np.arange(4) * 0.2, np.zeros(4)], 1)            # 1 m/s along +x
    ep = make_episode(xy, "collision", peds=np.tile([[[1.0, 0.0]]], (4, 1, 1)))
    f = classify(ep)
    assert f.name == "at-fault"
    assert f.evidence["collision_kind"] == "at-fault"
    assert f.evidence["touched"] == "pedestrian" and f.evidence["pedestrian"] == 0
    assert f.evidence["robot_speed"] == pytest.approx(1.0)
    assert f.evidence["approach_speed"] > 0.5
    assert f.cycle == 2  # the last cycle planned before the contact state


def test_a_standing_robot_hit_by_a_walker_is_struck_while_stopped():
    ped = np.stack([2.0 - np.arange(8) * 0.2, np.zeros(8)], 1)[:, None, :]
    ep = make_episode(standing(8), "collision", peds=ped)
    f = classify(ep)
    assert f.name == "struck-stopped"
    assert f.evidence["collision_kind"] == "struck"
    assert f.evidence["robot_speed"] == pytest.approx(0.0)
    assert f.evidence["pedestrian_speed"] == pytest.approx(1.0)


def test_a_robot_hit_side_on_while_driving_is_struck_while_moving():
    n = 8
    y = np.arange(n) * 0.1                                          # 0.5 m/s along +y
    xy = np.stack([np.zeros(n), y], 1)
    ped = np.stack([2.0 - np.arange(n) * 0.2, y], 1)[:, None, :]     # closes along x only
    f = classify(make_episode(xy, "collision", peds=ped, goal=(0.0, 5.0)))
    assert f.name == "struck-moving"
    assert f.evidence["robot_speed"] == pytest.approx(0.5)
    assert f.evidence["robot_speed"] > failures.STOPPED_SPEED
    assert abs(f.evidence["approach_speed"]) < 0.01


def test_a_collision_says_when_it_came_and_how_far_the_person_stood_at_the_start():
    """The walker of the struck-stopped case starts 2.0 m off (a gap of 1.4 m) and touches at
    1.4 s; a replay's person parked off stage at the start has no ``start_gap``."""
    ped = np.stack([2.0 - np.arange(8) * 0.2, np.zeros(8)], 1)[:, None, :]
    f = classify(make_episode(standing(8), "collision", peds=ped))
    assert f.evidence["contact_time"] == pytest.approx(1.4)
    assert f.evidence["start_gap"] == pytest.approx(1.4)
    parked = ped.copy()
    parked[0] = OFFSTAGE
    assert "start_gap" not in classify(make_episode(standing(8), "collision",
                                                    peds=parked)).evidence


def test_the_report_counts_the_contacts_of_the_first_second(tmp_path):
    """Two collisions, at 0.6 s (a walker 1.2 m off at the start: a gap of 0.6 m) and at
    1.4 s: one early contact, with that walker's start gap; none in a folder whose only
    collision comes at 1.4 s."""
    table = ResultTable(tmp_path, "barn", ("world",), {"benchmark": "barn"})
    for world, start in ((0, 1.2), (1, 2.0)):
        ped = np.stack([start - np.arange(8) * 0.2, np.zeros(8)], 1)[:, None, :]
        n = int(round((start - 0.6) / 0.2)) + 1          # up to the contact state
        episode = make_episode(standing(n), "collision", peds=ped[:n])
        table.add({"world": world, "outcome": "collision",
                   "episode_file": keep_failure(episode, tmp_path, f"w{world}")})
    report = classify_folder(tmp_path)
    assert report["early_contacts"] == {"within": 1.0, "collisions": 1,
                                        "start_gap": [pytest.approx(0.6), pytest.approx(0.6)]}
    assert main(["failures", str(tmp_path), "--figures", "0"]) == 0
    assert "1 of the collisions came within 1 s of the start, the person touched standing " \
        "0.60-0.60 m" in (tmp_path / "failures.md").read_text()
    assert "early_contacts" not in classify_folder(_folder(tmp_path / "late"))
    evidence = report["failures"][0]["evidence"]
    assert f"start_gap: {evidence['start_gap']:.2f}" in _text(evidence)    # the figure's box


def _appearing(n, on_stage_from):
    """A walker closing on a standing robot along +x at 1 m/s, parked at OFFSTAGE before
    state ``on_stage_from`` (as the ETH/UCY replay keeps a track that has not begun)."""
    ped = np.stack([0.2 * n - np.arange(n) * 0.2 + 0.4, np.zeros(n)], 1)
    ped[:on_stage_from] = OFFSTAGE
    return ped[:, None, :]


def test_struck_by_a_walker_who_appeared_moments_before_is_appeared_in_reach():
    n = 12                              # contact at the last state, t = 2.2 s
    f = classify(make_episode(standing(n), "collision", peds=_appearing(n, n - 4)))
    assert f.name == "appeared-in-reach"
    assert f.evidence["contact_age"] == pytest.approx(0.6)      # on stage for 3 steps
    assert f.evidence["appeared_within"] == APPEARED
    assert f.evidence["collision_kind"] == "struck"            # the benchmark's kind is kept


def test_the_scene_draws_the_person_touched_where_they_were_at_the_contact():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dsmpepc_nlp.viz.failures import draw_scene

    n = 12                              # on stage only at the contact: not at the stuck cycle
    episode = make_episode(standing(n), "collision", peds=_appearing(n, n - 1))
    failure = classify(episode).to_dict()
    fig, ax = plt.subplots()
    try:
        draw_scene(ax, episode, failure, "appeared")
        outlines = [p for p in ax.patches if not p.get_fill()]
        assert len(outlines) == 1 and outlines[0].get_linestyle() == "--"
        assert tuple(outlines[0].center) == pytest.approx(tuple(episode.ped_positions[n - 1, 0]))
    finally:
        plt.close(fig)


def test_the_evidence_sits_beside_the_scene_not_over_it(tmp_path, monkeypatch):
    """The evidence box covered the overview map's top left (people, the start); it now has a
    column of its own, and no text of it overlaps any scene axes."""
    import matplotlib
    matplotlib.use("Agg")

    from dsmpepc_nlp.viz import failures as figures

    n = 12
    episode = make_episode(standing(n), "collision", peds=_appearing(n, n - 4))
    failure = classify(episode).to_dict()
    drawn = {}
    savefig = figures.atomic_savefig

    def keep(fig, path, **kw):
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        drawn["boxes"] = [t.get_window_extent(renderer) for ax in fig.axes for t in ax.texts
                          if "contact_age" in t.get_text()]
        drawn["scenes"] = [ax.get_window_extent(renderer) for ax in fig.axes if ax.axison]
        return savefig(fig, path, **kw)

    monkeypatch.setattr(figures, "atomic_savefig", keep)
    figures.failure_figure("appeared-in-reach", [("run", episode, failure, None)],
                           tmp_path / "f.png", total=1)
    assert len(drawn["boxes"]) == 1
    assert len(drawn["scenes"]) == 2                          # the scene and its close-up
    assert not any(drawn["boxes"][0].overlaps(scene) for scene in drawn["scenes"])


def test_a_walker_seen_for_longer_than_the_threshold_is_not_appeared_in_reach():
    n = 12
    f = classify(make_episode(standing(n), "collision", peds=_appearing(n, n - 8)))
    assert f.evidence["contact_age"] == pytest.approx(1.4)
    assert f.name == "struck-stopped"
    # on stage from the first state: present all along, whatever the contact time
    f = classify(make_episode(standing(4), "collision", peds=_appearing(4, 0)))
    assert f.evidence["contact_age"] == math.inf and f.name == "struck-stopped"


# -- stuck ---------------------------------------------------------------------------------------


def test_a_person_standing_on_the_goal_all_window_is_goal_occupied():
    # the goal 1 m ahead; a person stands 0.1 m from it: 0.1 + 0.25 (tolerance) < 0.3 + 0.3
    ped = np.tile([[[1.1, 0.0]]], (STALL, 1, 1))
    f = classify(make_episode(standing(STALL), "deadlock", peds=ped, goal=(1.0, 0.0)))
    assert f.name == "goal-occupied"
    assert f.evidence["goal_occupied_share"] == 1.0
    assert f.evidence["goal_person"] == 0
    assert f.evidence["goal_person_distance"] == pytest.approx(0.1)


def test_goal_occupied_reads_what_the_footprint_covers_at_any_heading():
    """Two circles 0.2 m either side of the reference point (r 0.25) cover only 0.05 m about
    it at every heading: a person 0.12 m from the goal leaves a point of the 0.25 m tolerance
    where such a robot can stand (0.12 + 0.25 > 0.3 + 0.05), so that is not goal-occupied
    (it was by the smallest circle's 0.25 m); 0.05 m from the goal it is."""
    ped = np.tile([[[1.12, 0.0]]], (STALL, 1, 1))
    episode = make_episode(standing(STALL), "deadlock", peds=ped, goal=(1.0, 0.0))
    episode.meta["footprints"] = [[[0.2, 0.0, 0.25], [-0.2, 0.0, 0.25]]]
    assert classify(episode).evidence["goal_occupied_share"] == 0.0
    episode = make_episode(standing(STALL), "deadlock", peds=ped - [0.07, 0.0], goal=(1.0, 0.0))
    episode.meta["footprints"] = [[[0.2, 0.0, 0.25], [-0.2, 0.0, 0.25]]]
    assert classify(episode).name == "goal-occupied"


def test_a_goal_that_was_free_for_a_moment_is_not_goal_occupied():
    ped = np.tile([[[1.1, 0.0]]], (STALL, 1, 1))
    ped[STALL - 20] = (1.1, 2.0)            # stepped aside for one cycle in the window
    f = classify(make_episode(standing(STALL), "deadlock", peds=ped, goal=(1.0, 0.0)))
    assert 0.9 < f.evidence["goal_occupied_share"] < 1.0
    assert f.name == "stalled-near-goal-person"
    # beside the goal, not on it: a footprint fits within the tolerance (0.5 + 0.25 > 0.6)
    ped = np.tile([[[1.5, 0.0]]], (STALL, 1, 1))
    f = classify(make_episode(standing(STALL), "deadlock", peds=ped, goal=(1.0, 0.0)))
    assert f.evidence["goal_occupied_share"] == 0.0
    assert f.name == "stalled-near-goal-person"


def test_stalled_near_the_goal_beside_a_standing_person():
    ped = np.tile([[[0.0, 1.0]]], (STALL, 1, 1))
    f = classify(make_episode(standing(STALL), "deadlock", peds=ped, goal=(1.0, 0.0)))
    assert f.name == "stalled-near-goal-person"
    assert f.evidence["person"] == 0
    assert f.evidence["person_gap"] == pytest.approx(0.4)
    assert f.evidence["person_speed"] == pytest.approx(0.0)
    assert f.evidence["goal_distance"] == pytest.approx(1.0)
    assert f.evidence["net_displacement"] == pytest.approx(0.0)


def test_stalled_beside_a_standing_person_far_from_the_goal():
    ped = np.tile([[[0.0, 1.0]]], (STALL, 1, 1))
    f = classify(make_episode(standing(STALL), "deadlock", peds=ped, goal=(5.0, 0.0)))
    assert f.name == "stalled-beside-person"
    assert f.evidence["goal_distance"] > f.evidence["docking_radius"]


def test_a_walking_person_is_not_a_standing_one():
    ped = np.stack([np.arange(STALL) * 0.2 - 6.0, np.ones(STALL)], 1)[:, None, :]
    f = classify(make_episode(standing(STALL), "deadlock", peds=ped, goal=(5.0, 0.0)))
    assert f.name == "stalled-open"
    assert "person" not in f.evidence


def _gap_grid(width):
    """Free ground but two walls at |y| > width / 2 for |x| < 0.5: a passage ``width`` wide."""
    h = 0.05
    xs = -2.0 + (np.arange(160) + 0.5) * h
    ys = -2.0 + (np.arange(80) + 0.5) * h
    occupied = (np.abs(ys)[:, None] > width / 2) & (np.abs(xs)[None, :] < 0.5)
    return OccupancyGrid(occupied, h, (-2.0, -2.0))


def test_stalled_in_a_gap_reports_its_width_against_the_robot():
    f = classify(make_episode(standing(STALL), "deadlock", grid=_gap_grid(0.8)))
    assert f.name == "stalled-in-gap"
    assert f.evidence["in_gap"] is True
    assert f.evidence["gap_width"] == pytest.approx(0.8, abs=0.06)
    assert f.evidence["robot_width"] == pytest.approx(2 * RADIUS)
    assert f.evidence["gap_limit"] == pytest.approx(2 * RADIUS + 2 * failures.GAP_MARGIN)


def test_a_wide_passage_is_not_a_gap():
    f = classify(make_episode(standing(STALL), "deadlock", grid=_gap_grid(1.6)))
    assert f.name == "stalled-open"
    assert f.evidence["in_gap"] is False
    assert f.evidence["gap_width"] > f.evidence["gap_limit"]


def test_stalled_near_the_goal_alone():
    f = classify(make_episode(standing(STALL), "timeout", goal=(1.5, 0.0)))
    assert f.name == "stalled-near-goal"
    assert f.outcome == "timeout"


def test_going_back_and_forth_is_oscillating():
    t = np.arange(STALL) * DT
    xy = np.stack([0.3 * np.sin(math.pi * t), np.zeros(STALL)], 1)   # 2 s period
    f = classify(make_episode(xy, "deadlock"))
    assert f.name == "oscillating"
    assert f.evidence["net_displacement"] < f.evidence["stuck_limit"]
    assert f.evidence["path_in_window"] > failures.OSCILLATION_SHARE * f.evidence["stuck_limit"]
    assert f.evidence["reversals"] >= failures.OSCILLATION_REVERSALS


def test_still_making_way_when_the_time_ran_out_is_slow():
    xy = np.stack([np.arange(STALL) * 0.06, np.zeros(STALL)], 1)     # 0.3 m/s
    f = classify(make_episode(xy, "timeout", goal=(20.0, 0.0)))
    assert f.name == "slow"
    assert f.evidence["net_displacement"] == pytest.approx(3.0, abs=1e-6)
    assert f.evidence["stuck_limit"] == pytest.approx(1.0)


def test_circling_into_a_deadlock_is_wandering():
    a = np.arange(STALL) * DT * 0.5                                   # 1 m/s on a 2 m circle
    xy = np.stack([2 * np.cos(a), 2 * np.sin(a)], 1)
    f = classify(make_episode(xy, "deadlock", goal=(10.0, 0.0)))
    assert f.name == "wandering"
    assert f.evidence["net_displacement"] >= f.evidence["stuck_limit"]


def test_successes_and_missing_robots_are_refused():
    ep = make_episode(standing(5), "success")
    with pytest.raises(InputError, match="success"):
        classify(ep)
    with pytest.raises(InputError, match="robot 3"):
        classify(make_episode(standing(5), "deadlock"), robot=3)


def test_every_class_is_named_and_evidence_is_json():
    f = classify(make_episode(standing(STALL), "deadlock", grid=_gap_grid(0.8)))
    assert f.name in failures.CLASSES
    json.dumps(f.to_dict())


# -- keeping episodes and the command -------------------------------------------------------------


def test_only_unsuccessful_episodes_are_kept(tmp_path):
    assert keep_failure(make_episode(standing(5), "success"), tmp_path, "ok") is None
    assert keep_failure(make_episode(standing(5), "deadlock"), None, "no-folder") is None
    name = keep_failure(make_episode(standing(5), "deadlock"), tmp_path, "stuck")
    assert name == "episodes/stuck.npz"
    assert Episode.load(tmp_path / name).outcomes == ["deadlock"]


def test_which_rows_are_unsuccessful():
    assert unsuccessful({"outcome": "deadlock"}) and not unsuccessful({"outcome": "success"})
    assert unsuccessful({"status": "ok", "outcomes": "success,timeout"})
    assert not unsuccessful({"status": "ok", "outcomes": "success,success"})
    assert unsuccessful({"status": "failed"})


def _folder(tmp_path):
    table = ResultTable(tmp_path, "barn", ("world",), {"benchmark": "barn"})
    stuck = make_episode(standing(STALL), "deadlock", grid=_gap_grid(0.8))
    hit = make_episode(standing(8), "collision", peds=np.stack(
        [2.0 - np.arange(8) * 0.2, np.zeros(8)], 1)[:, None, :])
    table.add({"world": 0, "outcome": "success", "episode_file": None})
    table.add({"world": 1, "outcome": "deadlock",
               "episode_file": keep_failure(stuck, tmp_path, "w1")})
    table.add({"world": 2, "outcome": "collision",
               "episode_file": keep_failure(hit, tmp_path, "w2")})
    table.add({"world": 3, "outcome": "error", "message": "ValueError: boom"})
    return tmp_path


def test_the_folder_report_counts_each_class(tmp_path):
    report = classify_folder(_folder(tmp_path))
    assert report["runs"] == 4 and report["unsuccessful_runs"] == 3
    assert report["counts"] == {"struck-stopped": 1, "stalled-in-gap": 1}
    assert report["unclassified"] == 1
    assert report["unclassified_runs"][0]["reason"] == "ValueError: boom"


def test_the_command_writes_report_and_figures(tmp_path, capsys):
    folder = _folder(tmp_path)
    assert main(["failures", str(folder), "--figures", "1"]) == 0
    out = capsys.readouterr().out
    assert "3 of 4 runs did not succeed" in out and "stalled-in-gap 1" in out
    report = json.loads((folder / "failures.json").read_text())
    assert report["counts"] == {"struck-stopped": 1, "stalled-in-gap": 1}
    assert (folder / "failures-stalled-in-gap.png").stat().st_size > 10_000
    assert (folder / "failures-struck-stopped.png").exists()
    assert "| stalled-in-gap | 1 |" in (folder / "failures.md").read_text()


def test_a_replay_row_says_which_goals_no_planner_could_reach(tmp_path, capsys):
    """A crowd table's ``goal_free_at`` (None: covered from the earliest arrival to the end)
    goes into each failure's evidence and the report counts the runs nobody could win."""
    ped = np.tile([[[1.1, 0.0]]], (STALL, 1, 1))
    on_goal = make_episode(standing(STALL), "deadlock", peds=ped, goal=(1.0, 0.0))
    table = ResultTable(tmp_path, "crowd", ("episode",), {"benchmark": "crowd"})
    for episode, free_at in ((0, None), (1, 12.4)):
        table.add({"episode": episode, "outcome": "deadlock", "goal_free_at": free_at,
                   "episode_file": keep_failure(on_goal, tmp_path, f"e{episode}")})
    report = classify_folder(tmp_path)
    assert [f["evidence"]["goal_free_at"] for f in report["failures"]] == [None, 12.4]
    assert report["goal_never_free"] == 1
    assert main(["failures", str(tmp_path), "--figures", "0"]) == 0
    assert "goal never free (no planner could win): 1" in capsys.readouterr().out
    assert "1 of them no planner could win" in (tmp_path / "failures.md").read_text()
    assert "goal_never_free" not in classify_folder(_folder(tmp_path / "barn"))


def test_the_figure_says_when_the_goal_first_freed():
    from dsmpepc_nlp.viz.failures import _text

    assert "goal_free_at: never" in _text({"goal_occupied_share": 1.0, "goal_free_at": None})
    assert "goal_free_at: 28.2 s" in _text({"goal_free_at": 28.2})
    assert "goal_free_at" not in _text({"goal_occupied_share": 1.0})


def test_the_figure_says_whether_a_collision_had_a_way_out():
    from dsmpepc_nlp.viz.failures import _text

    assert _text({"contact_age": 0.0, "escape": "none", "escape_from": 4.6}).splitlines() == [
        "contact_age: 0.00", "escape: none"]
    assert _text({"contact_age": math.inf}) == "contact_age: on stage from the start"
    searched = _text({"escape": "not searched: the pedestrians of this run react to the robot"})
    assert searched == "escape: not searched"          # the reason stays in failures.md


def test_the_command_refuses_a_folder_without_a_table(tmp_path, capsys):
    assert main(["failures", str(tmp_path)]) == 2
    assert "no benchmark table" in capsys.readouterr().err
    assert main(["failures", str(tmp_path / "missing")]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_the_stuck_cycle_is_costed_at_the_ladder_level_the_robot_planned_it_at():
    """The stall monitor reads only the robot's positions and goal, so replaying it over a
    logged episode gives each cycle's ladder level: the level a planner fed the same cycles
    had (one every 2 s standing, up to 3), and the stuck cycle's panels are costed with the
    progress weight it planned with. The report carries the level in the evidence."""
    ped = np.tile([[[0.0, 1.0]]], (STALL, 1, 1))
    episode = make_episode(standing(STALL), "deadlock", peds=ped, goal=(5.0, 0.0))
    planner = Planner(episode.config(), SolverConfig.sampling(n_samples=16))
    for k, (state, world, goal) in enumerate(episode.planning_inputs()):
        config, level = stuck_config(episode, 0, k)
        assert level == planner.plan(state, world, goal).stall_level == min(k // 10, 3)
        gain = config.stall.gain ** level
        assert config.cost.w_progress == pytest.approx(PlannerConfig().cost.w_progress * gain)


def test_the_report_gives_each_failures_ladder_level(tmp_path):
    """12 s standing in a gap: the ladder's top (3) at the stuck cycle; struck after 1.4 s
    standing: level 0. The figure's evidence box prints it."""
    report = classify_folder(_folder(tmp_path))
    levels = {f["class"]: f["evidence"]["stall_level"] for f in report["failures"]}
    assert levels == {"stalled-in-gap": 3, "struck-stopped": 0}
    assert "stall_level: 3" in _text({"stall_level": 3})


def test_cases_keeps_only_the_runs_of_those_episodes(tmp_path, capsys, monkeypatch):
    """``--cases`` classifies only the rows whose episode is given, says so in the report, the
    page and the figures' titles, and refuses a selection that keeps nothing or a table with
    no episode or world to select by."""
    on_goal = make_episode(standing(STALL), "deadlock", peds=np.tile([[[1.1, 0.0]]],
                           (STALL, 1, 1)), goal=(1.0, 0.0))
    table = ResultTable(tmp_path, "crowd", ("episode",), {"benchmark": "crowd"})
    for episode in (0, 1, 2, 5):
        table.add({"episode": episode, "outcome": "deadlock",
                   "episode_file": keep_failure(on_goal, tmp_path, f"e{episode}")})
    report = classify_folder(tmp_path, cases={1, 2, 3})
    assert report["runs"] == 2 and report["cases"] == "1-3"
    assert [f["label"] for f in report["failures"]] == ["crowd episode=1", "crowd episode=2"]
    assert classify_folder(tmp_path)["runs"] == 4
    from dsmpepc_nlp.viz import failures as figures

    titles, savefig = [], figures.atomic_savefig

    def keep(fig, path, **kw):
        titles.append(fig.get_suptitle())
        return savefig(fig, path, **kw)

    monkeypatch.setattr(figures, "atomic_savefig", keep)
    assert main(["failures", str(tmp_path), "--cases", "5", "--figures", "1",
                 "--no-panels"]) == 0
    assert titles and all(t.endswith("(1 of 1 runs shown, of cases 5)") for t in titles)
    assert "1 of 1 runs (cases 5) did not succeed" in capsys.readouterr().out
    assert "(cases 5 only)" in (tmp_path / "failures.md").read_text()
    assert main(["failures", str(tmp_path), "--cases", "7-9"]) == 2
    assert "no run of" in capsys.readouterr().err
    assert main(["failures", str(tmp_path), "--cases", "9-7"]) == 2
    assert "--cases = '9-7'" in capsys.readouterr().err
    scenes = ResultTable(tmp_path / "scen", "scenarios", ("scenario",), {})
    scenes.add({"scenario": "hall", "outcome": "deadlock"})
    with pytest.raises(InputError, match="numbers its runs by none of world, episode"):
        classify_folder(tmp_path / "scen", cases={0})
