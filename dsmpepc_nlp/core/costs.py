"""The MPEPC / DS-MPEPC cost terms (docs/method.md sec. 3-5), exact and smooth forms side by side.

Two layers. The *geometry* of a trajectory (distances, inverse times to collision and to goal,
navigation-function values) is measured exactly by :mod:`.exact_cost` from the world (signed
distance field, ray marching, disk closed forms) and smoothly by the NLP graph; the formulas
both share (time to collision with a disk, time to goal, heading error, the bell's width) are
here. The *assembly* of the cost from that geometry (collision probabilities, survivability,
the five terms) is written once here against an ops backend and serves both.

Object axis: object 0 is the static map when the world has one (all static structure is one
object, IROS 2012), then one object per dynamic obstacle. Steps: poses ``k = 0..N``; the speed
at pose ``k`` is the command held from it (``v[min(k, N-1)]``), the start pose included so that
a robot that starts in collision has survivability 0 at every step (Lemma 2).
"""

from __future__ import annotations

import numpy as np

from .config import PlannerConfig
from .control_law import EXACT
from .smooth import NUMPY, is_exact, relu, sabs, sigmoid, smax
from .terms import TERMS, EndQuantities, StepQuantities

# --- shared geometric formulas ----------------------------------------------------------------


def disk_inverse_ttc(px, py, wx, wy, radius, smoothing=EXACT, ops=NUMPY):
    """Inverse time to collision of two disks moving at constant velocity, 1/s.

    ``p`` is the position of one centre relative to the other, ``w`` the relative velocity
    (same order), ``radius`` the sum of the radii. Exactly: the smallest non-negative root t of
    ``|p + w t| = R`` gives ``1/t = (-b + sqrt(b^2 - a c)) / c`` with ``a = |w|^2``,
    ``b = p.w``, ``c = |p|^2 - R^2``; ``inf`` when overlapping (c <= 0), 0 when receding or
    missing. Smooth: the two gates (approaching; closest approach inside R) become sigmoids with
    the distance temperature, in m/s and m.
    """
    a = wx * wx + wy * wy
    b = px * wx + py * wy
    c = px * px + py * py - radius * radius
    disc = b * b - a * c
    num = relu(-b, 0.0, ops) + ops.sqrt(relu(disc, 0.0, ops))
    if is_exact(smoothing.distance):
        hit = ops.where(b < 0, 1.0, 0.0) * ops.where(disc >= 0, 1.0, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = hit * num / ops.fmax(c, 1e-300)
        return ops.where(c <= 0, np.inf, inv)
    tau = smoothing.distance
    # sqrt(max(x, 0)) has an infinite slope at 0 whose product with max's zero slope is NaN
    # in automatic differentiation; a floor of tau^2 * 1e-12 keeps it finite and negligible.
    floor = tau * tau * 1e-12
    num = relu(-b, 0.0, ops) + ops.sqrt(relu(disc, 0.0, ops) + floor * (a + floor))
    dist = ops.sqrt(px * px + py * py + tau * tau)
    approach = -b / dist                                    # closing speed, m/s
    miss = ops.sqrt(relu(px * px + py * py - b * b / (a + tau * tau), 0.0, ops) + floor)  # m
    gate = sigmoid(approach / tau, ops) * sigmoid((radius - miss) / tau, ops)
    return gate * num / smax(c, tau * radius, tau * radius, ops)


GOAL_TOLERANCE = 1e-6
"""Distance to the goal (m) within which a pose counts as on the goal: there the time to goal
is 0 (``1/TTG = inf``, so ``C_TTG = 0`` and the terminal term is 0, the paper's limit for
``TTG -> 0``) and the heading error is 0 (the descent direction is undefined at the goal).
Our definition; the paper gives only the limits."""


def inverse_ttg(poses_terminal, v_terminal, goal, ops=NUMPY, smoothing=EXACT):
    """Inverse expected time to goal at the horizon's end, 1/s (docs/method.md section 4.1).

    Distance to the goal over the component of the terminal velocity along the goal
    direction: ``1/TTG = max(v u.(g - p), 0) / |g - p|^2``; 0 when that component is <= 0.
    Exact: ``inf`` within :data:`GOAL_TOLERANCE` of the goal (TTG = 0 there, as the paper's
    limit TTG -> 0 says; before, the 0/0 gave 1/TTG = 0 and the terminal term jumped to -1 on
    the goal). The ``1e-12`` m^2 in the denominator (both forms) keeps the graph finite on the
    goal. Smooth: the clip acts on the ratio, so its temperature is in 1/s like the result.
    """
    dx, dy = goal[0] - poses_terminal[0], goal[1] - poses_terminal[1]
    along = v_terminal * (ops.cos(poses_terminal[2]) * dx + ops.sin(poses_terminal[2]) * dy)
    squared = dx * dx + dy * dy
    inverse = relu(along / (squared + 1e-12), smoothing.inverse_time, ops)
    if ops is NUMPY and smoothing.inverse_time == 0:
        return np.where(squared <= GOAL_TOLERANCE ** 2, np.inf, inverse)
    return inverse


def heading_error(phi, descent_x, descent_y, ops=NUMPY, smoothing=EXACT):
    """Angle between heading ``phi`` and the NF descent direction, rad, in [0, pi].

    Exact: 0 where the descent direction has no length (on the goal, where it is undefined;
    before, ``atan2(0, -0.0)`` made it pi there). The smooth form is left as it is: its
    ``sabs`` temperature already keeps it finite and the verdict is the exact one.
    """
    cos_phi, sin_phi = ops.cos(phi), ops.sin(phi)
    dot = cos_phi * descent_x + sin_phi * descent_y
    cross = cos_phi * descent_y - sin_phi * descent_x
    angle = ops.atan2(sabs(cross, smoothing.angle, ops), dot)
    if ops is NUMPY:
        return np.where((descent_x == 0) & (descent_y == 0), 0.0, angle)
    return angle


# --- assembly: one formula for the exact and the smooth cost ----------------------------------


def dynamic_sigma(time, cost):
    """Width of a moving object's collision-probability bell at look-ahead ``time`` (s, a
    number, an array or a CasADi symbol): ``sigma_dynamic + sigma_dynamic_growth * time``, m.
    The prediction (constant velocity) grows less certain the further ahead it looks
    (docs/method.md section 3.5); with no growth it is ``sigma_dynamic`` to the bit."""
    return cost.sigma_dynamic + cost.sigma_dynamic_growth * time


def collision_probability(distance, inv_ttc, sigma, config: PlannerConfig, smoothing=EXACT,
                          ops=NUMPY):
    """Collision probability per pose and object.

    MPEPC: ``exp(-d^2 / sigma^2)`` with ``d <= 0`` giving 1. DS-MPEPC multiplies by the
    anticipatory factor ``1 - a exp(-(1/TTC)^2 / s_ttc^2)``.
    """
    d = relu(distance, smoothing.distance, ops)
    pc = ops.exp(-(d * d) / (sigma * sigma))
    if config.anticipatory_pc:
        # The paper (eq. 5) prints exp(+(1/TTC)^2 / s^2). With a = 0.7 and s = 0.5 that factor
        # is negative for every TTC below 3.35 s, so it cannot be meant: Lemmas 1 and 2 need a
        # factor that is 1 at TTC = 0 and 1 - a at TTC = inf, which is this form
        # (docs/method.md section 3.4).
        s = config.cost.s_ttc
        pc = pc * (1.0 - config.cost.a * ops.exp(-(inv_ttc * inv_ttc) / (s * s)))
    return pc


def assemble(distance, inv_ttc, sigma, nf, v, omega, heading_err, inv_ttg, inv_ttc_terminal,
             config: PlannerConfig, smoothing=EXACT, ops=NUMPY, kept=None):
    """The cost and its terms from a trajectory's geometry.

    Shapes for numpy (one trajectory in CasADi drops the leading ``n``): ``distance``,
    ``inv_ttc``: ``(n, N+1, M)``; ``sigma``: ``(N+1, M)`` (numpy) or ``(N+1) x M``; ``nf``:
    ``(n, N+1, 1)``; ``v``, ``omega``: ``(n, N, 1)``; ``heading_err``, ``inv_ttg``,
    ``inv_ttc_terminal``: ``(n, 1, 1)``; ``kept`` (optional, ``(n, N+1, 1)``): further
    objects' product of ``1 - P_c`` per pose (the graph's), multiplied into the survivability.

    Returns ``total`` ``(n, 1, 1)``, ``terms`` (a dict over :data:`TERM_NAMES`) and
    ``survivability`` ``(n, N+1, 1)``.
    """
    pc = collision_probability(distance, inv_ttc, sigma, config, smoothing, ops)
    survival = ops.cumprod_steps(ops.prod_objects(1.0 - pc) * (1.0 if kept is None else kept))
    after_start = ops.steps(survival, 1, None)
    final = ops.steps(survival, -1, None)
    at = {"steps": StepQuantities(after_start, ops.steps(nf, 1, None) - ops.steps(nf, None, -1),
                                  v, omega, config.horizon.dt),
          "end": EndQuantities(final, heading_err, inv_ttg, inv_ttc_terminal)}
    # Each term of the table unweighted, then weighted or switched off (PlannerConfig.cost_terms)
    # and added up in the table's order.
    raw = {term.name: term.raw(at[term.over], config.cost) for term in TERMS}
    terms, total = {}, None
    for term, (name, weight, enabled) in zip(TERMS, config.cost_terms()):
        value = raw[name] if term.over == "end" else ops.sum_steps(raw[name])
        terms[name] = weight * value if enabled else 0.0 * final
        total = terms[name] if total is None else total + terms[name]
    return total, terms, survival


# --- exact geometry from a world --------------------------------------------------------------
