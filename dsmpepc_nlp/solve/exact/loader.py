"""The compiled exact evaluator: when it runs, where its compiled code is cached, what it reads.

The kernel (:mod:`.kernel`, numba, both cores) rolls out and costs a batch of z from the
flat arrays of a :class:`~dsmpepc_nlp.solve.exact.cycle.Cycle` and returns the same
:class:`~dsmpepc_nlp.core.exact_cost.CostBreakdown` as the numpy reference
(:func:`~dsmpepc_nlp.core.exact_cost.evaluate`). The reference stays the definition: the kernel is a
transcription of it held to it by a property test (1e-9 on every output; see the kernel's
docstring), and with numba missing or ``DSMPEPC_NO_COMPILE=1`` everything runs the reference,
after one warning line.

Compiled code is cached on disk in ``cache_dir("numba") / <hash of the kernel's source>``, so
an edit of the kernel (or another package version) never loads stale code and a second process
loads the kernel instead of compiling it. The configuration is data to the kernel (a parameter
vector), so one compiled kernel serves every configuration.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from ...core.compile_cache import (
    compile_enabled,
    import_numba_module,
    numba_folder,
    sources_hash,
    warn_once,
)
from ...core.config import VARIANTS, PlannerConfig, RobotState
from ...core.control_law import Trajectory, rollout
from ...core.exact_cost import CostBreakdown
from ...core.terms import TERM_NAMES
from ...core.world import DynamicObstacle, OccupancyGrid, World
from .cycle import Cycle

_KERNEL_MODULE = f"{__package__}.kernel.costs"
_LOCK = threading.Lock()
_STATE = {"kernel": None, "failed": "", "numpy_only": False, "loading": None,
          "deferred": False}


def kernel_source_hash() -> str:
    """Hash of the kernel's sources (the kernel and every module of the package it imports):
    part of the cache path, so an edit to any of them recompiles."""
    return sources_hash(_KERNEL_MODULE)


def kernel_cache_dir() -> Path:
    """Where the compiled kernel is cached (package version, source closure and numba version
    in the path)."""
    return numba_folder(_KERNEL_MODULE)


def kernel():
    """The compiled kernel module, or None (numba missing, compilation off or broken).

    The first call imports numba and the kernel with numba's cache pointed at
    :func:`kernel_cache_dir`; without it, one warning line says the numpy path runs.
    """
    if _STATE["numpy_only"]:
        return None
    loading = _STATE.get("loading")
    if loading is not None and loading.is_alive() and threading.current_thread() is not loading:
        return None               # being loaded in the background (preload): numpy meanwhile
    if _STATE.get("deferred") and _STATE["kernel"] is None:
        return None               # not loaded before a preload (defer): numpy meanwhile
    if not compile_enabled():     # read on every call, so that it holds from when it is set
        warn_once("exact-compile", "exact cost on the numpy path, slower (compiled evaluator "
                  "off: DSMPEPC_NO_COMPILE is set)")
        return None
    if _STATE["kernel"] is not None:
        return _STATE["kernel"]
    if not _STATE["failed"]:
        try:
            _STATE["kernel"] = _import_kernel()
        except ImportError:
            _STATE["failed"] = "numba is missing"
        except OSError as error:
            _STATE["failed"] = f"the compile cache is not writable ({error})"
    if _STATE["kernel"] is None:
        warn_once("exact-compile", f"exact cost on the numpy path, slower (compiled evaluator "
                  f"off: {_STATE['failed']})")
    return _STATE["kernel"]


def preload() -> None:
    """Load the compiled kernel in a background thread (numba's import and the cached kernel
    take ~0.6 s); until it is there, :func:`kernel` answers None and the exact cost runs on
    the numpy path (the same costs to ~1e-12), so a robot's first plan does not wait for it.
    :func:`wait_for_kernel` waits for it."""
    _STATE["deferred"] = False
    if _STATE["kernel"] is not None or _STATE.get("loading") or not compile_enabled():
        return
    thread = threading.Thread(target=_compile_then_load, name="dsmpepc-kernel-load",
                              daemon=True)
    _STATE["loading"] = thread
    thread.start()


def _compile_then_load():
    """The preload thread: a kernel not in the cache yet is compiled by a child process that
    runs it once on every argument type (:func:`warm_up`; numba compiles on a first call, and
    its compiler would hold Python's lock for ~10 s, stalling every plan of this process),
    then loaded here (~0.6 s). The cache folder is this source's own (its path and stamp are
    in the folder's name), so files there were written for this very source."""
    try:
        if not any(kernel_cache_dir().rglob("*.nbi")):
            here = str(Path(__file__).resolve().parents[3])      # this copy, not another
            path = os.pathsep.join([here] + [p for p in [os.environ.get("PYTHONPATH")] if p])
            subprocess.run([sys.executable, "-c", "from dsmpepc_nlp.solve.exact import loader; "
                            "loader.warm_up()"], capture_output=True, timeout=600, check=False,
                           env={**os.environ, "PYTHONPATH": path})
    except (OSError, subprocess.SubprocessError):
        pass
    kernel()


def defer() -> None:
    """Until :func:`preload` or :func:`wait_for_kernel`, :func:`kernel` answers None (the numpy
    path) while the kernel is not loaded: a robot's first plan does not pay numba's import and
    the kernel's load (~0.6 s; the numpy path plans in ~0.2 s); the planner preloads after it."""
    if _STATE["kernel"] is None:
        _STATE["deferred"] = True


def standing_in() -> bool:
    """True while :func:`kernel` answers None only because the kernel is deferred or still
    loading: the numpy path stands in for a plan or two of a fresh process."""
    if _STATE["kernel"] is not None or _STATE["numpy_only"] or _STATE["failed"]:
        return False
    loading = _STATE.get("loading")
    return bool(_STATE.get("deferred")) or (loading is not None and loading.is_alive())


def wait_for_kernel():
    """:func:`kernel`, after a :func:`preload` in progress has finished (a deferred kernel is
    loaded now)."""
    _STATE["deferred"] = False
    loading = _STATE.get("loading")
    if loading is not None:
        loading.join()
    return kernel()


@contextlib.contextmanager
def numpy_only():
    """Within this block every exact evaluation runs the numpy reference (for side-by-side
    timing and comparisons), without the fallback warning."""
    previous = _STATE["numpy_only"]
    _STATE["numpy_only"] = True
    try:
        yield
    finally:
        _STATE["numpy_only"] = previous


def _import_kernel():
    return import_numba_module(_KERNEL_MODULE, kernel_cache_dir())


def evaluate_compiled(z: np.ndarray, cycle, module,
                      parallel_rows: int = 64) -> tuple[Trajectory, CostBreakdown]:
    """Roll out and cost ``z`` (n, 4) with the compiled kernel ``module`` from ``cycle``:
    :func:`as_breakdown` of :func:`kernel_pass`."""
    return as_breakdown(kernel_pass(z, cycle, module, parallel_rows), module)


def as_breakdown(raw: tuple, module) -> tuple[Trajectory, CostBreakdown]:
    """The trajectories and the :class:`CostBreakdown` of a :func:`kernel_pass`'s outputs."""
    z, poses, v, omega, target, survival, out = raw
    columns = dict(zip(module.OUT, out.T))
    with np.errstate(divide="ignore"):
        costs = CostBreakdown(
            columns["total"].copy(),
            {name: columns[name].copy() for name in TERM_NAMES},
            survival, columns["min_distance"].copy(),
            # + 0.0: a -0.0 (a turn in place's progress) is +0.0, as in the numpy reference
            1.0 / (columns["inv_ttg"] + 0.0), 1.0 / (columns["inv_ttc_terminal"] + 0.0))
    return Trajectory(z, poses, v, omega, target), costs


def kernel_pass(z, cycle, module, parallel_rows: int = 64) -> tuple:
    """The kernel's outputs for ``z`` (n, 4): ``(z, poses, v, omega, target, survival, out)``
    (``out``: the columns ``module.OUT``). Batches of at least ``parallel_rows`` rows use
    every core, smaller ones the calling thread
    (:attr:`~dsmpepc_nlp.core.solver_config.ParallelSettings.parallel_rows`).

    Rollouts the kernel marks fragile (passing a discontinuity of the law, see
    ``kernel.layout.FRAGILE_ANGLE``) are redone with the numpy reference and costed again, so
    both paths follow the same branch there.
    """
    z = np.array(z, dtype=float, order="C")  # writable and contiguous: one kernel signature
    n, n_steps = z.shape[0], cycle.config.horizon.n_steps
    poses = np.empty((n, n_steps + 1, 3))
    v = np.empty((n, n_steps))
    omega = np.empty((n, n_steps))
    target = np.empty((n, 3))
    survival = np.empty((n, n_steps + 1))
    out = np.empty((n, len(module.OUT)))
    _run(module, cycle, z, poses, v, omega, target, survival, out, False, parallel_rows)
    fragile = np.flatnonzero(out[:, module.OUT.index("fragile")])
    if fragile.size:
        again = rollout(z[fragile], cycle.state, cycle.config)
        parts = [np.array(a, order="C") for a in (again.poses, again.v, again.omega)]
        part_survival = np.empty((fragile.size, n_steps + 1))
        part_out = np.empty((fragile.size, out.shape[1]))
        _run(module, cycle, z[fragile], *parts, again.target, part_survival, part_out, True,
             parallel_rows)
        poses[fragile], v[fragile], omega[fragile] = parts
        target[fragile], survival[fragile], out[fragile] = again.target, part_survival, part_out
    return z, poses, v, omega, target, survival, out


def cost_given(trajectories: Trajectory, cycle, module, parallel_rows: int = 64) -> CostBreakdown:
    """The kernel's exact cost of ``trajectories`` (a batch on the cycle's horizon, whatever
    made them: the law's rollouts or moves it cannot make), costed as given, not rolled out.
    Its speeds must stay within ``v_limit`` (:func:`given_in_reach`): the cycle's culling of
    far objects rests on it."""
    n, n_steps = trajectories.v.shape
    arrays = [np.array(a, dtype=float, order="C") for a in (
        trajectories.z, trajectories.poses, trajectories.v, trajectories.omega,
        trajectories.target)]
    survival = np.empty((n, n_steps + 1))
    out = np.empty((n, len(module.OUT)))
    _run(module, cycle, *arrays, survival, out, True, parallel_rows)
    return as_breakdown((*arrays, survival, out), module)[1]


def given_in_reach(trajectories: Trajectory, cycle) -> np.ndarray:
    """Which of ``trajectories`` (a batch) the kernel may cost as given (bool, (n,)): on the
    cycle's horizon, finite, and never faster than ``v_limit`` either way (:func:`inside_reach`
    for given trajectories: the cycle's culling of far objects rests on it)."""
    n_steps = cycle.config.horizon.n_steps
    n = len(trajectories.z)
    if trajectories.v.shape != (n, n_steps) or trajectories.poses.shape != (n, n_steps + 1, 3):
        return np.zeros(n, dtype=bool)
    finite = (np.all(np.isfinite(trajectories.z), axis=1)
              & np.all(np.isfinite(trajectories.poses), axis=(1, 2))
              & np.all(np.isfinite(trajectories.omega), axis=1)
              & np.all(np.isfinite(trajectories.target), axis=1))
    return finite & np.all(np.abs(trajectories.v) <= cycle.config.robot.v_limit, axis=1)


def _run(module, cycle, z, poses, v, omega, target, survival, out, given, parallel_rows):
    k = cycle.kernel_arrays
    parallel = len(z) >= parallel_rows
    run = module.exact_costs if parallel else module.exact_costs_serial
    # numba's thread pool takes one launch at a time: threads of one process queue here for
    # it. The serial kernel touches no shared state (it lets go of Python's lock and writes
    # only its own outputs): threads run it side by side.
    with _LOCK if parallel else contextlib.nullcontext():
        run(z, cycle.parameters, module.cost_numbers(cycle.config.cost), k["footprint"],
            k["sdf"], k["nf"], k["predicted"], k["radii"],
            k["velocities"], k["starts"], k["culled_predicted"], k["culled_radii"],
            k["end_centers"], k["end_radii"], k["end_velocities"], poses, v, omega, target,
            survival, out, given, module.numba.get_num_threads())


def inside_reach(z: np.ndarray, cycle) -> bool:
    """True when every row is finite with ``0 <= v_max <= v_limit``: the robot's speed then
    never exceeds v_limit, which the cycle's culling of far objects rests on."""
    v_max = z[:, 3]
    return bool(np.all(np.isfinite(z)) and np.all((v_max >= 0.0)
                                                  & (v_max <= cycle.config.robot.v_limit)))


def _probe_worlds() -> list:
    """Small worlds whose cycles give the kernel every argument type a plan gives it: with and
    without a map, with and without objects."""
    occupied = np.zeros((20, 20), dtype=bool)
    occupied[:, 12] = True
    grid = OccupancyGrid(occupied, 0.2, (-2.0, -2.0))
    objects = [DynamicObstacle.pedestrian((1.5, 0.5), (-0.5, 0.0)),
               DynamicObstacle.robot((0.0, 1.5, 0.0), (0.2, 0.0),
                                     ((0.2, 0.0, 0.2), (-0.2, 0.0, 0.2)))]
    return [World(grid, objects), World(None, objects), World(grid, ()), World(None, ())]


def _run_once(module, configs) -> None:
    """The kernel, parallel and serial, on every probe world with each of ``configs``."""
    z = np.array([[1.0, 0.0, 0.0, 0.5], [2.0, 0.3, -0.3, 1.0]])
    for config in configs:
        for world in _probe_worlds():
            cycle = Cycle.prepare(RobotState(0.0, 0.0, 0.0), world, (3.0, 0.0), config)
            evaluate_compiled(z, cycle, module, parallel_rows=1)           # the parallel kernel
            evaluate_compiled(z, cycle, module, parallel_rows=len(z) + 1)  # and the serial one


def warm_up() -> bool:
    """Run the kernel once on every argument type a plan gives it, so that its compiled code
    is loaded (or, should numba's index not match, compiled) now, in a planner's
    ``prepare``, and never in a plan. False on the numpy path."""
    module = wait_for_kernel()
    if module is None:
        return False
    if not _STATE.get("warm"):        # once a process: every planner's prepare calls it
        _run_once(module, [PlannerConfig()])
        _STATE["warm"] = True
    return True


def build_kernel() -> dict:
    """Compile (or load) the kernel and run it once per built-in configuration.

    One compiled kernel serves every configuration; running each variant (MPEPC, DS-MPEPC and
    the two ablations) on small maps with a pedestrian and a robot checks that it loads and
    runs for all of them. Returns ``compiled`` (False on the numpy path), ``seconds``,
    ``cache`` (the folder) and ``configurations``.
    """
    started = time.perf_counter()
    module = kernel()
    if module is not None:
        _run_once(module, [PlannerConfig.variant(name) for name in VARIANTS])
    return {"compiled": module is not None, "seconds": time.perf_counter() - started,
            "cache": str(kernel_cache_dir()) if module is not None else None,
            "configurations": list(VARIANTS)}
