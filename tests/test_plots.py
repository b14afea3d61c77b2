"""Figures and animations are views over episodes: they draw what was logged and close."""

import matplotlib.pyplot as plt
import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.core.world import OccupancyGrid, World
from dsmpepc_nlp.sim.panels import cost_panels
from dsmpepc_nlp.sim.simulate import simulate
from dsmpepc_nlp.sim.types import Agent, FixedGoal, Pedestrian, Scenario
from dsmpepc_nlp.viz import plots


@pytest.fixture(scope="module")
def episode():
    occ = np.zeros((40, 60), bool)
    occ[0, :] = occ[-1, :] = True
    grid = OccupancyGrid(occ, 0.1)
    scenario = Scenario("strip", (Agent("a", RobotState(0.5, 2.0, 0.0), FixedGoal((4.5, 2.0))),),
                        grid=grid, pedestrians=(Pedestrian.constant((5.0, 3.0), (-0.3, 0.0)),),
                        duration=1.6)
    return simulate(scenario, PlannerConfig(), SolverConfig(method="sampling", n_samples=64),
                    np.random.default_rng(0), record_samples=[0, 4], max_samples=20)


def test_episode_figure_draws_map_pedestrians_path_and_samples(episode, tmp_path):
    fig = plots.episode_figure(episode)
    ax = fig.axes[0]
    assert len(ax.images) == 1                                   # the map
    red = [p for p in ax.patches if p.get_facecolor()[:3] == plt.matplotlib.colors.to_rgb(
        "tab:red")]
    assert len(red) == 1                                         # one pedestrian
    # 2 recorded cycles x 20 samples in grey, plus the robot path
    grey = [ln for ln in ax.lines if ln.get_color() == "0.7"]
    assert len(grey) == 40
    assert ax.get_xlabel() == "x [m]" and ax.get_ylabel() == "y [m]"
    assert any("a: timeout" in t.get_text() for t in fig.texts)    # the outcome caption
    labels = ax.get_legend().get_texts()
    names = {t.get_text() for t in labels}
    assert {"robot a (path)", "pedestrian (path)", "pedestrian", "goal (x, robot's colour)",
            "sampled trajectories (recorded cycles)", "each cycle's plan (thin)"} <= names
    path = plots.episode_figure(episode, path=tmp_path / "f" / "ep.png")
    assert path.is_file() and path.stat().st_size > 1000
    assert plt.get_fignums() == [fig.number]                    # the saved one was closed


def test_cost_panels_show_fifty_of_each(episode):
    state, world, goal = episode.planning_inputs(0)[0]
    data = cost_panels(state, world, goal, episode.config(), n_samples=256, n_best=50)
    assert [len(poses) for _, poses in data.panels[1:]] == [50, 50, 50]
    fig = plots.cost_panels(data)
    assert [ax.get_title() for ax in fig.axes] == [
        "Sampled trajectories", "MPEPC cost: lowest", "Time to goal: lowest",
        "Terminal TTC: highest"]
    for ax in fig.axes[1:]:
        assert sum(ln.get_color() == "tab:blue" for ln in ax.lines) == 50


def test_compare_figure_has_one_panel_per_variant(episode, tmp_path):
    path = plots.compare_figure({"mpepc": episode, "ds-mpepc": episode},
                                path=tmp_path / "c.png")
    assert path.is_file()
    fig = plots.compare_figure({"x": episode, "y": episode, "z": episode})
    assert len(fig.axes) == 3 and fig.axes[0].get_title().startswith("x: ")


def test_gif_animation_is_written_atomically(episode, tmp_path):
    path = plots.animate(episode, tmp_path / "a.gif", stride=4)
    assert path.read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]
    assert plt.get_fignums() == []
    with pytest.raises(ValueError, match="gif or .mp4"):
        plots.animate(episode, tmp_path / "a.avi")


def test_crosscheck_histogram_counts_cycles(tmp_path):
    fig = plots.crosscheck_figure([0.0, -0.1, 0.2, np.nan, 0.0])
    assert "4 cycles, 1 where the NLP is worse, 1 non-finite" in fig.axes[0].get_title()


def test_draw_map_without_grid_draws_nothing():
    fig, ax = plt.subplots()
    plots.draw_map(ax, World().grid)
    assert len(ax.images) == 0


def test_the_caption_tells_at_fault_from_struck(monkeypatch):
    from types import SimpleNamespace

    monkeypatch.setattr(plots, "collision_kind", lambda episode, robot: "struck")
    episode = SimpleNamespace(meta={"robots": ["a", "b"]}, outcomes=["collision", "success"],
                              outcome_times=[2.5, 9.0])
    assert plots.outcome_caption(episode) == ("outcome: a: collision (struck) at t = 2.5 s; "
                                              "b: success at t = 9.0 s")


def test_people_parked_off_the_stage_are_left_out_of_lines_and_limits():
    """A replayed recording parks pedestrians at 1e4 m before and after their tracks: the
    figures break their lines there and keep the axes on the scene."""
    from types import SimpleNamespace

    scene = SimpleNamespace(states=np.zeros((1, 3, 5)), goals=np.array([[[4.0, 0.0]] * 3]))
    points = np.array([[1.0, 1.0], [1.0e4, 1.0e4], [12.0, 0.0], [15.0, 0.0]])
    kept = plots.on_stage(scene, points)
    assert np.array_equal(kept[[0, 2]], points[[0, 2]])      # within 10 m of the robot's area
    assert np.all(np.isnan(kept[[1, 3]]))


def test_captions_keep_a_quarter_second():
    """CrowdNav's plans are 0.25 s apart: a caption that rounds to the tenth says 0.8 s for a
    contact at 0.75 s; logged times print to the hundredth, at least one decimal kept."""
    from dsmpepc_nlp.core.errors import seconds

    assert [seconds(t) for t in (0.75, 4.6000000000000005, 9.0, 10.25)] == \
        ["0.75", "4.6", "9.0", "10.25"]


def test_compare_figure_frames_every_panel_alike_and_names_a_robot_once():
    """Runs of one scene drawn side by side share one frame, the union of what each holds (a
    run that went far is not drawn at another scale); a robot named "robot" is not "robot
    robot" in the legend."""
    def run(goal):
        scenario = Scenario("open", (Agent("robot", RobotState(0.0, 0.0, 0.0),
                                           FixedGoal(goal)),), duration=0.6)
        return simulate(scenario, PlannerConfig(), SolverConfig(method="sampling",
                                                                n_samples=32),
                        np.random.default_rng(0))

    near, far = run((2.0, 0.0)), run((0.0, 6.0))
    fig = plots.compare_figure({"near": near, "far": far})
    (a, b) = fig.axes[:2]
    assert a.get_xlim() == b.get_xlim() and a.get_ylim() == b.get_ylim()
    assert a.get_xlim()[1] >= 3.0 and a.get_ylim()[1] >= 7.0          # both goals, 1 m round
    labels = b.get_legend_handles_labels()[1]
    assert "robot (path)" in labels and "robot robot (path)" not in labels
    plt.close(fig)
