"""What a CasADi user needs to put the DS-MPEPC cost into their own problem, in one place.

Re-exported from :mod:`dsmpepc_nlp.solve.problem` and :mod:`dsmpepc_nlp.solve.exact.cycle`;
``examples/embed_in_opti.py`` is a complete example (its own world, ``casadi.Opti``, an extra
constraint, the exact cost at the solution).

Usage
-----
>>> cycle = Cycle.prepare(state, world, goal, config)          # doctest: +SKIP
>>> sizes = GraphSizes(max_objects=4, table_cells=64)           # doctest: +SKIP
>>> f = cost_function(config, sizes)                            # doctest: +SKIP
>>> f(z=[2.0, 0.0, 0.0, 0.8], **pack_parameters(cycle, sizes))["cost"]   # doctest: +SKIP

Inputs of the cost function
---------------------------
z : (4,)
    The plan's variables: r [m] (distance to the target pose), theta [rad] (target bearing
    from the robot's heading), delta [rad] (the target's heading against that bearing),
    v_max [m/s] (the speed cap of the control law). Box: ``config.z_lower``, ``config.z_upper``.
The parameter blocks, in the order of :data:`PARAMETER_NAMES`, shaped by
:func:`parameter_shapes` (CasADi's column-major ``vec`` when flattened), are described by
:data:`PARAMETER_DOCS`; :func:`pack_parameters` fills them from a prepared :class:`Cycle`.
"""

from __future__ import annotations

from .core.grid import FAR
from .solve.exact.cycle import Cycle
from .solve.problem import (
    FRAME_COLUMNS,
    PARAMETER_NAMES,
    GraphSizes,
    cost_function,
    flat_cost,
    flatten_parameters,
    pack_parameters,
    parameter_shapes,
)
from .solve.problem.parameters import names as settings_names

_TABLE = ("values at cell centres, flattened x-fastest (entry ``iy * table_cells + ix`` is "
          "column ix, row iy of the window, row 0 the lowest y); cells past the frame's valid "
          "columns and rows are padding the lookup never reads")
_FRAME = ("(5,): x0 [m], y0 [m] of the window's lower-left cell corner, resolution [m/cell], "
          "valid columns, valid rows (the bilinear lookup clamps to them)")

PARAMETER_DOCS = {
    "state": "(5, 1): the robot now: x [m], y [m], phi [rad], v [m/s], omega [rad/s] (the "
             "measured speeds clamped to the robot's limits).",
    "goal": "(3, 1): goal x [m], goal y [m], and a flag: 1 when the progress term is the "
            "Euclidean distance to the goal (no map: the navigation table is unused), 0 when "
            "it is read from the navigation table (nav_frame, nav_table).",
    "obstacle_circles": "(max_objects * circles_per_object, 3): x [m], y [m], radius [m] of "
                        "each dynamic object's circles now, an object's circles together, "
                        "nearest objects first; padding sits FAR (1e3 m) away.",
    "obstacle_velocities": "(max_objects, 2): vx, vy [m/s] of each object of "
                           "obstacle_circles (constant-velocity prediction).",
    "pose_circles": "(pose_objects * circles_per_object, 3): as obstacle_circles, for the "
                    "objects seen at every pose (those the robot can reach).",
    "pose_velocities": "(pose_objects, 2): as obstacle_velocities, for pose_circles.",
    "pose_mask": "(n_steps + 1, pose_objects): 1 where object j may matter at pose k, 0 where "
                 "it cannot (its collision probability is exactly 0 there).",
    "map_frame": f"{_FRAME}; the map's signed distance window.",
    "map_table": f"(table_cells**2, 1): the map's signed distance [m], {_TABLE}.",
    "nav_frame": f"{_FRAME}; the navigation function's window (the map_frame when goal[2] is 1).",
    "nav_table": f"(table_cells**2, 1): the navigation function [m to the goal], {_TABLE}.",
    "settings": ("(n_settings, 1), n_settings = len(settings_names(config)): the "
                 "configuration's numbers (weights, widths, limits, gains, dt, temperatures, "
                 "footprint circles, the DS-MPEPC switches as 0/1), in the order of "
                 "settings_names(config); pack_parameters fills it from the cycle's "
                 "configuration. A graph built for one configuration serves every "
                 "configuration of the same structure (step count, circle count): change a "
                 "number here, not the graph."),
}
"""Meaning, units and layout of each parameter block, by name. A block added to
:data:`PARAMETER_NAMES` after this was written is described by :func:`describe` as "see
pack_parameters"."""


def describe(name: str) -> str:
    """:data:`PARAMETER_DOCS` of ``name`` (a block of :data:`PARAMETER_NAMES`)."""
    return PARAMETER_DOCS.get(name, "a block of the cost's parameters: see pack_parameters.")


__all__ = ["FAR", "FRAME_COLUMNS", "PARAMETER_DOCS", "PARAMETER_NAMES", "Cycle", "GraphSizes",
           "cost_function", "describe", "flat_cost", "flatten_parameters", "pack_parameters",
           "parameter_shapes", "settings_names"]
