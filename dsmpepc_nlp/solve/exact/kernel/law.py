"""The control law and its rollout, compiled (``control_law.law_command`` and ``rollout``
with the exact smoothing, operation for operation)."""

from __future__ import annotations

import math

from .layout import (
    ACCEL_LIMIT,
    ALPHA_LIMIT,
    BETA,
    DT,
    FRAGILE_ANGLE,
    FRAGILE_RHO,
    K1,
    K2,
    LAM,
    OMEGA0,
    OMEGA_LIMIT,
    PHI0,
    R_THRESH,
    RHO_GUARD2,
    V0,
    X0,
    Y0,
    jit,
)

_SINC_SERIES = 1e-4
_KAPPA_FLOOR = 1e-12

_TWO_PI = 2.0 * math.pi


@jit
def wrap(angle):
    """``control_law.wrap`` (to (-pi, pi]) by arithmetic: the same angle to an ulp or two,
    without the reference's three transcendental calls."""
    if -math.pi < angle <= math.pi:
        return angle
    wrapped = angle - _TWO_PI * math.floor((angle + math.pi) / _TWO_PI)
    return wrapped + _TWO_PI if wrapped <= -math.pi else wrapped


@jit
def rate_limit(value, previous, limit, dt):
    if limit == math.inf:
        return value
    low, high = previous - limit * dt, previous + limit * dt
    return min(max(value, low), high)


@jit
def law(x, y, phi, tx, ty, tphi, v_max, p):
    """``control_law.law_command`` with the exact smoothing."""
    dx, dy = tx - x, ty - y
    rho = math.sqrt(dx * dx + dy * dy + p[RHO_GUARD2])
    los = math.atan2(dy, dx)
    th = wrap(tphi - los)
    de = wrap(phi - los)
    k1th = p[K1] * th
    kappa = -(p[K2] * (de - math.atan(-k1th)) + (1.0 + p[K1] / (1.0 + k1th * k1th))
              * math.sin(de)) / rho
    abs_kappa = abs(kappa)
    slowdown = kappa * kappa if p[LAM] == 2.0 else abs_kappa ** p[LAM]
    v = min(v_max / (1.0 + p[BETA] * slowdown), v_max * rho / p[R_THRESH])
    v_cap = p[OMEGA_LIMIT] / max(abs_kappa, _KAPPA_FLOOR)
    v = min(v, v_cap)
    fragile = rho < FRAGILE_RHO or abs(th) > math.pi - FRAGILE_ANGLE or \
        abs(de) > math.pi - FRAGILE_ANGLE
    return v, kappa * v, fragile


@jit
def rollout(z, p, n_steps, poses, vs, omegas, target):
    """``control_law.rollout`` of one z into the given rows; True when it is fragile."""
    x, y, phi, v_prev, w_prev = p[X0], p[Y0], p[PHI0], p[V0], p[OMEGA0]
    dt = p[DT]
    los = phi - z[2]
    tx, ty, tphi = x + z[0] * math.cos(los), y + z[0] * math.sin(los), los + z[1]
    target[0], target[1], target[2] = tx, ty, tphi
    poses[0, 0], poses[0, 1], poses[0, 2] = x, y, phi
    fragile = False
    for j in range(n_steps):
        v, w, at_jump = law(x, y, phi, tx, ty, tphi, z[3], p)
        fragile = fragile or at_jump
        v = rate_limit(v, v_prev, p[ACCEL_LIMIT], dt)
        w = rate_limit(w, w_prev, p[ALPHA_LIMIT], dt)
        half = w * dt / 2.0
        if abs(half) < _SINC_SERIES:
            sinc = 1.0 - half * half / 6.0
        else:
            sinc = math.sin(half) / half
        chord = v * dt * sinc
        heading = phi + half
        x, y, phi = x + chord * math.cos(heading), y + chord * math.sin(heading), phi + w * dt
        v_prev, w_prev = v, w
        vs[j], omegas[j] = v, w
        poses[j + 1, 0], poses[j + 1, 1], poses[j + 1, 2] = x, y, phi
    return fragile
