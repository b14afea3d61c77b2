"""The cost's term table: each term of the MPEPC / DS-MPEPC cost as one definition.

A term is a name, the :class:`~dsmpepc_nlp.core.cost_config.CostConfig` field that weighs it,
where it is counted (on every step after the start, summed, or once at the horizon's end) and
its unweighted formula ``raw(q, c)``: ``q`` the trajectory's quantities there
(:class:`StepQuantities` or :class:`EndQuantities`), ``c`` the cost's numbers (the fields of
``CostConfig``, read by attribute). A formula uses arithmetic and :func:`exp` only, so one text
serves the numpy reference (arrays), the NLP's graph (CasADi symbols) and the compiled kernel
(numba compiles it for floats): ``costs.assemble`` and ``solve/exact/kernel`` loop over
:data:`TERMS`; the weights, switches, breakdown entries and output columns follow the table.
Adding a term is one :class:`Term` here (and a ``CostConfig`` field for its weight, unless it
shares one); docs/method.md section 5.3 says what each one is.
"""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass
from typing import Callable

import numpy as np

StepQuantities = namedtuple("StepQuantities", "survival nf_gain v omega dt")
"""What a step term sees at step k = 1..N: the survivability ``S_k`` of pose k, the
navigation function's change ``NF(p_k) - NF(p_{k-1})``, the speed ``v`` and turn rate
``omega`` over the step (k-1 -> k) and the step length ``dt``."""

EndQuantities = namedtuple("EndQuantities", "final heading_err inv_ttg inv_ttc_terminal")
"""What an end term sees once, at the horizon's last pose: its survivability ``S_N``, the
heading error to the navigation function's descent, the inverse time to goal and the inverse
time to collision at ``v_limit`` along the final heading."""

OVER = ("steps", "end")
"""Where a term is counted: summed over the steps after the start, or once at the end."""


def exp(x):
    """``e ** x`` of a float, a numpy array or a CasADi expression: the one function besides
    arithmetic a term's formula may call (the compiled kernel gives numba ``math.exp``)."""
    return x.exp() if hasattr(x, "exp") else np.exp(x)


@dataclass(frozen=True)
class Term:
    """One term of the cost (docs/method.md section 5.3)."""

    name: str
    """The term's name: its breakdown entry, its weight ``w_<name>`` and switch ``on_<name>``
    in the kernel's parameters, its output of the graph's assembly."""
    weight: str
    """The ``CostConfig`` field that weighs it."""
    over: str
    """``"steps"`` (``raw`` of :class:`StepQuantities`, summed over k = 1..N) or ``"end"``
    (``raw`` of :class:`EndQuantities`)."""
    raw: Callable
    """The unweighted formula ``raw(q, c)``."""

    def __post_init__(self):
        if self.over not in OVER:
            raise ValueError(f"Term {self.name!r}: over = {self.over!r}: must be one of "
                             f"{', '.join(OVER)}")


def _progress(q, c):
    """Progress toward the goal weighted by survivability (MPEPC): ``S_k (NF_k - NF_{k-1})``."""
    return q.survival * q.nf_gain


def _action(q, c):
    """Control effort: ``(c_v v^2 + c_w omega^2) dt``."""
    return (c.c_v * q.v * q.v + c.c_w * q.omega * q.omega) * q.dt


def _collision(q, c):
    """The chance of having collided by pose k: ``1 - S_k``."""
    return 1.0 - q.survival


def _heading(q, c):
    """The terminal heading error, weighted by the horizon's survivability (docs/method.md
    section 8: unweighted, a robot in collision could gain by turning, breaking Lemma 3)."""
    return q.heading_err * q.final


def _terminal(q, c):
    """DS-MPEPC's terminal reward: ``-S_N C_TTG C_TTC`` with the two inverse-time bells."""
    return -q.final * exp(-(q.inv_ttg * q.inv_ttg) / (c.s_ttg * c.s_ttg)) \
        * exp(-(q.inv_ttc_terminal * q.inv_ttc_terminal) / (c.s_ttc * c.s_ttc))


TERMS = (
    Term("progress", "w_progress", "steps", _progress),
    Term("action", "w_action", "steps", _action),
    Term("collision", "c_collision", "steps", _collision),
    Term("heading", "c_heading", "end", _heading),
    Term("terminal", "w_terminal", "end", _terminal),
)
"""The cost's terms, in the order of docs/method.md section 5.3 (and of every breakdown)."""

TERM_NAMES = tuple(term.name for term in TERMS)
"""The terms' names, in :data:`TERMS` order."""
if len(set(TERM_NAMES)) != len(TERM_NAMES):
    raise ValueError(f"the term table names a term twice: {TERM_NAMES}")
