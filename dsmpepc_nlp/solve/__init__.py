"""The planner: ``Planner.plan(state, world, goal) -> Plan``, in rooms by idea.

- :mod:`.planner`, :mod:`.verdicts`, :mod:`.plan`, :mod:`.policy`, :mod:`.start_state`: the
  front door. The planner's stages, the verdicts that make the search's best a plan, the
  :class:`~.plan.Plan` it returns (and each NLP start's record), the
  planner interface the baselines share, and the start as given (an overlap, Lemma 3's brake).
- :mod:`.problem`: what is optimised. The smooth cost as one CasADi graph in z (its parameter
  layout, geometry, pieces, build) and the configuration's numbers as its parameters.
- :mod:`.build`: the problem compiled. Generated C, the compiled library per structure, and
  compiling in a child process while the sampler answers. The on-disk cache they (and the
  compiled kernels) write to is :mod:`dsmpepc_nlp.core.compile_cache`.
- :mod:`.exact`: the verifier. The per-cycle data (:mod:`.exact.cycle`), the one door to the
  exact cost (:mod:`.exact.evaluator`), the compiled kernel (:mod:`.exact.kernel`) and its loader.
  The reference formulas themselves are :mod:`dsmpepc_nlp.core.exact_cost`.
- :mod:`.optimize`: the search over z. Starts, the multistart NLP, the backends (IPOPT, the box
  Newton method), the exact-cost polish and the sampling planner.
- :mod:`.behaviours`: what the planner does beyond the optimiser. Docking, the stall monitor,
  the back-up rung with its dodges and turns, the last resort and passive safety.

The rooms' imports run one way (pyproject's import-linter contracts): the front door uses every
room; behaviours use optimize and exact; optimize uses exact, build and problem; exact and build
use problem and the core.
"""
