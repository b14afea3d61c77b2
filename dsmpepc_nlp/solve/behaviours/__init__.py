"""What the planner does beyond the optimiser, each costed through the one evaluator: the chain
the configuration orders and switches (:mod:`.chain`, ``PlannerConfig.behaviours``), docking at
a fixed goal (:mod:`.docking`), the back-up rung's moves, reverses, dodges and turns in place
(:mod:`.backup`, :mod:`.ways`), its last resort (:mod:`.last_resort`) with passive safety
(:mod:`.passive`), and the stall monitor's ladder that gates them (:mod:`.stall`). DS-MPEPC as
published (``PlannerConfig.paper``) runs none of them but docking."""
