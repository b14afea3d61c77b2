"""The NLP's cost, gradient and Hessian as compiled C, built once per configuration and cached.

The solvers evaluate the cost thousands of times per plan; CasADi's virtual machine and the
Python call around it cost more than the arithmetic. Here the problem's functions of
``(z, p)`` (``p`` the flat parameter vector of one cycle) are generated as C with CasADi's code
generator, compiled with the system C compiler into a shared library cached on disk
(:mod:`~dsmpepc_nlp.core.compile_cache`: per configuration, package version and source hash), and
loaded twice: as CasADi ``external`` functions for ``nlpsol`` (no Python inside IPOPT) and
through ``ctypes`` with the parameter vector bound once per solve (one C call per
evaluation for the trust-region Newton method). Without a compiler, or with
``DSMPEPC_NO_COMPILE=1``, the same functions run in CasADi's virtual machine (one warning).
"""

from __future__ import annotations

import ctypes
import functools
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

from ...core.compile_cache import (
    build_lock,
    cache_dir,
    compile_enabled,
    config_key,
    prune,
    sources_hash,
    touch,
    warn_once,
)
from .csource import OF_Z_ALONE, complete, specialise

NAMES = ("F", "G", "H")
"""Generated functions of ``(z, p)``: ``F -> f``, ``G -> (f, grad)``, ``H -> (f, grad, hess)``."""
@functools.lru_cache(maxsize=1)
def source_hash() -> str:
    """Hash of every module the generated code is made from (:func:`.cache.source_closure` of
    the graph and this file): a code change never loads stale C."""
    return sources_hash(f"{__package__}.graph.build", __name__)


def problem_functions(cost: ca.Function, fd_step=None, hessian="differences") -> dict:
    """``F``, ``G``, ``H`` (and ``adj1_F`` for ``nlpsol``) from the cost graph.

    ``cost(z, p) -> f`` takes the flat parameter vector; it is inlined, so the gradient's
    reverse sweep is built for ``z`` only. ``hessian``: ``differences`` (forward differences
    of the gradient with steps ``fd_step`` (4,), symmetrised: a bilinear table has no
    curvature to add) or ``exact`` (forward over reverse through the whole graph). With
    ``fd_step`` None the four steps are parameters: the functions' ``p`` is the cost's
    followed by the steps (the box's size, hence the steps, is a setting, not structure).
    """
    n_cost = cost.size1_in(1)
    z, p = ca.MX.sym("z", 4), ca.MX.sym("p", n_cost + (4 if fd_step is None else 0))
    f = cost.call([z, p[:n_cost] if fd_step is None else p], True, False)[0]
    grad = ca.gradient(f, z)
    G = ca.Function("G", [z, p], [f, grad])
    if hessian == "exact":
        hess = ca.jacobian(grad, z)
    else:
        steps = [p[n_cost + i] for i in range(4)] if fd_step is None else list(fd_step)
        columns = []
        for i in range(4):
            if fd_step is None:
                step = ca.vertcat(*(steps[i] if j == i else 0.0 for j in range(4)))
            else:
                step = np.zeros(4)
                step[i] = fd_step[i]
            columns.append((G(z + step, p)[1] - grad) / steps[i])
        hess = ca.horzcat(*columns)
    F = ca.Function("F", [z, p], [f])
    H = ca.Function("H", [z, p], [f, grad, 0.5 * (hess + hess.T)])
    out, seed = ca.MX.sym("out_f"), ca.MX.sym("adj_f")
    adjoint = ca.Function("Fz_adj", [z, out, seed, p], [seed * grad])
    return {"F": F, "G": G, "H": H, f"adj1_{F.name()}": F.reverse(1), "Fz_adj": adjoint}


