"""Minimise the DS-MPEPC cost over z in your own ``casadi.Opti``, with an extra constraint.

The embedded cost reads the cycle's distance and navigation tables directly, so it is the
same cost wherever your optimiser goes: the script ends by comparing it with the exact cost
at the solution. The inputs' meanings, units and layouts: ``dsmpepc_nlp.embed``
(``PARAMETER_DOCS``).
"""

import casadi as ca
import numpy as np

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.core.control_law import rollout
from dsmpepc_nlp.core.exact_cost import evaluate
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World
from dsmpepc_nlp.embed import Cycle, GraphSizes, cost_function, pack_parameters

config = PlannerConfig()
sizes = GraphSizes(max_objects=4, table_cells=64)   # the 6 m room fits in 64 x 64 cells

# A 6 m x 6 m room with one block, and a pedestrian crossing.
occupied = np.zeros((60, 60), dtype=bool)
occupied[25:35, 35:40] = True
world = World(OccupancyGrid(occupied, 0.1, (-1.0, -3.0)),
              [DynamicObstacle.pedestrian([2.0, 1.5], [0.0, -0.4])])
state = RobotState(0.0, 0.0, 0.0, v=0.3)
goal = np.array([4.5, 0.5])

cost = cost_function(config, sizes)
params = pack_parameters(Cycle.prepare(state, world, goal, config), sizes)

opti = ca.Opti()
z = opti.variable(4)
opti.minimize(cost(z=z, **params)["cost"])
opti.subject_to(opti.bounded(config.z_lower, z, config.z_upper))
opti.subject_to(z[3] <= 0.5)                       # the user's own constraint: v_max <= 0.5
opti.set_initial(z, [2.0, 0.0, 0.0, 0.5])
# The map and navigation tables are bilinear (as in the exact cost): the gradient jumps at
# cell edges, so stop when the objective stops moving rather than on the dual residual.
opti.solver("ipopt", {"print_time": False},
            {"print_level": 0, "sb": "yes", "hessian_approximation": "limited-memory",
             "acceptable_tol": 1e3, "acceptable_obj_change_tol": 1e-6, "acceptable_iter": 3,
             "max_iter": 200})
solution = opti.solve()
z_opt = solution.value(z)
terms = cost(z=z_opt, **params)
exact = evaluate(rollout(z_opt[None], state, config), world, goal, config).total[0]
print("z* =", np.round(z_opt, 3))
print({name: round(float(value), 4) for name, value in terms.items()})
print(f"embedded cost {float(terms['cost']):.4f}, exact cost {exact:.4f} at z*")
