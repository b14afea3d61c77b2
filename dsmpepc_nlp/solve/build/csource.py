"""The C text spliced into CasADi's generated code: bound variants of the problem's functions
and fast paths for the bilinear tables (:func:`complete`); :mod:`.compiled` compiles the result.
"""

from __future__ import annotations

import re

_BOUND_SHIM = """
/* Bound variants (dsmpepc): NAMEb(z) is NAME(z, p) with the p of dsmpepc_bind(p), so that a
   caller holding the parameters once per cycle (IPOPT through CasADi) passes z alone and no
   copy of the tables is made per call. */
static const casadi_real* dsmpepc_bound_p = 0;
CASADI_SYMBOL_EXPORT void dsmpepc_bind(const casadi_real* p) { dsmpepc_bound_p = p; }
"""

_BOUND_FUNCTION = """
CASADI_SYMBOL_EXPORT casadi_int BOUND_n_in(void) { return NIN; }
CASADI_SYMBOL_EXPORT casadi_int BOUND_n_out(void) { return NAME_n_out(); }
CASADI_SYMBOL_EXPORT const casadi_int* BOUND_sparsity_in(casadi_int i) {
  return i < NIN ? NAME_sparsity_in(i) : 0;
}
CASADI_SYMBOL_EXPORT const casadi_int* BOUND_sparsity_out(casadi_int i) {
  return NAME_sparsity_out(i);
}
CASADI_SYMBOL_EXPORT int BOUND_work(casadi_int *sz_arg, casadi_int* sz_res, casadi_int *sz_iw,
                                    casadi_int *sz_w) {
  int flag = NAME_work(sz_arg, sz_res, sz_iw, sz_w);
  if (*sz_arg < NIN + 1) *sz_arg = NIN + 1;
  return flag;
}
CASADI_SYMBOL_EXPORT int BOUND(const casadi_real** arg, casadi_real** res, casadi_int* iw,
                               casadi_real* w, int mem) {
  if (!dsmpepc_bound_p) return 1;
  arg[NIN] = dsmpepc_bound_p;   /* p is NAME's last input; arg holds sz_arg > NIN pointers */
  return NAME(arg, res, iw, w, mem);
}
"""

_TABLE_FAST_PATHS = {
    # CasADi's generic N-d interpolation loops over corners with counters, clears and a flip;
    # the graph's tables are 2-d with one value per node, read ~190 times per evaluation
    # (29-32 % of a cost or gradient call, callgrind). For that case the same operations run
    # unrolled, in the same order, so every result is the same to the bit (tested against the
    # virtual machine). Inserted at the top of the generic function: any other case runs it.
    "casadi_interpn": """
  if (ndim == 2 && m == 1) {   /* dsmpepc: 2-d, one value per node */
    casadi_real a0, a1, b0, b1, r;
    casadi_int ld;
    const casadi_real* v;
    casadi_interpn_weights(2, grid, offset, x, w, iw, lookup_mode);
    a0 = w[0]; a1 = w[1]; b0 = 1-a0; b1 = 1-a1;
    ld = offset[1]-offset[0];
    v = values + iw[0] + iw[1]*ld;
    r = 0;
    r += (b0*b1)*v[0];
    r += (a0*b1)*v[1];
    r += (b0*a1)*v[ld];
    r += (a0*a1)*v[ld+1];
    res[0] = r;
    return;
  }
""",
    "casadi_interpn_grad": """
  if (grad && ndim == 2 && m == 1) {   /* dsmpepc: 2-d, one value per node */
    casadi_real a0, a1, b0, b1, g0, g1, u;
    casadi_int j0, j1, ld;
    const casadi_real* v;
    casadi_interpn_weights(2, grid, offset, x, w, iw, lookup_mode);
    a0 = w[0]; a1 = w[1]; b0 = 1-a0; b1 = 1-a1;
    j0 = iw[0]; j1 = iw[1]; ld = offset[1]-offset[0];
    v = values + j0 + j1*ld;
    g0 = 0; g1 = 0;
    u = 0; u += v[0];    g1 -= u*b0; u *= b1; g0 -= u;
    u = 0; u += v[1];    g1 -= u*a0; u *= b1; g0 += u;
    u = 0; u += v[ld];   g1 += u*b0; u *= a1; g0 -= u;
    u = 0; u += v[ld+1]; g1 += u*a0; u *= a1; g0 += u;
    g0 /= grid[offset[0]+j0+1]-grid[offset[0]+j0];
    g1 /= grid[offset[1]+j1+1]-grid[offset[1]+j1];
    grad[0] = g0; grad[1] = g1;
    return;
  }
""",
}
"""Fast paths for the bilinear tables, keyed by the generated C function they enter."""