COMPILE_FLAGS = ("-O2", "-fno-semantic-interposition", "-fno-math-errno")
"""How the generated C is compiled (the measurements:
docs/experiments/2026-11-23-what-a-compiled-call-spends.md):

- ``-O2``: shorter calls than ``-O1`` for a longer compile;
- ``-fno-semantic-interposition``: the file's own small helpers (``casadi_sq``,
  ``casadi_fmax``, ``casadi_copy``, ...) may be inlined, which ``-fPIC`` otherwise forbids;
- ``-fno-math-errno``: ``sqrt`` as one instruction (nothing reads ``errno``).

No ``-ffast-math`` and no ``-march``: without reassociation or fused multiply-adds every
operation rounds as written, and the outputs are ``-O1``'s to the bit."""


@functools.lru_cache(maxsize=4)
def _find_compiler(name: str) -> str | None:
    return shutil.which(name) or shutil.which("cc")


def _compiler() -> str | None:
    return _find_compiler(os.environ.get("CC", "gcc"))


def _usable_compiler() -> str | None:
    """The C compiler, or None (with one warning) when compilation is off or there is none."""
    if not compile_enabled():
        warn_once("casadi-compile", "DSMPEPC_NO_COMPILE is set: the NLP runs in CasADi's "
                  "virtual machine (slower)")
        return None
    compiler = _compiler()
    if compiler is None:
        warn_once("casadi-compile", "no C compiler found: the NLP runs in CasADi's virtual "
                  "machine (slower)")
    return compiler


def _library_path(key: str) -> Path:
    return cache_dir("casadi") / f"nlp_{key}.so"


def compile_library(functions: dict, key: str, flags=COMPILE_FLAGS) -> Path | None:
    """The shared library of ``functions`` for ``key``, compiled unless cached; None when
    compilation is disabled or fails (the caller then uses the virtual machine)."""
    compiler = _usable_compiler()
    if compiler is None:
        return None
    library = _library_path(key)
    if library.exists():
        touch(library)
        return library
    with build_lock(library):
        if library.exists():          # built by another process while this one waited
            return library
        built = _compile(functions, key, library, compiler, flags)
    if built is not None:
        prune(keep=(built,))
    return built


def _compile(functions: dict, key: str, library: Path, compiler: str, flags) -> Path | None:
    """Generate, specialise and compile the C of ``functions`` into ``library``."""
    with tempfile.TemporaryDirectory(dir=library.parent) as work:
        generator = ca.CodeGenerator(f"nlp_{key}.c", {"with_header": False})
        for function in functions.values():
            generator.add(function)
        generator.generate(work + os.sep)
        source = Path(work) / f"nlp_{key}.c"
        source.write_text(complete(source.read_text()))
        target = Path(work) / library.name
        # The options, then the first (the optimisation level) alone for a compiler that
        # refuses the others; one attempt when there are no others.
        for attempt in dict.fromkeys((tuple(flags), tuple(flags[:1]))):
            done = subprocess.run([compiler, "-shared", "-fPIC", *attempt, "-o", str(target),
                                   str(source), "-lm"], capture_output=True, text=True)
            if done.returncode == 0:
                break
        if done.returncode != 0:
            warn_once("casadi-compile", f"compiling the NLP failed ({done.stderr[-200:]}): "
                      "CasADi's virtual machine is used (slower)")
            return None
        os.replace(target, library)   # atomic: a concurrent process sees all or nothing
    return library


_NATIVE = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_size_t, ctypes.c_size_t, ctypes.c_size_t,
                           ctypes.c_size_t, ctypes.c_int)
"""A generated function's C signature with its pointers as integers (``size_t`` and a pointer
have the same size and are passed alike on the platforms numba runs on): numba calls it with
addresses it holds as numbers."""


