"""The solves of one plan on parallel threads, and the idle thread they leave.

Both solvers run a plan's starts here (:func:`run_starts`): IPOPT, whose ``nlpsol`` lets go
of Python's lock while it runs, and the fast method's compiled loop (numba, ``nogil``). Each
thread takes the next start when it is free. Three starts on two threads end with one thread
waiting for the last solve; the multistart lends it work (``idle``: the polish ahead, see
:mod:`.nlp`).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

_POOLS = {}


def pool(threads: int, kind: str = "solve") -> ThreadPoolExecutor:
    """This process's pool of ``threads`` threads of one ``kind``, made once (a forked child
    makes its own: a parent's pool threads do not exist there). ``"solve"``: a plan's starts
    (:func:`run_starts`); ``"walks"``: the polish's walks beside the calling thread, a pool of
    its own so that a solve thread asking for one never waits for itself."""
    key = (os.getpid(), kind, threads)
    if key not in _POOLS:
        _POOLS[key] = ThreadPoolExecutor(threads, thread_name_prefix=f"dsmpepc-{kind}")
    return _POOLS[key]


def run_starts(solve, n: int, slots: int, idle=None, more=None) -> list:
    """``[solve(i, slot) for i in range(n)]`` on ``slots`` threads, each thread (``slot``)
    taking the next ``i`` when it is free; in order of ``i``.

    ``more(busy)``, when given, is called once, by the first thread that finds no start left
    (the others wait for it), and returns how many starts follow: ``solve`` is then called for
    ``n, n + 1, ...`` too and the list is that much longer. ``busy`` says whether a start
    still solves meanwhile (if not, the listing has every core to itself). The multistart
    lends it the screen of its starts, which the starts after the warm one depend on, while
    the warm one solves.

    ``idle(done, busy)``, when given, is called on a thread that has no start left while
    another still solves: ``done`` maps the index of every finished start to its result and
    ``busy()`` says whether a solve still runs. At most one thread runs it at a time, and
    this returns after it has. Exceptions of ``solve``, ``more`` or ``idle`` reach the caller.
    """
    queue = {"pending": iter(range(n)), "more": more}
    lock, idle_lock, more_lock = threading.Lock(), threading.Lock(), threading.Lock()
    results = [None] * n
    running = [0]

    def busy():
        with lock:
            return running[0] > 0

    def take():
        with lock:
            i = next(queue["pending"], None)
            running[0] += i is not None
        if i is not None or queue["more"] is None:
            return i
        with more_lock:         # one thread lists the further starts; the others wait here
            listing = queue["more"]
            if listing is not None:
                try:
                    extra = listing(busy())
                    with lock:
                        queue["pending"] = iter(range(len(results), len(results) + extra))
                        results.extend([None] * extra)
                finally:        # set once the starts are queued (or ``more`` raised): never
                    queue["more"] = None        # called twice, never a start missed
        return take()

    def work(slot):
        while True:
            i = take()
            if i is None:
                break
            try:
                results[i] = solve(i, slot)
            finally:
                with lock:
                    running[0] -= 1
        if idle is not None and busy() and idle_lock.acquire(blocking=False):
            try:
                with lock:
                    done = {i: r for i, r in enumerate(results) if r is not None}
                idle(done, busy)
            finally:
                idle_lock.release()

    if slots <= 1:
        work(0)
        return results
    for future in [pool(slots).submit(work, slot) for slot in range(slots)]:
        future.result()
    return results


__all__ = ["pool", "run_starts"]
