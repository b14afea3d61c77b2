"""The paper's claims on the built-in scenarios (slow: closed-loop runs of whole scenarios).

Identical parameters except the two DS-MPEPC switches (``PlannerConfig.paper``: the paper's
values, none of our extensions). The solver
is ``nlp`` (IPOPT) unless the environment variable ``DSMPEPC_CLAIMS_SOLVER`` names another
(``sampling``, ``fast``). Seed 0 throughout. Each test asserts the paper's claim as stated;
the claim-map tests at the end assert what ``dsmpepc claims`` found instead (sampler only).
"""

import os

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig
from dsmpepc_nlp.core.solver_config import SolverConfig
from dsmpepc_nlp.sim import families
from dsmpepc_nlp.sim.scenario import load_scenario
from dsmpepc_nlp.sim.simulate import simulate

pytestmark = pytest.mark.slow

SOLVER = os.environ.get("DSMPEPC_CLAIMS_SOLVER", "nlp")


def run(name, variant):
    episode = simulate(load_scenario(name), PlannerConfig.paper(variant),
                       SolverConfig.named(SOLVER), np.random.default_rng(0))
    print(f"{name} {variant} {SOLVER}: {episode.outcomes} at {episode.outcome_times}")
    return episode


T_CORRIDOR_SEEN = (
    "does not reproduce: with the sampling solver (4096 samples, seed 0) DS-MPEPC creeps up the "
    "main corridor and stops beside the side corridor's entrance (deadlock at 23.8 s), its "
    "terminal term near -0.55 and progress near 0: the stop-facing-free-space hazard of "
    "docs/method.md section 5.4. MPEPC deadlocks as the paper says."
)


@pytest.mark.parametrize("name", [
    pytest.param("t-corridor", marks=pytest.mark.xfail(reason=T_CORRIDOR_SEEN, strict=False)),
    # With the local-model NLP of earlier versions both robots stayed on the symmetric
    # corridor's centre line and deadlocked; the global graph passes like the sampler.
    "narrow-corridor",
])
def test_mpepc_deadlocks_where_ds_mpepc_succeeds(name):
    """Paper Figs. 4 and 5: MPEPC deadlocks, DS-MPEPC reaches the goal."""
    mpepc, ds = run(name, "mpepc"), run(name, "ds-mpepc")
    assert "deadlock" in mpepc.outcomes, f"MPEPC: {mpepc.outcomes}"
    assert ds.outcomes == ["success"] * ds.n_robots, f"DS-MPEPC: {ds.outcomes}"


@pytest.mark.parametrize("name", ["circle-4", "circle-10"])
def test_ds_mpepc_brings_every_circle_agent_home(name):
    """Paper Figs. 6 and 7: every agent reaches its antipodal goal without collision."""
    ds = run(name, "ds-mpepc")
    assert ds.outcomes == ["success"] * ds.n_robots, ds.outcomes


@pytest.mark.parametrize("name", ["hall", "l-corridor"])
def test_following_a_pedestrian_ends_without_collision(name):
    """Paper Figs. 1-3: the robot follows its pedestrian without a collision."""
    ds = run(name, "ds-mpepc")
    assert "collision" not in ds.outcomes, ds.outcomes


# ---------------------------------------------------------------------------------------------
# The claim map (dsmpepc claims, docs/claims.md "Where the claim holds"): cells of every
# family, asserting what the full map found with the sampler (4096 samples, seed 0), not what
# the paper hoped.
# The map runs the sampler whatever DSMPEPC_CLAIMS_SOLVER says, and so do these.

MAP_FOUND = [
    # family, first axis, second axis, {variant: outcome of every robot}
    ("t-corridor", 1.0, 1.8, {"mpepc": "deadlock", "ds-mpepc": "success"}),
    ("t-corridor", 1.0, 2.6, {"mpepc": "deadlock", "ds-mpepc": "success"}),
    ("t-corridor", 0.85, 1.8, {"mpepc": "deadlock", "ds-mpepc": "deadlock"}),
    # the ablations: the anticipatory collision probability passes, the terminal cost stops
    ("t-corridor", 1.2, 1.8, {"pc-only": "success", "terminal-only": "deadlock"}),
    ("narrow-corridor", 1.4, 12.6, {"mpepc": "deadlock", "ds-mpepc": "success"}),
    ("narrow-corridor", 1.2, 12.6, {"mpepc": "deadlock", "ds-mpepc": "deadlock"}),
    ("doorway", 1.0, 1.5, {"mpepc": "success", "ds-mpepc": "success"}),
    # the one cell where MPEPC wins: DS-MPEPC stops in front of a 0.9 m door (4 seeds of 5)
    ("doorway", 0.9, 1.5, {"mpepc": "success", "ds-mpepc": "deadlock"}),
]


@pytest.mark.parametrize("family, x, y, expected", MAP_FOUND,
                         ids=[f"{f}-{x:g}-{y:g}" for f, x, y, _ in MAP_FOUND])
def test_the_claim_map_cell(family, x, y, expected, tmp_path):
    """The cell's outcome per variant, as the full claim map found it."""
    scenario = load_scenario(families.save(family, x, y, tmp_path))
    for variant, outcome in expected.items():
        episode = simulate(scenario, PlannerConfig.paper(variant), SolverConfig.sampling(),
                           np.random.default_rng(0), record_trajectories=False)
        print(f"{scenario.name} {variant} sampling: {episode.outcomes}")
        assert episode.outcomes == [outcome] * episode.n_robots, (variant, episode.outcomes)