_INTERPN_SIGNATURE = ("\nvoid {name}(casadi_real* {out}, casadi_int ndim, const casadi_real* grid, "
                      "const casadi_int* offset, const casadi_real* values, const casadi_real* x, "
                      "const casadi_int* lookup_mode, casadi_int m, casadi_int* iw, "
                      "casadi_real* w) {{\n")


def specialise(source: str) -> str:
    """The generated C ``source`` with :data:`_TABLE_FAST_PATHS` entered where CasADi's
    generic interpolation begins (unchanged where it is not there, as with another CasADi
    version's code: the generic loop then runs)."""
    for name, fast in _TABLE_FAST_PATHS.items():
        out = "grad" if name.endswith("_grad") else "res"
        head = _INTERPN_SIGNATURE.format(name=name, out=out)
        if source.count(head) == 1:
            source = source.replace(head, head + fast)
    return source


OF_Z_ALONE = {"F": "F_of_z", "G": "G_of_z", "H": "H_of_z"}
"""The name of ``F``, ``G``, ``H`` of z alone, reading the parameters bound by
:meth:`Compiled.bind` (what IPOPT calls; ``adj1_F_of_z``, the reverse derivative of ``F_of_z``
in z, is there for CasADi)."""
_BOUND = (("F_of_z", "F", 1), ("G_of_z", "G", 1), ("H_of_z", "H", 1),
          ("adj1_F_of_z", "Fz_adj", 3))
"""(bound name, generated function, inputs before p)."""


LONG_FUNCTION_LINES = 5000
"""Generated functions longer than this are compiled at ``-O1`` (:func:`lighten`)."""

_FUNCTION_HEAD = re.compile(r"^static int casadi_f\d+\(const casadi_real\*\* arg", re.M)


def lighten(source: str, lines: int = LONG_FUNCTION_LINES) -> str:
    """``source`` with GCC's ``optimize("O1")`` on every generated function longer than
    ``lines``: the MX-level drivers of F, G, H and the adjoint (long runs of calls and copies)
    took most of ``-O2``'s compile time for little of a call's
    (docs/experiments/2026-11-24-compile-per-structure.md); the SX pieces, where the arithmetic
    is, stay at ``-O2``. Without reassociation or contraction both levels round alike, so the
    outputs are the same bits. Other compilers ignore the attribute."""
    out, position = [], 0
    for match in _FUNCTION_HEAD.finditer(source):
        end = source.find("\n}", match.start())
        if end < 0 or source.count("\n", match.start(), end) <= lines:
            continue
        out.append(source[position:match.start()])
        out.append('__attribute__((optimize("O1")))\n')
        position = match.start()
    out.append(source[position:])
    return "".join(out)


def complete(generated: str) -> str:
    """The generated C with the table fast paths entered, the long functions lightened and
    the bound variants appended."""
    return lighten(specialise(generated)) + _BOUND_SHIM + "".join(
        _BOUND_FUNCTION.replace("BOUND", bound).replace("NAME", name)
        .replace("NIN", str(n_in)) for bound, name, n_in in _BOUND)


__all__ = ["OF_Z_ALONE", "complete", "specialise"]
