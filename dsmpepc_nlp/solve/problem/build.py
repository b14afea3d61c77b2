"""The smooth cost as one CasADi graph (:func:`build_cost_function`), the solvers' flat form
(:func:`flat_cost`) and the cost to embed in your own problem (:func:`cost_function`)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from ...core.config import PlannerConfig
from ...core.control_law import symbolic_rollout
from ...core.terms import TERM_NAMES
from .geometry import lookups, table_lookup
from .layout import PARAMETER_NAMES, GraphSizes, parameter_shapes, resolved_sizes
from .pieces import (
    final_functions,
    object_function,
    piece,
    pose_functions,
    symbolic,
    terminal_functions,
)


def build_cost_function(config: PlannerConfig, sizes: GraphSizes, smoothing=None,
                        fixed_parameters: bool = False) -> ca.Function:
    """The smooth cost as a ``casadi.Function`` named ``dsmpepc_cost``.

    Inputs: ``z`` (4) and the blocks of :data:`PARAMETER_NAMES` (shapes from
    :func:`parameter_shapes`, values from :func:`pack_parameters`; the configuration's numbers
    are the ``settings`` block, so one graph serves every configuration of the same
    :func:`.settings.structure`). Outputs: ``cost`` and each term of
    :data:`~dsmpepc_nlp.core.cost_config.TERM_NAMES`. A ``smoothing`` other than the configuration's
    is built in as constants.

    An MX graph of small SX functions (the rollout, one pose's geometry called N+1 times, the
    terminal ray, the assembly) and the table look-ups: each piece and its derivatives exist
    once in generated code, so it compiles in seconds, not minutes. With ``fixed_parameters``
    (the solvers' graph) derivatives exist in ``z`` alone: every parameter block is marked
    not differentiable.
    """
    sizes = resolved_sizes(config, sizes)
    fixed = fixed_parameters
    shapes = parameter_shapes(config, sizes)
    n_steps = config.horizon.n_steps
    z_sx, state_sx = ca.SX.sym("z", 4), ca.SX.sym("state", 5)
    q, sym_config, sym_smoothing = symbolic(config, smoothing)
    rollout = piece("dsmpepc_rollout", [z_sx, state_sx, q],
                     list(symbolic_rollout(z_sx, state_sx, sym_config, sym_smoothing)[:3]),
                     fixed, (1, 2))
    pose_query, pose_geometry = pose_functions(config, sizes, smoothing, fixed)
    object_kept = object_function(config, sizes, smoothing, fixed)
    ray_query, terminal = terminal_functions(config, sizes, smoothing, fixed)
    nav_query, final = final_functions(config, sizes, smoothing, fixed)
    lookup = table_lookup(sizes)
    z = ca.MX.sym("z", 4)
    p = {name: ca.MX.sym(name, *shape) for name, shape in shapes.items()}
    settings = p["settings"]
    objects = (p["obstacle_circles"], p["obstacle_velocities"])
    c_obj = sizes.circles_per_object
    poses, vs, omegas = rollout(z, p["state"], settings)
    distances, inverses, kept = [], [], []
    for k in range(n_steps + 1):
        pose, speed = poses[:, k], vs[min(k, n_steps - 1)]
        raw = lookups(lookup, pose_query(pose, p["map_frame"], settings), p["map_table"])
        d, inv = pose_geometry(pose, speed, raw, p["map_frame"], settings)
        distances.append(d)
        inverses.append(inv)
        product = ca.MX(1.0)
        for j in range(sizes.k_pose):
            product = product * object_kept(p["pose_mask"][k, j], pose, speed, k,
                                             p["pose_circles"][j * c_obj:(j + 1) * c_obj, :],
                                             p["pose_velocities"][j, :], settings)
        kept.append(product)
    inv_term = ca.MX(0)
    if sym_config.terminal_cost:        # always: MPEPC's is the switch's 0 (settings.py)
        end = poses[:, -1]
        raw = lookups(lookup, ray_query(end, p["map_frame"], settings), p["map_table"])
        inv_term = terminal(end, raw, p["map_frame"], *objects, settings)
    nav_raw = lookups(lookup, nav_query(poses, p["nav_frame"]), p["nav_table"])
    outputs = final(poses, vs, omegas, p["goal"], p["nav_frame"], nav_raw,
                    ca.vertcat(*distances), ca.vertcat(*inverses), ca.vertcat(*kept), inv_term,
                    settings)
    return ca.Function("dsmpepc_cost", [z, *(p[n] for n in PARAMETER_NAMES)], outputs,
                       ["z", *PARAMETER_NAMES], ["cost", *TERM_NAMES])


def flat_cost(config: PlannerConfig, sizes: GraphSizes, smoothing=None) -> ca.Function:
    """The cost as ``(z, p) -> f`` with ``p`` the flat vector of :func:`flatten_parameters`
    (what the solvers and the compiled code take; derivatives in ``z`` alone)."""
    cost = build_cost_function(config, sizes, smoothing, fixed_parameters=True)
    shapes = parameter_shapes(config, sizes)
    counts = [int(np.prod(shapes[n])) for n in PARAMETER_NAMES]
    z, p = ca.MX.sym("z", 4), ca.MX.sym("p", sum(counts))
    blocks = ca.vertsplit(p, np.cumsum([0, *counts]).tolist())
    blocks = [ca.reshape(b, *shapes[n]) for b, n in zip(blocks, PARAMETER_NAMES)]
    # Inlined (not a call of ``cost``): a call's reverse sweep would also build the adjoint
    # of every parameter, the two 65k-entry tables included, on every gradient.
    return ca.Function("dsmpepc_flat_cost", [z, p], [cost.call([z, *blocks], True, False)[0]])


def cost_function(config: PlannerConfig, sizes: GraphSizes | None = None,
                  smoothing=None) -> ca.Function:
    """The smooth DS-MPEPC cost as a ``casadi.Function`` to embed in your own problem.

    Parameters
    ----------
    config : PlannerConfig
        Method and parameters; the temperatures come from ``config.smoothing`` unless
        ``smoothing`` is given (``SmoothingConfig.exact()`` gives the non-smooth forms).
    sizes : GraphSizes, optional
        Objects seen, table window and terminal ray samples.

    Returns
    -------
    casadi.Function
        Named inputs ``z`` (4: r [m], theta [rad], delta [rad], v_max [m/s]) and the blocks of
        :data:`PARAMETER_NAMES` (from :func:`pack_parameters` of a prepared ``Cycle``); named
        outputs ``cost``, ``progress``, ``action``, ``collision``, ``heading``, ``terminal``.

    Examples
    --------
    >>> f = cost_function(PlannerConfig())                       # doctest: +SKIP
    >>> params = pack_parameters(Cycle.prepare(state, world, goal, config), GraphSizes())
    ...                                                          # doctest: +SKIP
    >>> f(z=[2.0, 0.0, 0.0, 0.8], **params)["cost"]              # doctest: +SKIP
    """
    return build_cost_function(config, GraphSizes() if sizes is None else sizes, smoothing)
