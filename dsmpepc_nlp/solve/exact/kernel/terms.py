"""The term table compiled: each term's formula (:data:`~dsmpepc_nlp.core.terms.TERMS`, the
text the numpy reference and the graph run) compiled by numba for one pose's floats, and two
functions that run them in the table's order: :data:`STEP_TERMS` at every step, :data:`END_TERMS`
once at the horizon's end. Nothing here is typed per term."""

from __future__ import annotations

import math

from numba.extending import overload

from ....core import terms as table
from .layout import jit


@overload(table.exp)
def _exp(x):
    """``terms.exp`` in compiled code: ``math.exp`` of a float."""
    return lambda x: math.exp(x)


def chain(formulas: tuple):
    """A compiled ``run(q, c, out, col)`` that writes ``formula(q, c)`` into ``out[slot, col]``
    for each ``(slot, formula)`` of ``formulas``, in order (a chain of calls: numba inlines
    each formula; a loop over a tuple of functions would call them through pointers)."""
    if not formulas:
        @jit
        def done(q, c, out, col):
            return None
        return done
    (slot, formula), rest = formulas[0], chain(formulas[1:])
    head = jit(formula)

    @jit
    def link(q, c, out, col):
        out[slot, col] = head(q, c)
        rest(q, c, out, col)
    return link


STEP_TERMS = chain(tuple((t, term.raw) for t, term in enumerate(table.TERMS)
                         if term.over == "steps"))
"""``STEP_TERMS(StepQuantities, CostNumbers, scratch, k - 1)``: every step term at step k,
into its row ``t`` (its place in the table) of ``scratch``."""
END_TERMS = chain(tuple((t, term.raw) for t, term in enumerate(table.TERMS)
                        if term.over == "end"))
"""``END_TERMS(EndQuantities, CostNumbers, scratch, 0)``: every end term, into ``scratch[t, 0]``."""
