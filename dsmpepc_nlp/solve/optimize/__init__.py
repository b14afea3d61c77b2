"""The search over z: where it starts (:mod:`.starts`: the box, the named starts, Sobol points),
the multistart NLP (:mod:`.multistart`: screen exactly, solve from the best few, choose
exactly), the backends by name (:mod:`.solvers`; IPOPT in :mod:`.ipopt`, the box Newton method
in :mod:`.newton` with :mod:`.trust_region` and its numba loop :mod:`._newton_kernel`), the
threads a plan's solves share (:mod:`.threads`), the exact-cost polish (:mod:`.polish`) and the
sampling planner, the NLP's verifier and fallback (:mod:`.sampling`)."""
