"""Adding a cost term is one definition: a throwaway term appended to the term table of a copy
of the package reaches the exact cost (numpy), the compiled kernel and the NLP's graph, with no
other line changed."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import dsmpepc_nlp

FORMULA = '''def _speed(q, c):
    """A throwaway term for a test: the square of the speed over each step, times dt."""
    return q.v * q.v * q.dt


'''
ENTRY = '''    Term("speed", "w_action", "steps", _speed),
'''

CHECK = r'''
import json, sys
import numpy as np
from dsmpepc_nlp import PlannerConfig, RobotState, World, DynamicObstacle
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.cost_config import SmoothingConfig
from dsmpepc_nlp.core.exact_cost import evaluate
from dsmpepc_nlp.core.terms import TERM_NAMES
from dsmpepc_nlp.solve import problem as g
from dsmpepc_nlp.solve.exact import loader as exact
from dsmpepc_nlp.solve.exact.cycle import Cycle
from dsmpepc_nlp.solve.exact.evaluator import evaluate_batch

config = PlannerConfig()
state = RobotState(0.0, 0.0, 0.0, v=0.3)
world = World(obstacles=[DynamicObstacle.pedestrian((2.0, 0.4), (-0.4, 0.0))])
goal = (4.0, 0.0)
z = np.array([[1.0, 0.2, -0.1, 0.6], [2.5, -0.4, 0.3, 1.0], [0.8, 1.0, 0.5, 0.3]])
trajectory = rollout(z, state, config)
reference = evaluate(trajectory, world, goal, config)
by_hand = config.cost.w_action * np.sum(trajectory.v ** 2 * config.horizon.dt, axis=1)
cycle = Cycle.prepare(state, world, goal, config)
kernel = evaluate_batch(z, cycle, compiled=True)
sizes = g.GraphSizes()
params = g.pack_parameters(cycle, sizes)
f = g.build_cost_function(config, sizes, SmoothingConfig.exact()).map(len(z))
out = f(z.T, *(params[n] for n in g.PARAMETER_NAMES))
graph = {name: np.array(o).ravel() for name, o in zip(["cost", *TERM_NAMES], out)}
json.dump({
    "names": list(TERM_NAMES),
    "kernel_compiled": exact.kernel() is not None,
    "by_hand": by_hand.ravel().tolist(),
    "reference": np.ravel(reference.terms["speed"]).tolist(),
    "reference_total": np.ravel(reference.total).tolist(),
    "reference_sum": np.ravel(sum(reference.terms[n] for n in TERM_NAMES)).tolist(),
    "kernel": np.ravel(kernel.costs.terms["speed"]).tolist(),
    "kernel_total": np.ravel(kernel.costs.total).tolist(),
    "graph": graph["speed"].tolist(),
    "graph_action": graph["action"].tolist(),
    "reference_action": np.ravel(reference.terms["action"]).tolist(),
}, sys.stdout)
'''


def test_a_term_added_to_the_table_reaches_the_exact_cost_the_kernel_and_the_graph(tmp_path):
    package = Path(dsmpepc_nlp.__file__).parent
    copy = tmp_path / "src" / "dsmpepc_nlp"
    shutil.copytree(package, copy, ignore=shutil.ignore_patterns("__pycache__"))
    table = copy / "core" / "terms.py"
    text = table.read_text()
    last = '    Term("terminal", "w_terminal", "end", _terminal),\n'
    assert text.count("TERMS = (\n") == 1 and text.count(last) == 1
    # The one definition: the formula and its entry at the end of the table.
    table.write_text(text.replace("TERMS = (\n", FORMULA + "TERMS = (\n")
                     .replace(last, last + ENTRY))
    env = dict(os.environ, PYTHONPATH=str(tmp_path / "src"),
               DSMPEPC_CACHE_DIR=str(tmp_path / "cache"))
    env.pop("DSMPEPC_NO_COMPILE", None)
    done = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True,
                          env=env, cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    got = json.loads(done.stdout)
    assert got["names"][-1] == "speed"
    # The numpy reference: the term's formula, weighted, and in the total.
    assert got["reference"] == pytest.approx(got["by_hand"], rel=1e-12)
    assert min(got["reference"]) > 0.0
    assert got["reference_total"] == pytest.approx(got["reference_sum"], rel=1e-12)
    # The graph: the same term beside the others.
    assert got["graph"] == pytest.approx(got["reference"], abs=1e-9)
    assert got["graph_action"] == pytest.approx(got["reference_action"], abs=1e-9)
    # The compiled kernel (where numba is there): a new output column, in the total.
    if got["kernel_compiled"]:
        assert got["kernel"] == pytest.approx(got["reference"], abs=1e-9)
        assert got["kernel_total"] == pytest.approx(got["reference_total"], abs=1e-9)
