"""Compiling a problem's library in a child process, so that no plan waits for a compiler.

:func:`start` launches a Python child process with the configuration on its standard input; the
child builds the :class:`~dsmpepc_nlp.solve.build.library.Problem` (compiling its library into the
cache under the library's lock) and exits. A separate process, not a thread: building and
generating the graph holds Python's lock for seconds, which a thread would take from the
planner's control loop. The planner polls :func:`state` once a cycle and plans with the sampler
until the library is there.
"""

from __future__ import annotations

import pickle
import subprocess
import sys
import time

from ...core.compile_cache import warn_once

_CHILD = ("import pickle, sys; from dsmpepc_nlp.solve.build.library import Problem; "
          "Problem(*pickle.loads(sys.stdin.buffer.read()))")
"""The child's program: build (compile) the problem pickled on its standard input."""

_CHILDREN: dict = {}
"""key -> (Popen, started at)."""


MAX_RUNNING = 1
"""Children compiling at once for the planners of one process: each ``cc1`` takes a core and up
to ~0.9 GB, and the plans need the other core."""

MAX_TRIES = 2
"""Compiles of one library before the planner builds it itself (in the plan)."""

_TRIES: dict = {}


def exhausted(key) -> bool:
    """True when ``key``'s compiles failed :data:`MAX_TRIES` times (the planner then builds the
    library itself)."""
    return _TRIES.get(key, 0) >= MAX_TRIES and state(key)[0] == "failed"


def running() -> int:
    """Children compiling now."""
    return sum(child.poll() is None for child, _ in _CHILDREN.values())


def start(key, config, sizes, solver) -> bool:
    """Compile the problem of ``(config, sizes, solver)`` in a child process unless one for
    ``key`` is running or done, :data:`MAX_RUNNING` are running (the caller asks again later)
    or it failed :data:`MAX_TRIES` times. True when one is running for ``key`` now."""
    if key in _CHILDREN:
        if _CHILDREN[key][0].poll() is None:
            return True
        if state(key)[0] == "done" or exhausted(key):
            return False
        del _CHILDREN[key]                     # failed: try again
    if running() >= MAX_RUNNING:
        return False
    _TRIES[key] = _TRIES.get(key, 0) + 1
    _spawn(key, config, sizes, solver)
    return True


def _spawn(key, config, sizes, solver) -> None:
    child = subprocess.Popen([sys.executable, "-c", _CHILD], stdin=subprocess.PIPE,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        child.stdin.write(pickle.dumps((config, sizes, solver)))
        child.stdin.close()
    except OSError:
        pass
    _CHILDREN[key] = (child, time.monotonic())


def state(key) -> tuple:
    """``(status, seconds)`` of ``key``'s child: ``running``, ``done``, ``failed`` (one
    warning line with the child's last words) or ``none`` (never started); seconds since it
    started."""
    if key not in _CHILDREN:
        return "none", 0.0
    child, started = _CHILDREN[key]
    code = child.poll()
    elapsed = time.monotonic() - started
    if code is None:
        return "running", elapsed
    tail = ""
    if child.stderr is not None and not child.stderr.closed:
        tail = child.stderr.read().decode(errors="replace")[-300:]
        child.stderr.close()
    if code != 0:
        warn_once(f"background-{key}", f"compiling the NLP in the background failed ({tail}): "
                  "the planner builds it in its own process")
        return "failed", elapsed
    return "done", elapsed


def run_all(jobs, workers: int) -> None:
    """Compile ``jobs`` (``(key, config, sizes, solver)`` each) in at most ``workers`` child
    processes at once; returns when every child has ended."""
    queue, running = list(jobs), []
    while queue or running:
        while queue and len(running) < workers:
            key, config, sizes, solver = queue.pop(0)
            _CHILDREN.pop(key, None)
            _TRIES.pop(key, None)
            _spawn(key, config, sizes, solver)
            running.append(key)
        time.sleep(0.05)
        running = [key for key in running if state(key)[0] == "running"]
