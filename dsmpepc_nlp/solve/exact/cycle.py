"""The per-cycle object: everything a plan's evaluators read that does not depend on z.

Built once per :meth:`~dsmpepc_nlp.solve.planner.Planner.plan` (like Nav2 MPPI's
``CriticData``): the robot state, the goal, the dynamic obstacles and their predicted positions
at every pose time, the static map's distance table and the navigation function. The exact
evaluators (numpy and compiled), the screening of the NLP's starts, the sampler, the verdict,
docking and the NLP's parameters all read this one object; nothing is re-derived inside a plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.config import PlannerConfig, RobotState
from ...core.control_law import _RHO_GUARD, clamp_measured
from ...core.costs import GOAL_TOLERANCE, dynamic_sigma
from ...core.exact_cost import _SIGNIFICANT_BELL
from ...core.navigation import NavigationFunction
from ...core.terms import TERM_NAMES
from ...core.world import World

PARAMETERS = (
    "x0", "y0", "phi0", "v0", "omega0", "k1", "k2", "beta", "lam", "r_thresh",
    "omega_limit", "accel_limit", "alpha_limit", "v_limit", "dt", "rho_guard2",
    "has_grid", "sdf_res", "sdf_ox", "sdf_oy", "ttc_range", "sigma_static",
    "sigma_dynamic", "a", "s_ttc", "anticipatory", "terminal",
    "nf_grid", "nf_res", "nf_ox", "nf_oy", "goal_x", "goal_y", "goal_tol2",
    *(f"w_{name}" for name in TERM_NAMES), *(f"on_{name}" for name in TERM_NAMES),
    "cull_floor", "near_static", "goal_tol", "cull_sigmas", "sigma_dynamic_growth")
"""Names of the kernel's scalar parameters, in the order of its parameter vector: each term of
the term table (``TERM_NAMES``) has its weight ``w_<term>`` and its switch ``on_<term>``. (The
term formulas read the cost's numbers by name, from ``kernel.layout.cost_numbers``.)"""

CULL_SIGMAS = 7.0
"""An object farther than this many bell widths (``costs.dynamic_sigma`` at that pose's time)
from everywhere the robot can reach has ``1 - P_c == 1.0`` exactly in double precision
(``exp(-49)`` is below half an ulp of 1), so leaving it out of the survivability changes no
bit."""
_REACH_SLACK = 1e-6
"""Metres added to the reach for the rounding of the rollout's sums."""


@dataclass(frozen=True, eq=False)
class Cycle:
    """What one planning cycle knows, prepared once.

    Attributes
    ----------
    config : PlannerConfig
    state : RobotState
    goal : ndarray, (2,)
        Goal position, m.
    world : World
        The world the cycle was prepared from (static grid and obstacles now).
    times : ndarray, (N+1,)
        Time of each pose from the plan's start, s.
    centers, radii, velocities, owner : ndarray
        Every dynamic-obstacle circle, flattened: ``(K, 2)`` m, ``(K,)`` m, ``(K, 2)`` m/s,
        ``(K,)`` index of the circle's object (see ``World.stacked_obstacles``).
    predicted : ndarray, (N+1, K, 2)
        Each circle's centre at each pose time (constant velocity), m.
    navigation : NavigationFunction
        Path length to the goal on the inflated map (Euclidean without a map).
    footprint : ndarray, (C, 3)
        The robot's body-frame circles ``(cx, cy, radius)``, m.
    reach_bounds : ndarray, (N+1, K)
        :func:`reach_bound` of every circle at every pose (what culls objects from the cycle,
        and per pose from the NLP's graph).
    in_reach : ndarray of bool, (number of objects,)
        Whether each dynamic object can matter to the collision probability within the
        horizon's reach (see :func:`reach_mask`); the others only enter the smallest distance
        and the terminal time to collision.
    cull : ndarray, (N+1,)
        :func:`cull_distances` at each pose time, m: what culls objects from the cycle and, per
        pose, from the NLP's graph.
    parameters : ndarray
        The compiled kernel's scalar parameters (:data:`PARAMETERS`).
    kernel_arrays : dict of str to ndarray
        What the compiled kernel reads, contiguous: ``footprint``; ``sdf`` (the map's signed
        distance table, read in place) and ``nf`` (the navigation function's table), each with
        its resolution and origin in ``parameters``; the circles of the objects ``in_reach``
        (``predicted`` (N+1, K', 2), ``radii``, ``velocities``, ``starts``: object ``o`` is
        circles ``starts[o]:starts[o+1]``); the others' ``culled_predicted`` and
        ``culled_radii``; every circle at the horizon's end (``end_centers``, ``end_radii``,
        ``end_velocities``).
    """

    config: PlannerConfig
    state: RobotState
    goal: np.ndarray
    world: World
    times: np.ndarray
    centers: np.ndarray
    radii: np.ndarray
    velocities: np.ndarray
    owner: np.ndarray
    predicted: np.ndarray
    navigation: NavigationFunction
    footprint: np.ndarray = None
    reach_bounds: np.ndarray = None
    in_reach: np.ndarray = None
    parameters: np.ndarray = None
    kernel_arrays: dict = None
    cull: np.ndarray = None

    @classmethod
    def prepare(cls, state: RobotState, world, goal, config: PlannerConfig) -> Cycle:
        """Derive the cycle's data from ``world`` once (predictions, navigation function).

        ``config`` is taken as it plans on the world's map (:meth:`PlannerConfig.for_map`):
        ``Cycle.config`` is what every evaluator of the cycle reads."""
        goal = np.asarray(goal, dtype=float)
        config = config.for_map(world.grid.resolution if world.grid is not None else None)
        times = np.arange(config.horizon.n_steps + 1) * config.horizon.dt
        centers, radii, velocities, owner = world.stacked_obstacles()
        predicted = centers[None, :, :] + velocities[None, :, :] * times[:, None, None]
        navigation = world.navigation(goal, config.robot.inflation_radius,
                                      near=(state.x, state.y), reach=config.reach)
        footprint = np.array(config.robot.footprint, dtype=float)
        bounds = reach_bound(state, config, predicted, radii)
        cull = cull_distances(times, config)
        in_reach, floor = reach_mask(bounds, cull, owner, len(world.obstacles))
        keep = in_reach[owner]
        kept = np.flatnonzero(in_reach)
        counts = np.bincount(owner[keep], minlength=len(in_reach))[kept]
        grid = world.grid
        arrays = {
            "footprint": footprint,
            "sdf": _table(grid.signed_distance if grid is not None else None),
            "nf": _table(navigation.values),
            "predicted": predicted[:, keep], "radii": radii[keep],
            "velocities": velocities[keep],
            "starts": np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            "culled_predicted": predicted[:, ~keep], "culled_radii": radii[~keep],
            "end_centers": predicted[-1], "end_radii": radii, "end_velocities": velocities,
        }
        arrays = {name: a if name in ("sdf", "nf") else np.array(a, order="C")
                  for name, a in arrays.items()}
        parameters = parameter_vector(state, goal, config, grid, navigation, floor, CULL_SIGMAS)
        return cls(config, state, goal, world, times, centers, radii, velocities, owner,
                   predicted, navigation, footprint, bounds, in_reach, parameters, arrays, cull)

    @property
    def grid(self):
        """The static OccupancyGrid, or None."""
        return self.world.grid


def reach_bound(state: RobotState, config: PlannerConfig, predicted, radii) -> np.ndarray:
    """A lower bound on the gap between any footprint circle and each circle at each pose,
    whatever z in the box: ``|c_j(k) - p_0| - k dt v_limit - bounding_radius - r_j`` (less a
    rounding slack), ``(N+1, K)`` from ``predicted`` ``(N+1, K, 2)`` and ``radii`` ``(K,)``.

    At step k the robot's origin is within ``k dt v_limit`` of its start (the law never exceeds
    ``v_max <= v_limit``). Where the bound is at least ``CULL_SIGMAS`` times the bell's width
    at that step (:func:`cull_distances`), ``1 - P_c == 1.0`` exactly (see :data:`CULL_SIGMAS`).
    """
    robot = config.robot
    times = np.arange(predicted.shape[0]) * config.horizon.dt
    spread = np.hypot(predicted[..., 0] - state.x, predicted[..., 1] - state.y)
    return (spread - (times * robot.v_limit)[:, None] - robot.bounding_radius
            - np.asarray(radii)[None, :] - _REACH_SLACK)


def cull_distances(times, config: PlannerConfig) -> np.ndarray:
    """``CULL_SIGMAS`` bell widths at each pose time (``times``, s): beyond them a moving
    object's ``1 - P_c`` is 1.0 exactly, m."""
    return CULL_SIGMAS * dynamic_sigma(np.asarray(times, dtype=float), config.cost)


def reach_mask(bounds, cull, owner, n_objects):
    """Which objects can matter to the collision probability within the horizon's reach.

    An object whose :func:`reach_bound` (``bounds``, (N+1, K)) stays at or above its step's
    cull distance (``cull``, (N+1,): :func:`cull_distances`) at every step is left out (see
    :data:`CULL_SIGMAS`).

    Returns
    -------
    reach : ndarray of bool, (n_objects,)
    floor : float
        The smallest bound over the objects left out (inf when none is): an exact smallest
        distance only needs them when nothing kept is nearer.
    """
    has = bounds.shape[1] > 0
    bound = bounds.min(axis=0) if has else np.zeros(0)
    # How far inside its step's cull distance each circle comes (< 0: it can matter).
    inside = (bounds - cull[:, None]).min(axis=0) if has else np.zeros(0)
    per_object, margin = np.full(n_objects, np.inf), np.full(n_objects, np.inf)
    np.minimum.at(per_object, owner, bound)
    np.minimum.at(margin, owner, inside)
    reach = margin < 0.0
    floor = float(per_object[~reach].min()) if np.any(~reach) else float("inf")
    return reach, floor


def _table(values) -> np.ndarray:
    """A read-only, C-contiguous float view of a world table (a 1 x 1 stand-in for None): the
    kernel reads it in place, and one array type means one compiled kernel."""
    table = np.zeros((1, 1)) if values is None else np.ascontiguousarray(values, dtype=float)
    view = table.view()
    view.flags.writeable = False
    return view


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
        "anticipatory": config.anticipatory_pc, "terminal": config.terminal_cost,
        "nf_grid": navigation.values is not None,
        "nf_res": nf_grid.resolution if nf_grid is not None else 1.0,
        "nf_ox": nf_grid.origin[0] if nf_grid is not None else 0.0,
        "nf_oy": nf_grid.origin[1] if nf_grid is not None else 0.0,
        "goal_x": navigation.goal[0], "goal_y": navigation.goal[1],
        "goal_tol2": GOAL_TOLERANCE ** 2, "goal_tol": GOAL_TOLERANCE,
        "cull_floor": cull_floor, "cull_sigmas": cull_sigmas,
        "near_static": _SIGNIFICANT_BELL * cost.sigma_static,
        "sigma_dynamic_growth": cost.sigma_dynamic_growth,
    }
    for name, weight, enabled in terms:
        values[f"w_{name}"] = weight
        values[f"on_{name}"] = enabled
    return np.array([float(values[name]) for name in PARAMETERS])
