"""Run a built-in scenario in closed loop, print its metrics, save the episode and a figure.

The same as ``dsmpepc run t-corridor --solver sampling``, as a library user writes it. Shortened
to 6 simulated seconds and 1024 samples so that it runs in a few seconds; drop those two
changes (and pick ``SolverConfig()`` for the NLP) for the real run.
"""

import dataclasses
import os
from pathlib import Path

import matplotlib
import numpy as np

from dsmpepc_nlp.core.config import PlannerConfig
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.sim.metrics import episode_metrics
from dsmpepc_nlp.sim.panels import cost_panels
from dsmpepc_nlp.sim.scenario import load_scenario
from dsmpepc_nlp.sim.simulate import Episode, simulate

matplotlib.use("Agg")
from dsmpepc_nlp.viz import plots  # noqa: E402  (after choosing the backend)

out = Path(os.environ.get("DSMPEPC_EXAMPLE_OUT", "out"))
scenario = dataclasses.replace(load_scenario("t-corridor"), duration=6.0)
config = PlannerConfig.variant("ds-mpepc")              # or "mpepc", "pc-only", "terminal-only"
solver = SolverConfig.sampling(n_samples=1024)          # SolverConfig() is the NLP (IPOPT)

episode = simulate(scenario, config, solver, np.random.default_rng(0), record_samples=[0, 15])
for row in episode_metrics(episode):
    print(f"{row['robot']}: {row['outcome']} after {row['outcome_time']:.1f} s, "
          f"path {row['path_length']:.2f} m, min clearance {row['min_static_clearance']:.2f} m")

path = episode.save(out / "t-corridor.npz")               # NPZ, written atomically
assert Episode.load(path).outcomes == episode.outcomes
print("figure:", plots.episode_figure(episode, path=out / "t-corridor.png"))
state, world, goal = episode.planning_inputs(0)[15]     # the paper's Fig. 2 for one cycle
panels = cost_panels(state, world, goal, config, n_samples=1024)  # sample, then draw
print("panels:", plots.cost_panels(panels, path=out / "t-corridor-panels.png"))
