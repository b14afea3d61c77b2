"""The smooth DS-MPEPC cost as one CasADi graph in z, valid wherever the horizon can reach.

This is the graph the built-in solvers minimise (compiled, :mod:`..build.library`) and the cost to
embed in your own optimiser (:func:`cost_function`): it reads the world through parameters set
once per cycle, never through models taken along a reference trajectory, so its value is
honest at every z:

- the static signed distance and the navigation function as look-up tables over a window of
  ``GraphSizes.table_cells`` cells around the robot (the cycle's own tables, cut out at their
  resolution), read by the same clamped bilinear interpolation plus outside distance as
  ``core/world.py::_interpolate`` (a parametric CasADi ``interpolant``, called once per point
  in MX so that the table is read in place);
- the gradient of either table (the wall normal for the static time to collision, the NF
  descent direction for the heading term) as central differences one cell wide, the formula
  of ``NavigationFunction.gradient``;
- static 1/TTC along the trajectory as the closing speed over the gap to the nearest wall's
  tangent plane (the exact ray distance in front of any flat wall); at the horizon's end,
  where it reaches ``ttc_range`` ahead, from samples of the distance along the ray at most a
  footprint radius apart (:func:`ray_samples`) (first crossing, interpolated between samples);
- the ``max_objects`` dynamic objects that come nearest to the robot's start over the horizon
  for the terminal time to collision, and at every pose the nearest ``pose_objects`` of those
  the robot can reach, moved at constant velocity inside the graph, each computed only at the
  poses it can reach that soon (:func:`pose_mask`, a CasADi conditional per pair).

Everything but the look-ups is SX (compact derivatives); the cost is ``costs.assemble``, the
formula the exact cost uses. Accuracy and speed, with the commands, are in ``docs/design.md``.

The package: :mod:`.layout` (the parameter blocks: sizes, names, shapes, and the packing of a
cycle into them, one layout in one file), :mod:`.geometry` (the formulas on symbols:
look-ups, static and dynamic geometry, the terminal ray), :mod:`.pieces` (the small SX functions
the graph calls), :mod:`.build` (the graph, and the cost to embed) and :mod:`.parameters` (the
configuration's numbers as the graph's parameter block).
"""

from .build import build_cost_function, cost_function, flat_cost
from .layout import (
    FRAME_COLUMNS,
    PARAMETER_NAMES,
    GraphSizes,
    flatten_parameters,
    is_finite_parameters,
    objects_in_reach,
    pack_obstacles,
    pack_parameters,
    pack_table,
    parameter_shapes,
    pose_mask,
    ray_samples,
    resolved_sizes,
)

__all__ = ["FRAME_COLUMNS", "GraphSizes", "PARAMETER_NAMES", "build_cost_function",
           "cost_function", "flat_cost", "flatten_parameters", "is_finite_parameters",
           "objects_in_reach", "pack_obstacles", "pack_parameters", "pack_table",
           "parameter_shapes", "pose_mask", "ray_samples", "resolved_sizes"]
