"""What one start of the NLP's multi-start search did: the record the solver and planner share.

It lives below both (``nlp`` writes records, ``planner`` reads them) so that neither imports
the other for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StartRecord:
    """One start of the multi-start search.

    ``z0`` the start, ``z`` where the solver ended (clipped to the box), ``status`` the solver's
    return status, ``nit`` iterations, ``time_s`` wall time, ``smooth_cost`` the NLP objective
    at ``z`` and ``exact_cost`` the exact cost of ``z`` (the verdict).
    """

    name: str
    z0: np.ndarray
    z: np.ndarray
    status: str
    success: bool
    nit: int
    time_s: float
    smooth_cost: float = math.nan
    exact_cost: float = math.nan


__all__ = ["StartRecord"]
