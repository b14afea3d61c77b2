"""The compiled exact evaluator: when it runs, where its compiled code is cached, what it reads.

The kernel (:mod:`._exact_kernel`, numba, both cores) rolls out and costs a batch of z from the
flat arrays of a :class:`~dsmpepc_nlp.solve.cycle.Cycle` and returns the same
:class:`~dsmpepc_nlp.core.costs.CostBreakdown` as the numpy reference
(:func:`~dsmpepc_nlp.core.costs.evaluate`). The reference stays the definition: the kernel is a
transcription of it held to it by a property test (1e-9 on every output; see the kernel's
docstring), and with numba missing or ``DSMPEPC_NO_COMPILE=1`` everything runs the reference,
after one warning line.

Compiled code is cached on disk in ``cache_dir("numba") / <hash of the kernel's source>``, so
an edit of the kernel (or another package version) never loads stale code and a second process
loads the kernel instead of compiling it. The configuration is data to the kernel (a parameter
vector), so one compiled kernel serves every configuration.
"""

from __future__ import annotations

import hashlib
import importlib
import math
from pathlib import Path

import numpy as np

from ..core.config import PlannerConfig
from ..core.control_law import _RHO_GUARD, Trajectory, clamp_measured, rollout
from ..core.costs import _SIGNIFICANT_BELL, GOAL_TOLERANCE, CostBreakdown
from .cache import cache_dir, compile_enabled, warn_once

PARAMETERS = (
    "x0", "y0", "phi0", "v0", "omega0", "k1", "k2", "beta", "lam", "r_thresh",
    "omega_limit", "accel_limit", "alpha_limit", "v_limit", "dt", "rho_guard2",
    "has_grid", "sdf_res", "sdf_ox", "sdf_oy", "ttc_range", "sigma_static",
    "sigma_dynamic", "a", "s_ttc", "s_ttg", "c_v", "c_w", "anticipatory", "terminal",
    "nf_grid", "nf_res", "nf_ox", "nf_oy", "goal_x", "goal_y", "goal_tol2",
    "w_progress", "w_action", "w_collision", "w_heading", "w_terminal",
    "on_progress", "on_action", "on_collision", "on_heading", "on_terminal",
    "cull_floor", "near_static", "goal_tol", "cull_sigmas")
"""Names of the kernel's scalar parameters, in the order of its parameter vector."""

_KERNEL_FILE = Path(__file__).with_name("_exact_kernel.py")
_STATE = {"kernel": None, "failed": False}


def parameter_vector(state, goal, config: PlannerConfig, grid, navigation,
                     cull_floor: float, cull_sigmas: float) -> np.ndarray:
    """The kernel's scalar parameters for one cycle (see :data:`PARAMETERS`)."""
    law, robot, cost = config.control_law, config.robot, config.cost
    v0, omega0 = clamp_measured(state, config)
    terms = config.cost_terms()
    nf_grid = navigation.working_grid
    values = {
        "x0": state.x, "y0": state.y, "phi0": state.phi, "v0": v0, "omega0": omega0,
        "k1": law.k1, "k2": law.k2, "beta": law.beta, "lam": law.lam, "r_thresh": law.r_thresh,
        "omega_limit": robot.omega_limit, "accel_limit": robot.accel_limit,
        "alpha_limit": robot.alpha_limit, "v_limit": robot.v_limit, "dt": config.horizon.dt,
        "rho_guard2": _RHO_GUARD ** 2, "has_grid": grid is not None,
        "sdf_res": grid.resolution if grid is not None else 1.0,
        "sdf_ox": grid.origin[0] if grid is not None else 0.0,
        "sdf_oy": grid.origin[1] if grid is not None else 0.0,
        "ttc_range": cost.ttc_range, "sigma_static": cost.sigma_static,
        "sigma_dynamic": cost.sigma_dynamic, "a": cost.a, "s_ttc": cost.s_ttc,
        "s_ttg": cost.s_ttg, "c_v": cost.c_v, "c_w": cost.c_w,
        "anticipatory": config.anticipatory_pc, "terminal": config.terminal_cost,
        "nf_grid": navigation.values is not None,
        "nf_res": nf_grid.resolution if nf_grid is not None else 1.0,
        "nf_ox": nf_grid.origin[0] if nf_grid is not None else 0.0,
        "nf_oy": nf_grid.origin[1] if nf_grid is not None else 0.0,
        "goal_x": navigation.goal[0], "goal_y": navigation.goal[1],
        "goal_tol2": GOAL_TOLERANCE ** 2, "goal_tol": GOAL_TOLERANCE,
        "cull_floor": cull_floor, "cull_sigmas": cull_sigmas,
        "near_static": _SIGNIFICANT_BELL * cost.sigma_static,
    }
    for name, weight, enabled in terms:
        values[f"w_{name}"] = weight
        values[f"on_{name}"] = enabled
    return np.array([float(values[name]) for name in PARAMETERS])


