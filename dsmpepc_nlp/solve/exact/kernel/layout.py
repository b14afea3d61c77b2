"""The kernel's layout: the named positions of the parameter vector (:data:`.cycle.PARAMETERS`,
frozen by numba as constants), the output columns, and the compiler settings."""

from __future__ import annotations

import dataclasses
import functools
from collections import namedtuple

import numba

from ....core.cost_config import CostConfig
from ....core.terms import TERM_NAMES, TERMS
from ..cycle import PARAMETERS

OUT = ("total", *TERM_NAMES, "min_distance", "inv_ttg", "inv_ttc_terminal", "fragile")
"""Columns of the kernel's per-trajectory output: the total, each term of the term table
(``TERM_NAMES``, in its order), then what the evaluation reports beside the cost."""
N_TERMS = len(TERM_NAMES)
STEPWISE = tuple(term.over == "steps" for term in TERMS)
"""For each term of the table: summed over the steps (True) or counted at the end (False)."""
TOTAL_COLUMN = OUT.index("total")
MIN_DISTANCE_COLUMN = OUT.index("min_distance")
INV_TTG_COLUMN = OUT.index("inv_ttg")
INV_TTC_TERMINAL_COLUMN = OUT.index("inv_ttc_terminal")
FRAGILE_COLUMN = OUT.index("fragile")

FRAGILE_RHO = 1e-6
"""Target distance (m) below which the line of sight, and so the turn, rests on rounding."""
FRAGILE_ANGLE = 1e-6
"""Distance (rad) of theta or delta to +-pi within which wrapping may jump by 2 pi on rounding.

Near these two points the law is discontinuous: two correct evaluations that differ in the last
bit may turn opposite ways. A rollout that passes near them is marked fragile, and the caller
rolls that z out with the numpy reference instead (then costs it here)."""

# Indices into the parameter vector (numba freezes module-level ints as constants).
X0 = PARAMETERS.index('x0')
Y0 = PARAMETERS.index('y0')
PHI0 = PARAMETERS.index('phi0')
V0 = PARAMETERS.index('v0')
OMEGA0 = PARAMETERS.index('omega0')
K1 = PARAMETERS.index('k1')
K2 = PARAMETERS.index('k2')
BETA = PARAMETERS.index('beta')
LAM = PARAMETERS.index('lam')
R_THRESH = PARAMETERS.index('r_thresh')
OMEGA_LIMIT = PARAMETERS.index('omega_limit')
ACCEL_LIMIT = PARAMETERS.index('accel_limit')
ALPHA_LIMIT = PARAMETERS.index('alpha_limit')
V_LIMIT = PARAMETERS.index('v_limit')
DT = PARAMETERS.index('dt')
RHO_GUARD2 = PARAMETERS.index('rho_guard2')
HAS_GRID = PARAMETERS.index('has_grid')
SDF_RES = PARAMETERS.index('sdf_res')
SDF_OX = PARAMETERS.index('sdf_ox')
SDF_OY = PARAMETERS.index('sdf_oy')
TTC_RANGE = PARAMETERS.index('ttc_range')
SIGMA_STATIC = PARAMETERS.index('sigma_static')
SIGMA_DYNAMIC = PARAMETERS.index('sigma_dynamic')
A = PARAMETERS.index('a')
S_TTC = PARAMETERS.index('s_ttc')
ANTICIPATORY = PARAMETERS.index('anticipatory')
TERMINAL = PARAMETERS.index('terminal')
NF_GRID = PARAMETERS.index('nf_grid')
NF_RES = PARAMETERS.index('nf_res')
NF_OX = PARAMETERS.index('nf_ox')
NF_OY = PARAMETERS.index('nf_oy')
GOAL_X = PARAMETERS.index('goal_x')
GOAL_Y = PARAMETERS.index('goal_y')
GOAL_TOL2 = PARAMETERS.index('goal_tol2')
CULL_FLOOR = PARAMETERS.index('cull_floor')
W_FIRST_TERM = PARAMETERS.index(f"w_{TERM_NAMES[0]}")  # the weights follow in TERM_NAMES order
ON_FIRST_TERM = PARAMETERS.index(f"on_{TERM_NAMES[0]}")  # and so do the switches
NEAR_STATIC = PARAMETERS.index('near_static')
GOAL_TOL = PARAMETERS.index('goal_tol')
CULL_SIGMAS = PARAMETERS.index('cull_sigmas')
SIGMA_DYNAMIC_GROWTH = PARAMETERS.index('sigma_dynamic_growth')

COST_FIELDS = tuple(field.name for field in dataclasses.fields(CostConfig)
                    if field.type == "float")
CostNumbers = namedtuple("CostNumbers", COST_FIELDS)
"""The cost's numbers as the term formulas read them (``c.c_v``, ...) in the kernel: every
float field of :class:`~dsmpepc_nlp.core.cost_config.CostConfig`."""


@functools.lru_cache(maxsize=64)
def cost_numbers(cost: CostConfig) -> CostNumbers:
    """:data:`CostNumbers` of a configuration's cost (once per configuration)."""
    return CostNumbers(*(float(getattr(cost, name)) for name in COST_FIELDS))


jit = numba.njit(cache=False, fastmath=False, error_model="numpy")
