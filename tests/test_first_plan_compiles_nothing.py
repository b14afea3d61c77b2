"""After ``Planner.prepare()`` nothing is left for a plan to compile, whatever path the package
was installed at: numba's cache index is valid only for the source path and stamp it was
written for, so a cache folder filled from another checkout must not pass for this one's."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "dsmpepc_nlp"

SCRIPT = r"""
import json, time
import numpy as np
from dsmpepc_nlp import DynamicObstacle, OccupancyGrid, Planner, RobotState, SolverConfig, World
from dsmpepc_nlp.solve.exact import loader as exact
import dsmpepc_nlp

planner = Planner(solver=SolverConfig.sampling())
started = time.perf_counter()
planner.prepare()
prepared = time.perf_counter() - started
module = exact.kernel()
dispatchers = [module.exact_costs, module.exact_costs_serial]

def compiled():
    return [sum(d.stats.cache_misses.values()) for d in dispatchers]

before = compiled()
occupied = np.zeros((60, 60), bool)
occupied[20:40, 35:38] = True
world = World(OccupancyGrid(occupied, 0.1, (-3.0, -3.0)),
              [DynamicObstacle.pedestrian((2.0, 0.5), (-0.5, 0.0))])
started = time.perf_counter()
plan = planner.plan(RobotState(0.0, 0.0, 0.0), world, (4.0, 0.0))
first = time.perf_counter() - started
print(json.dumps({"package": dsmpepc_nlp.__file__, "before": before, "after": compiled(),
                  "status": plan.status, "first_plan_s": first, "prepare_s": prepared,
                  "folder": str(exact.kernel_cache_dir())}))
"""


def _run(where: Path, cache: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(where), "DSMPEPC_CACHE_DIR": str(cache)}
    env.pop("DSMPEPC_NO_COMPILE", None)
    done = subprocess.run([sys.executable, "-c", SCRIPT], cwd=where, env=env,
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(os.environ.get("DSMPEPC_NO_COMPILE") == "1", reason="compilation off")
def test_a_copy_at_a_new_path_compiles_in_prepare_not_in_the_first_plan(tmp_path):
    pytest.importorskip("numba")
    cache = tmp_path / "cache"
    first, second = tmp_path / "one", tmp_path / "two"
    for where in (first, second):
        shutil.copytree(PACKAGE, where / "dsmpepc_nlp",
                        ignore=shutil.ignore_patterns("__pycache__"))
    one = _run(first, cache)
    two = _run(second, cache)            # the same cache, filled from the first copy
    for run, where in ((one, first), (two, second)):
        assert run["package"].startswith(str(where)), run
        assert run["before"] == [0, 0], f"the planner's process compiled: {run}"
        assert run["after"] == run["before"], f"the first plan compiled: {run}"
    assert one["folder"] != two["folder"]