def kernel_source_hash() -> str:
    """Hash of the kernel's source: part of the cache path, so an edit recompiles."""
    return hashlib.sha1(_KERNEL_FILE.read_bytes()).hexdigest()[:16]


def kernel_cache_dir() -> Path:
    """Where the compiled kernel is cached (package version and source hash in the path)."""
    path = cache_dir("numba") / kernel_source_hash()
    path.mkdir(parents=True, exist_ok=True)
    return path


def kernel():
    """The compiled kernel module, or None (numba missing, compilation off or broken).

    The first call imports numba and the kernel with numba's cache pointed at
    :func:`kernel_cache_dir`; without it, one warning line says the numpy path runs.
    """
    if _STATE["kernel"] is not None:
        return _STATE["kernel"]
    if _STATE["failed"] or not compile_enabled():
        warn_once("exact-compile", "dsmpepc_nlp: exact cost on the numpy path (compiled "
                  "evaluator off: DSMPEPC_NO_COMPILE is set or numba is missing); slower")
        return None
    try:
        import numba
    except ImportError:
        _STATE["failed"] = True
        return kernel()
    previous = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(kernel_cache_dir())
    try:  # numba picks the cache folder when the kernel is decorated, i.e. on import
        _STATE["kernel"] = importlib.import_module("._exact_kernel", __package__)
    finally:
        numba.config.CACHE_DIR = previous
    return _STATE["kernel"]


def evaluate_compiled(z: np.ndarray, cycle, module) -> tuple[Trajectory, CostBreakdown]:
    """Roll out and cost ``z`` (n, 4) with the compiled kernel ``module`` from ``cycle``.

    Rollouts the kernel marks fragile (passing a discontinuity of the law, see
    ``_exact_kernel.FRAGILE_ANGLE``) are redone with the numpy reference and costed again, so
    both paths follow the same branch there.
    """
    z = np.array(z, dtype=float, order="C")  # writable and contiguous: one kernel signature
    n, n_steps = z.shape[0], cycle.config.horizon.n_steps
    poses = np.empty((n, n_steps + 1, 3))
    v = np.empty((n, n_steps))
    omega = np.empty((n, n_steps))
    target = np.empty((n, 3))
    survival = np.empty((n, n_steps + 1))
    out = np.empty((n, len(module.OUT)))
    _run(module, cycle, z, poses, v, omega, target, survival, out, False)
    fragile = np.flatnonzero(out[:, module.OUT.index("fragile")])
    if fragile.size:
        again = rollout(z[fragile], cycle.state, cycle.config)
        parts = [np.array(a, order="C") for a in (again.poses, again.v, again.omega)]
        part_survival = np.empty((fragile.size, n_steps + 1))
        part_out = np.empty((fragile.size, out.shape[1]))
        _run(module, cycle, z[fragile], *parts, again.target, part_survival, part_out, True)
        poses[fragile], v[fragile], omega[fragile] = parts
        target[fragile], survival[fragile], out[fragile] = again.target, part_survival, part_out
    columns = dict(zip(module.OUT, out.T))
    with np.errstate(divide="ignore"):
        costs = CostBreakdown(
            columns["total"].copy(),
            {name: columns[name].copy() for name in
             ("progress", "action", "collision", "heading", "terminal")},
            survival, columns["min_distance"].copy(), 1.0 / columns["inv_ttg"],
            1.0 / columns["inv_ttc_terminal"])
    return Trajectory(z, poses, v, omega, target), costs


def _run(module, cycle, z, poses, v, omega, target, survival, out, given):
    k = cycle.kernel_arrays
    module.exact_costs(z, cycle.parameters, k["footprint"], k["sdf"], k["nf"], k["predicted"],
                       k["radii"], k["velocities"], k["starts"], k["culled_predicted"],
                       k["culled_radii"], k["end_centers"], k["end_radii"], k["end_velocities"],
                       poses, v, omega, target, survival, out, given)


def inside_reach(z: np.ndarray, cycle) -> bool:
    """True when no row's v_max exceeds v_limit (the culling of the cycle assumes it)."""
    return bool(np.all(z[:, 3] <= cycle.config.robot.v_limit)) and math.isfinite(
        float(np.sum(z)))
