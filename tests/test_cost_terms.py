"""Cost terms as data: each term's weight and switch come from the configuration."""

import dataclasses

import numpy as np
import pytest

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.cost_config import CostConfig
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.exact_cost import evaluate
from dsmpepc_nlp.core.terms import TERM_NAMES
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World


def _scene():
    occupied = np.zeros((60, 100), dtype=bool)
    occupied[:, 90:92] = True
    world = World(OccupancyGrid(occupied, 0.05, (-1.0, -1.5)),
                  [DynamicObstacle.pedestrian((2.0, 1.0), (0.0, -0.3))])
    z = np.array([[2.0, 0.3, -0.2, 0.8], [1.0, -0.5, 0.4, 0.5], [2.5, 0.0, 0.0, 1.0],
                  [1.0, 0.0, 0.0, 0.0]])
    return world, rollout(z, RobotState(0.0, 0.0, 0.1, 0.3, 0.0), PlannerConfig()), (3.0, 0.5)


def test_the_four_variants_are_four_settings_of_one_table():
    for name, on in (("mpepc", False), ("ds-mpepc", True), ("pc-only", False),
                     ("terminal-only", True)):
        table = PlannerConfig.variant(name).cost_terms()
        assert [t[0] for t in table] == list(TERM_NAMES)
        assert dict((n, e) for n, _, e in table)["terminal"] is on


@pytest.mark.parametrize("name", TERM_NAMES)
def test_a_weight_scales_its_term_and_nothing_else(name):
    world, trajectories, goal = _scene()
    base = PlannerConfig()
    field = {"progress": "w_progress", "action": "w_action", "collision": "c_collision",
             "heading": "c_heading", "terminal": "w_terminal"}[name]
    cost = dataclasses.replace(base.cost, **{field: 3.0 * getattr(base.cost, field)})
    scaled = dataclasses.replace(base, cost=cost)
    a, b = evaluate(trajectories, world, goal, base), evaluate(trajectories, world, goal, scaled)
    for other in TERM_NAMES:
        factor = 3.0 if other == name else 1.0
        np.testing.assert_allclose(b.terms[other], factor * a.terms[other], rtol=1e-12,
                                   atol=1e-15)
    np.testing.assert_allclose(b.total, sum(b.terms.values()), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("name", TERM_NAMES)
def test_a_disabled_term_is_zero_and_leaves_the_total(name):
    world, trajectories, goal = _scene()
    base = PlannerConfig()
    off = dataclasses.replace(base, cost=dataclasses.replace(base.cost, disabled=(name,)))
    a, b = evaluate(trajectories, world, goal, base), evaluate(trajectories, world, goal, off)
    assert np.all(b.terms[name] == 0.0)
    np.testing.assert_allclose(b.total, a.total - a.terms[name], rtol=1e-12, atol=1e-14)
    assert np.any(a.terms[name] != 0.0), "the scene must exercise every term"


def test_unknown_term_names_are_refused():
    with pytest.raises(InputError, match="CostConfig.disabled"):
        CostConfig(disabled=("progres",))
    with pytest.raises(InputError, match="CostConfig.w_progress"):
        CostConfig(w_progress=-1.0)


def test_a_term_counted_neither_per_step_nor_at_the_end_is_refused():
    from dsmpepc_nlp.core.terms import Term

    with pytest.raises(ValueError, match="over = 'sideways'"):
        Term("speed", "w_action", "sideways", lambda q, c: q.v)