class CFunction:
    """One generated function called through ``ctypes`` with its parameters bound once.

    ``bind(p)`` keeps ``p`` (float64) for the following calls; ``__call__(z)`` writes ``z``
    and returns the outputs as numpy arrays (views of buffers reused by the next call: copy
    what you keep).
    """

    def __init__(self, library: ctypes.CDLL, name: str, function: ca.Function):
        self._call = getattr(library, name)
        self._call.restype = ctypes.c_int
        self._call.argtypes = [ctypes.c_void_p] * 4 + [ctypes.c_int]
        sizes = [ctypes.c_longlong() for _ in range(4)]
        work = getattr(library, f"{name}_work")
        work.argtypes = [ctypes.c_void_p] * 4
        work(*(ctypes.byref(s) for s in sizes))
        n_arg, n_res, n_iw, n_w = (max(int(s.value), 1) for s in sizes)
        self._iw = np.zeros(n_iw, dtype=np.int64)
        self._w = np.zeros(n_w)
        self._z = np.zeros(4)
        self._outputs = [np.zeros(function.nnz_out(i)) for i in range(function.n_out())]
        self._shapes = [function.size_out(i) for i in range(function.n_out())]
        self._arg = (ctypes.c_void_p * n_arg)()
        self._res = (ctypes.c_void_p * n_res)()
        self._arg[0] = self._z.ctypes.data
        for i, out in enumerate(self._outputs):
            self._res[i] = out.ctypes.data
        self._p = None
        self._rows = {}
        self._native = _NATIVE(ctypes.cast(self._call, ctypes.c_void_p).value)

    def bind(self, p: np.ndarray) -> None:
        """Use ``p`` (flat parameters) for every call until the next ``bind``."""
        self._p = np.ascontiguousarray(p, dtype=float)
        self._arg[1] = self._p.ctypes.data

    def native_rows(self, rows: int) -> tuple:
        """What compiled code needs to call this function itself, with ``rows`` independent
        sets of buffers (one per thread): ``(pointer, buffers, z, outputs)``. ``pointer`` is a
        ctypes function of four addresses (arg, res, iw, w) and the memory flag, ``buffers``
        those addresses per row ``(rows, 4)`` uint64, ``z`` ``(rows, 4)`` where each row's
        call reads z, ``outputs`` one ``(rows, nnz)`` array per output it writes. The arrays
        are kept here, so they live as long as this object; each call points them at the
        parameters of the last :meth:`bind`."""
        if rows not in self._rows:
            n_arg, n_res = len(self._arg), len(self._res)
            z = np.zeros((rows, self._z.size))
            outputs = [np.zeros((rows, out.size)) for out in self._outputs]
            iw = np.zeros((rows, self._iw.size), dtype=np.int64)
            w = np.zeros((rows, self._w.size))
            arg = np.zeros((rows, n_arg), dtype=np.uint64)
            res = np.zeros((rows, n_res), dtype=np.uint64)
            for r in range(rows):
                arg[r, 0] = z[r].ctypes.data
                for i, out in enumerate(outputs):
                    res[r, i] = out[r].ctypes.data
            index = np.arange(rows, dtype=np.uint64)
            buffers = np.stack([np.uint64(a.ctypes.data) + index * np.uint64(a.strides[0])
                                for a in (arg, res, iw, w)], axis=1)
            self._rows[rows] = (arg, buffers, z, outputs, res, iw, w)
        arg, buffers, z, outputs = self._rows[rows][:4]
        if self._p is not None:
            arg[:, 1] = self._p.ctypes.data
        return self._native, buffers, z, outputs

    def __call__(self, z) -> list:
        self._z[:] = z
        if self._call(self._arg, self._res, self._iw.ctypes.data, self._w.ctypes.data, 0):
            raise RuntimeError("generated code reported an error")
        return [out.reshape(shape, order="F") for out, shape in zip(self._outputs, self._shapes)]


