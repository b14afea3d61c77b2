"""The exact cost of many trajectories in compiled code (numba, both cores): the kernel alone.

Its modules import numba at their top and are imported only by :mod:`..exact` on first use
(numba's import alone takes a noticeable fraction of a second; the numpy path never pays it):
:mod:`.layout` (the parameter vector's named positions, the output columns and the cost's
numbers), :mod:`.terms` (the term table's formulas, compiled), :mod:`.law`
(the control law and the rollout), :mod:`.geometry` (look-ups, rays, times to collision and
to goal) and :mod:`.costs` (survivability, the assembly of the terms, the batch entry points).

The cost's terms are not transcribed: :mod:`.terms` compiles each formula of the term table
(:data:`~dsmpepc_nlp.core.terms.TERMS`), the text the numpy reference and the graph run, and
:mod:`.costs` loops over the table. The geometry under them is a scalar transcription of the
numpy reference (:func:`~dsmpepc_nlp.core.control_law.rollout`,
:func:`~dsmpepc_nlp.core.exact_cost.exact_geometry`, the survivability of
:func:`~dsmpepc_nlp.core.costs.assemble` with the exact smoothing, ``grid._interpolate``,
``OccupancyGrid.ray_distance`` and ``NavigationFunction.gradient``), written operation for
operation in the reference's order, and a property test (``tests/test_exact_compiled.py``)
holds every output to the reference to 1e-9 on random cycles and edge cases. Sums over the steps
follow numpy's pairwise summation so that the two paths round alike. An edit to either form that
the other does not follow fails that test.

The configuration enters as data (a vector named by :data:`.cycle.PARAMETERS`), so one compiled
kernel serves every configuration; :func:`..exact.kernel_cache_dir` keys the on-disk cache by
package version and the hash of every source the kernel is made of.
"""
