"""What the planner does beyond the optimiser, each costed through the one evaluator or the
exact reference: docking at a fixed goal (:mod:`.docking`), the stall monitor's ladder
(:mod:`.stall`), the back-up rung with its reverses, dodges and turns in place and its last
resort (:mod:`.backup`), and passive safety (:mod:`.passive`). DS-MPEPC as published
(``PlannerConfig.paper``) runs none of them but docking."""
