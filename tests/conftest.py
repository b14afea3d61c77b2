"""Shared test set-up: a non-interactive matplotlib backend and hypothesis profiles."""

import os

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

settings.register_profile(
    "default", deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "slow", deadline=None, max_examples=10_000, suppress_health_check=[HealthCheck.too_slow]
)
# HYPOTHESIS_PROFILE=slow runs the fuzzing suites with 10,000 examples each.
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))
# Plans compile the NLP's library in the plan when it is missing (not in the background with
# the sampler answering meanwhile), so that a test's plans do not depend on what the cache held
# when it started; tests of the background mode set it themselves.
os.environ.setdefault("DSMPEPC_COMPILE", "wait")
# Planners re-raise what a stage raises instead of falling back (Planner's ``strict``), so a
# bug is not hidden by a fallback plan; the tests of the fallbacks ask for strict=False.
os.environ.setdefault("DSMPEPC_STRICT", "1")
# Plans have no deadline (SolverConfig.time_budget's default), so that no test's outcome depends
# on how loaded the machine is; the tests of the deadline give their budgets themselves.
os.environ.setdefault("DSMPEPC_TIME_BUDGET", "none")


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture
def tool():
    """``tool("name")``: the developer tool ``tools/dev/name.py`` of the repository, loaded from
    its file (the tools are scripts, not a package; what users need is a ``dsmpepc`` command)."""
    import importlib.util
    from pathlib import Path

    def load(name):
        path = Path(__file__).resolve().parents[1] / "tools" / "dev" / f"{name}.py"
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module

    return load
