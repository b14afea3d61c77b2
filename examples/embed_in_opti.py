"""Minimise the DS-MPEPC cost over z in your own ``casadi.Opti``, with an extra constraint."""

import casadi as ca
import numpy as np

from dsmpepc_nlp.core.config import PlannerConfig, RobotState
from dsmpepc_nlp.solve.nlp import GraphSizes, cost_function, pack_parameters
from dsmpepc_nlp.core.world import DynamicObstacle, OccupancyGrid, World

config = PlannerConfig()
sizes = GraphSizes(max_objects=4, near_objects=2)   # small: builds fast

# A 6 m x 6 m room with one block, and a pedestrian crossing.
occupied = np.zeros((60, 60), dtype=bool)
occupied[25:35, 35:40] = True
world = World(OccupancyGrid(occupied, 0.1, (-1.0, -3.0)),
              [DynamicObstacle.pedestrian([2.0, 1.5], [0.0, -0.4])])
state = RobotState(0.0, 0.0, 0.0, v=0.3)
goal = np.array([4.5, 0.5])

cost = cost_function(config, sizes)
guess = [2.0, 0.0, 0.0, 0.5]
# The map and navigation function enter as local models along the guess's rollout: exact
# there, good within about half a metre (re-pack around a solution that moved further).
params = pack_parameters(state, world, goal, config, sizes, reference=guess)

opti = ca.Opti()
z = opti.variable(4)
opti.minimize(cost(z=z, **params)["cost"])
opti.subject_to(opti.bounded(config.z_lower, z, config.z_upper))
opti.subject_to(z[3] <= 0.5)                       # the user's own constraint: v_max <= 0.5
opti.set_initial(z, guess)
opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes"})
solution = opti.solve()
z_opt = solution.value(z)
terms = cost(z=z_opt, **params)
print("z* =", np.round(z_opt, 3))
print({name: round(float(value), 4) for name, value in terms.items()})
