"""A trust-region Newton method on a small box: the NLP solver when z has only 4 variables.

With 4 variables, ``nlpsol``'s machinery (IPOPT's barrier, the SQP's QP and merit line search)
costs more than it buys: the whole step problem ``min g.d + d'Hd/2`` over the box intersected
with a trust region is solved exactly here by enumerating the 3^n faces of the box (compiled
with numba, :mod:`._newton_kernel`; the numpy definition :func:`box_qp_reference` without it),
so an indefinite Hessian needs no convexification, and every accepted step decreases the
objective (no non-monotone merit function). The objective, its gradient and its exact Hessian
come from one CasADi ``Function`` call; a trial point costs one objective call.

:func:`minimize` is the definition (Python); :class:`CompiledLoop` runs the same steps compiled
(with :func:`sr1`'s quasi-Newton Hessian); :class:`NewtonSolver` is the backend the multistart
calls (``SolverConfig.fast()``), ``solve_many(problem, starts, executor)`` like IPOPT's.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass

import numpy as np

from ...core.compile_cache import compile_enabled, import_numba_module, numba_folder, warn_once
from ...core.solver_config import SolverConfig
from ..build.library import Problem, SolveResult, snap
from .threads import StartExecutor
from .trust_region import (
    ETA,
    SHRINK,
    converged,
    model_decrease,
    next_radius,
    sr1_update,
    step_bounds,
)

_FACES = {}
_KERNEL = {}


def _faces(n: int):
    """The 3^n faces of the n-box and the 2^n sets of free variables they use.

    Returns ``(at_low, at_up, subset)`` per face (which variables sit on the lower / upper
    bound, the index of its free set) and ``(both, pad)`` per free set (the mask of the free
    block of a matrix, and the identity on the fixed variables).
    """
    if n not in _FACES:
        states = np.array(list(itertools.product((0, 1, 2), repeat=n)))  # 0 free, 1 low, 2 up
        masks = np.array(list(itertools.product((False, True), repeat=n)))
        subset = ((states == 0) * (2 ** np.arange(n)[::-1])).sum(axis=1)
        both = masks[:, :, None] & masks[:, None, :]
        pad = (~masks)[:, :, None] * np.eye(n)
        _FACES[n] = (states == 1, states == 2, subset, both, pad)
    return _FACES[n]


def box_qp(g, H, lower, upper) -> np.ndarray:
    """Global minimiser of ``g.d + d'Hd/2`` over ``lower <= d <= upper`` (small n, any H).

    :func:`box_qp_reference` with its face enumeration in compiled code
    (:mod:`._newton_kernel`, numba) when available; the reference otherwise.
    """
    g, H = np.asarray(g, dtype=float), np.asarray(H, dtype=float)
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    module = _kernel()
    if module is None:
        return box_qp_reference(g, H, lower, upper)
    d = _convex_step(g, H, lower, upper)
    if d is not None:
        return d
    return module.box_qp_faces(g, H, lower, upper, *_faces(g.size))


def _kernel():
    """The compiled box QP module, or None (numba missing or compilation off; the switch
    is read on every call, so that it holds from when it is set)."""
    if not compile_enabled():
        return None
    if "module" not in _KERNEL:
        _KERNEL["module"] = None

        try:
            folder = numba_folder(f"{__package__}._newton_kernel")
            _KERNEL["module"] = import_numba_module(f"{__package__}._newton_kernel", folder)
        except (ImportError, OSError):
            pass
    return _KERNEL["module"]


def _convex_step(g, H, lower, upper):
    """The Newton step when ``H`` is positive definite and the step lies in the box, else
    None (the common case, no face enumeration)."""
    try:
        factor = np.linalg.cholesky(H)
    except np.linalg.LinAlgError:
        return None
    d = -np.linalg.solve(factor.T, np.linalg.solve(factor, g))
    if np.all(d >= lower) and np.all(d <= upper):
        return d
    return None


def box_qp_reference(g, H, lower, upper) -> np.ndarray:
    """Global minimiser of ``g.d + d'Hd/2`` over ``lower <= d <= upper`` (small n, any H):
    the definition (numpy), which the compiled :func:`box_qp` is held to.

    The minimum of a quadratic over a box is a stationary point of its restriction to the
    relative interior of some face on which the reduced Hessian is positive semidefinite; every
    face with a positive definite reduced Hessian (and every vertex) is solved and the best
    feasible point kept. A singular reduced Hessian attains its minimum on a lower face too.
    The 2^n reduced Hessians are inverted once and shared by the 3^n faces (~0.08 ms, n = 4).
    """
    g, H = np.asarray(g, dtype=float), np.asarray(H, dtype=float)
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    n = g.size
    d = _convex_step(g, H, lower, upper)  # the common case: a convex model, step in the box
    if d is not None:
        return d
    at_low, at_up, subset, both, pad = _faces(n)
    fixed = np.where(at_low, lower, np.where(at_up, upper, 0.0))              # (3^n, n)
    reduced = np.where(both, H, 0.0) + pad                                    # (2^n, n, n)
    scale = max(1.0, float(np.max(np.abs(H))))
    positive = np.linalg.eigvalsh(reduced)[:, 0] > 1e-10 * scale                # (2^n,)
    definite = positive[subset]
    # Only the definite blocks are inverted: a singular one (seen on hall: a Hessian row of
    # exact zeros) made np.linalg.inv raise for the whole batch and the plan fall back.
    inverse = np.zeros_like(reduced)
    inverse[positive] = np.linalg.inv(reduced[positive])
    inverse *= both                               # zero outside the free block
    # Free variables: H_FF d_F = -(g_F + H_F,fixed d_fixed); fixed ones stay on their bound.
    d = fixed - np.einsum("fij,fj->fi", inverse[subset], g + fixed @ H)
    slack = 1e-9 * (1.0 + np.abs(upper - lower))
    ok = definite & np.all((d >= lower - slack) & (d <= upper + slack), axis=1)
    if not np.any(ok):
        return np.zeros(n)
    d = np.clip(d, lower, upper)
    value = np.where(ok, d @ g + 0.5 * np.einsum("fi,ij,fj->f", d, H, d), np.inf)
    return d[int(np.argmin(value))]


@dataclass(frozen=True)
class NewtonResult:
    """Where :func:`minimize` stopped: ``x``, ``fun``, ``nit`` (steps tried), ``status``,
    ``success`` (converged), evaluations of the objective alone (``nfev``) and with its
    derivatives (``nhev``)."""

    x: np.ndarray
    fun: float
    nit: int
    status: str
    success: bool
    nfev: int
    nhev: int


def minimize(f, fgh, x0, lower, upper, *, radius=0.25, max_iter=40, tol=1e-5,
             min_radius=1e-4) -> NewtonResult:
    """Minimise a smooth ``f`` over a box by trust-region Newton steps.

    Parameters
    ----------
    f : callable
        ``f(x) -> float``.
    fgh : callable
        ``fgh(x) -> (f, gradient (n,), Hessian (n, n))``.
    x0, lower, upper : array_like, (n,)
        Start (clipped into the box) and bounds.
    radius : float
        Initial trust radius as a share of each variable's range (max norm).
    max_iter : int
        Steps tried at most.
    tol : float
        Converged when a step inside the trust region predicts a decrease below ``tol``.
    min_radius : float
        Stop when the trust radius shrinks below this share of the ranges.

    Returns
    -------
    NewtonResult
        ``status`` is ``converged``, ``max_iter``, ``small_radius`` or ``non-finite``.
    """
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    span = np.where(upper > lower, upper - lower, 1.0)
    x = np.clip(np.asarray(x0, dtype=float), lower, upper)
    fx, g, H = fgh(x)
    nfev, nhev = 0, 1
    if not (math.isfinite(fx) and np.all(np.isfinite(g)) and np.all(np.isfinite(H))):
        return NewtonResult(x, fx, 0, "non-finite", False, nfev, nhev)
    status, nit = "max_iter", 0
    while nit < max_iter:
        nit += 1
        d = box_qp(g, H, *step_bounds(x, lower, upper, radius, span))
        predicted, on_edge = model_decrease(g, H, d, radius, span)
        if converged(predicted, on_edge, tol):
            status = "converged"
            break
        trial = x + d
        f_trial = f(trial)
        nfev += 1
        ratio, radius = next_radius(fx, f_trial, predicted, d, span, radius, on_edge)
        if ratio > ETA:
            f_new, g_new, H_new = fgh(trial)
            nhev += 1
            if math.isfinite(f_new) and np.all(np.isfinite(g_new)) and np.all(np.isfinite(H_new)):
                x, fx, g, H = trial, f_new, g_new, H_new
            else:
                radius *= SHRINK
        if radius < min_radius:
            status = "small_radius"
            break
    return NewtonResult(x, float(fx), nit, status, status == "converged", nfev, nhev)


_STATUS = ("converged", "max_iter", "small_radius", "non-finite")


class CompiledLoop:
    """:func:`minimize` with ``newton.sr1``'s quasi-Newton Hessian, the whole loop compiled
    (:func:`._newton_kernel.minimize_sr1`, numba, letting go of Python's lock): it calls the
    generated F, G and H of ``functions`` (a :class:`~dsmpepc_nlp.solve.build.compiled.Compiled`
    with its parameters bound) itself, no Python per evaluation. ``slots`` threads may solve
    at once, each with its own buffers; each start takes the same steps as in the Python loop
    (a test holds them together). Made by :func:`compiled_loop`."""

    def __init__(self, module, natives, lower, upper, knobs):
        self.module, self.natives, self.lower, self.upper = module, natives, lower, upper
        self.knobs = knobs
        self.faces = _faces(len(lower))

    def solve(self, x0, slot: int = 0) -> NewtonResult:
        """Minimise from ``x0`` on thread slot ``slot``'s buffers (raises :class:`LoopFailed`
        when the compiled loop itself fails, e.g. a numba that cannot type the call)."""
        (f_fn, f_buf, f_in, f_out), (g_fn, g_buf, g_in, g_out), (h_fn, h_buf, h_in, h_out) = \
            self.natives
        t, k = slot, self.knobs
        try:
            x, fun, nit, status, nfev, nhev = self.module.minimize_sr1(
                f_fn, f_buf[t], f_in[t], f_out[0][t], g_fn, g_buf[t], g_in[t], g_out[0][t],
                g_out[1][t], h_fn, h_buf[t], h_in[t], h_out[0][t], h_out[1][t], h_out[2][t],
                np.asarray(x0, dtype=float), self.lower, self.upper, float(k["radius"]),
                int(k["max_iter"]), float(k["tol"]), float(k["min_radius"]), *self.faces)
        except Exception as error:  # noqa: BLE001 - e.g. a numba that cannot type the call
            _KERNEL["loop_failed"] = True
            warn_once("newton-loop", f"the compiled Newton loop failed ({type(error).__name__}: "
                      f"{str(error)[:200]}): the Python loop runs (slower)")
            raise LoopFailed(str(error)[:200]) from error
        status = _STATUS[status]
        return NewtonResult(np.array(x), float(fun), int(nit), status, status == "converged",
                            int(nfev), int(nhev))


def compiled_loop(functions, lower, upper, slots: int = 1, *, radius=0.25, max_iter=40,
                  tol=1e-5, min_radius=1e-4) -> CompiledLoop | None:
    """The :class:`CompiledLoop` for ``functions`` on ``slots`` threads, or None when the loop
    cannot run compiled (no numba, compilation off, an earlier failure, or the functions on
    CasADi's virtual machine): use :func:`minimize`."""
    module = _kernel()
    if module is None or _KERNEL.get("loop_failed"):
        return None
    natives = [functions.native(name, max(1, int(slots))) for name in ("F", "G", "H")]
    if any(n is None for n in natives):
        return None
    return CompiledLoop(module, natives, np.asarray(lower, dtype=float),
                        np.asarray(upper, dtype=float),
                        dict(radius=radius, max_iter=max_iter, tol=tol, min_radius=min_radius))


def minimize_compiled(functions, x0, lower, upper, *, executor: StartExecutor | None = None,
                      threads: int = 2, **knobs) -> list | None:
    """:meth:`CompiledLoop.solve` from every row of ``x0`` (k, n), then from every row the
    ``executor`` adds (:class:`.threads.StartExecutor`; by default one on ``threads``
    threads), in order: one :class:`NewtonResult` each, or None when the loop cannot run
    compiled (:func:`compiled_loop`) or failed."""
    starts = list(np.asarray(x0, dtype=float).reshape(-1, len(lower)))    # none: zero rows
    executor = StartExecutor(threads) if executor is None else executor
    loop = compiled_loop(functions, lower, upper, executor.slots(len(starts)), **knobs)
    if loop is None:
        return None
    try:
        return executor.map(lambda x, slot: loop.solve(x, slot), starts)
    except LoopFailed:
        return None


class LoopFailed(RuntimeError):
    """The compiled loop itself failed (not the idle work its thread was lent)."""


def sr1(problem: Problem):
    """``fgh`` for :func:`minimize` with a quasi-Newton Hessian: the
    compiled (finite-difference) Hessian at the start, then symmetric rank-one updates from the
    gradients at the accepted points (one compiled gradient per step instead of five)."""
    state = {}

    def fgh(z):
        if not state:
            value, gradient, hessian = problem.fgh(z)
        else:
            value, gradient = problem.fg(z)
            hessian = sr1_update(state["H"], z - state["z"], gradient - state["g"])
        state.update(z=np.array(z, dtype=float), g=gradient, H=hessian)
        return value, gradient, hessian
    return fgh


class NewtonSolver:
    """The trust-region Newton method on a :class:`Problem` (parameters already bound);
    ``hessian="quasi-newton"``: symmetric rank-one updates (:func:`sr1`)."""

    def __init__(self, solver: SolverConfig):
        self.solver = solver

    def solve(self, problem: Problem, z0, lam_x=None) -> SolveResult:
        """Minimise from ``z0``; ``lam_x`` is ignored (no multipliers to warm)."""
        return self.solve_many(problem, [(z0, lam_x)])[0]

    def solve_many(self, problem: Problem, starts, executor: StartExecutor | None = None) -> list:
        """Minimise from every ``(z0, lam_x)`` of ``starts`` (``lam_x`` ignored), then from
        every start the ``executor`` adds (:class:`.threads.StartExecutor`; by default one on
        ``ParallelSettings.solve_threads`` threads).

        With the quasi-Newton Hessian on compiled functions the starts run at once on the
        executor's threads, the loop compiled (:class:`CompiledLoop`; each result's ``time_s``
        is the time from the batch's start to its end); else one after another in the Python
        loop, its definition (on one thread: none is left idle).
        """
        started = time.perf_counter()
        local = self.solver.local
        knobs = dict(radius=local.trust_radius, max_iter=local.max_iter, tol=local.tol)
        starts = list(starts)
        if executor is None:
            executor = StartExecutor(self.solver.parallel.solve_threads)
        loop = None
        if local.hessian == "quasi-newton":
            loop = compiled_loop(problem.functions, problem.lower, problem.upper,
                                 executor.slots(len(starts)), **knobs)
        if loop is not None:
            def solve(start, slot):
                z0 = np.asarray(start[0], dtype=float)
                if executor.time_left() <= 0.0:
                    return SolveResult.not_run(z0)
                result = loop.solve(z0, slot)
                return self._result(problem, z0, result, time.perf_counter() - started)
            try:
                return executor.map(solve, starts)
            except LoopFailed:      # warned once; the Python loop solves every start
                starts = None

        def python(start, slot):
            z0 = np.asarray(start[0], dtype=float)
            if executor.time_left() <= 0.0:
                return SolveResult.not_run(z0)
            begun = time.perf_counter()
            fgh = sr1(problem) if local.hessian == "quasi-newton" else problem.fgh
            result = minimize(problem.f, fgh, z0, problem.lower, problem.upper, **knobs)
            return self._result(problem, z0, result, time.perf_counter() - begun)

        return executor.map(python, starts, threads=1)

    @staticmethod
    def _result(problem, z0, result, elapsed) -> SolveResult:
        counts = dict(nfev=result.nfev, ngev=result.nhev)
        if not (np.all(np.isfinite(result.x)) and math.isfinite(result.fun)):
            return SolveResult(z0, math.nan, f"non-finite result ({result.status})", False,
                               result.nit, elapsed, **counts)
        return SolveResult(snap(result.x, problem.lower, problem.upper), result.fun,
                           result.status, result.status != "non-finite", result.nit, elapsed,
                           **counts)



__all__ = ["CompiledLoop", "LoopFailed", "NewtonResult", "NewtonSolver", "box_qp",
           "box_qp_reference", "compiled_loop", "minimize", "minimize_compiled", "sr1"]