class Compiled:
    """``F``, ``G``, ``H`` for ``nlpsol`` (CasADi Functions) and for Python (``call``).

    Attributes
    ----------
    functions : dict of str to casadi.Function
        External (compiled) functions, or the graph's own in the virtual machine; compiled,
        also ``F_of_z``, ``G_of_z``, ``H_of_z``, of z alone (:data:`OF_Z_ALONE`).
    compiled : bool
        True when the functions run as compiled C.
    """

    def __init__(self, functions: dict | None, library: Path | None):
        self.compiled = library is not None
        if library is None:
            self.functions = functions
            self._c = None
            return
        # The library alone (``functions`` may be None): the externals carry the generated
        # functions' shapes and work sizes, so a cached library needs no graph.
        self.functions = {name: ca.external(name, str(library))
                          for name in (*NAMES, *OF_Z_ALONE.values())}
        handle = ctypes.CDLL(str(library))
        self._c = {name: CFunction(handle, name, self.functions[name]) for name in NAMES}
        self._bind = handle.dsmpepc_bind
        self._bind.argtypes = [ctypes.c_void_p]
        self._bind.restype = None

    def bind(self, p: np.ndarray) -> None:
        """Set the parameters of the following :meth:`call` s (and, compiled, of the bound
        functions ``F_of_z``, ``G_of_z``, ``H_of_z``: ``p`` is kept, not copied, until the next
        bind)."""
        if self._c is None:
            self._p = ca.DM(p)
        else:
            self._p = np.ascontiguousarray(p, dtype=float)
            for function in self._c.values():
                function.bind(self._p)
            self._bind(self._p.ctypes.data)

    @property
    def n_params(self) -> int:
        """Length of the flat parameter vector ``p``."""
        return self.functions["F"].size1_in(1)

    def native(self, name: str, rows: int = 1):
        """:meth:`CFunction.native_rows` of ``name`` (F, G or H); None on the virtual
        machine."""
        return None if self._c is None else self._c[name].native_rows(rows)

    def call(self, name: str, z) -> list:
        """``name`` (F, G or H) at ``z`` with the bound parameters, as numpy arrays."""
        if self._c is None:
            out = self.functions[name](z, self._p)
            out = out if isinstance(out, (list, tuple)) else [out]
            return [np.asarray(o, dtype=float) for o in out]
        return self._c[name](z)


def load_or_compile(make_cost, fd_step, key_parts: tuple, hessian="differences") -> Compiled:
    """Compile (or load from the cache) the problem's functions for one structure.

    ``make_cost()`` returns the cost graph ``cost(z, p) -> f``. It is called only when the
    library is not in the cache (or runs on the virtual machine): building the graph and its
    derivatives takes ~0.2 s, loading the cached library a few ms, so that a planner meeting a
    new object bucket mid-run does not miss its control period. ``fd_step`` None: the
    difference steps are parameters (:func:`problem_functions`). The key holds ``key_parts``
    (the structure), the sources, CasADi's version, the compiler and its flags.
    """
    key = library_key(*key_parts, hessian=hessian, fd_step=fd_step)
    library = _library_path(key)
    if _usable_compiler() is not None and library.exists():
        touch(library)
        return Compiled(None, library)
    functions = problem_functions(make_cost(), fd_step, hessian)
    return Compiled(functions, compile_library(functions, key))


def compiling_possible() -> bool:
    """True when a library can be compiled (compilation on, a compiler found; the compiler is
    looked up once a process)."""
    return compile_enabled() and _compiler() is not None


def is_cached(key: str) -> bool:
    """True when the library of ``key`` is in the cache."""
    return _library_path(key).exists()


def library_key(*key_parts, hessian="differences", fd_step=None) -> str:
    """The cache key of the library :func:`load_or_compile` makes of these arguments."""
    steps = None if fd_step is None else tuple(np.asarray(fd_step, dtype=float).tolist())
    return config_key(*key_parts, hessian, steps, source_hash(), ca.__version__,
                      _compiler_identity(), COMPILE_FLAGS)


@functools.lru_cache(maxsize=1)
def _compiler_identity() -> str:
    """The compiler's resolved path, size and modification time: a new compiler, a new key."""
    compiler = _compiler()
    if compiler is None:
        return "none"
    path = Path(compiler).resolve()
    stat = path.stat()
    return f"{path}:{stat.st_size}:{stat.st_mtime_ns}"


__all__ = ["OF_Z_ALONE", "CFunction", "Compiled", "compile_library", "load_or_compile",
           "problem_functions", "source_hash", "specialise"]
