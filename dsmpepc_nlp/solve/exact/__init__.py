"""The exact cost, the verdict on every plan: the per-cycle data every evaluator reads
(:mod:`.cycle`), the one door to the exact cost for a plan (:mod:`.evaluator`, a z costed once),
and behind it the compiled kernel (:mod:`.kernel`, numba) with its loader (:mod:`.loader`: when
it runs, its cache, the numpy fallback). The formulas' reference is
:mod:`dsmpepc_nlp.core.exact_cost`; kernel and reference agree to 1e-9 (held by tests)."""
