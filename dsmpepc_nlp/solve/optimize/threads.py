"""The solves of one plan on parallel threads, and the idle thread they leave.

Both solvers hand their per-start solve to a :class:`StartExecutor` (``solve_many(problem,
starts, executor)``): IPOPT, whose ``nlpsol`` lets go of Python's lock while it runs, and the
fast method's compiled loop (numba, ``nogil``). Each thread takes the next start when it is
free. A solver knows nothing of what else the plan does meanwhile: the multistart injects an
executor of its own (:class:`.multistart.Overlap`) that lists further starts while
the first one solves (the screen) and lends a thread left without a start work (the polish
ahead): three starts on two threads end with one thread waiting for the last solve.
"""

from __future__ import annotations

import math
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


class StartExecutor:
    """Runs a solver's solves of a plan's starts on up to ``threads`` threads (:func:`run_starts`),
    in the order of the starts. This one runs just the starts it is given; a subclass may list
    further starts (:meth:`further`) and use a thread left idle (:meth:`idle`)."""

    open_ended = False
    """True when :meth:`further` may add starts (a solver then prepares for ``threads``)."""

    deadline = None
    """The plan's :class:`~dsmpepc_nlp.core.deadline.Deadline`, or None: a solver starts no
    solve once it has passed (:meth:`time_left`), and IPOPT stops at it."""

    def time_left(self) -> float:
        """Seconds until :attr:`deadline` (inf without one)."""
        return math.inf if self.deadline is None else self.deadline.left()

    def __init__(self, threads: int = 1):
        self.threads = max(1, int(threads))
        self.starts = []
        self._listed = False

    def slots(self, n: int) -> int:
        """Threads a batch of ``n`` starts runs on."""
        return self.threads if self.open_ended else max(1, min(self.threads, n))

    def map(self, solve, starts=None, threads: int | None = None) -> list:
        """``solve(start, slot)`` for every start, then for every further start, in order, on
        :meth:`slots` threads (or ``threads``); one result each. The starts are kept: a second
        call without ``starts`` (a solver falling back to another loop) runs the same ones,
        the further ones included, without listing them again."""
        if starts is not None:
            self.starts = list(starts)
        listing = None
        if self.open_ended and not self._listed:
            def listing(busy):
                self._listed = True
                extra = list(self.further(busy))
                self.starts.extend(extra)
                return len(extra)
        slots = self.slots(len(self.starts)) if threads is None else max(1, int(threads))
        return run_starts(lambda i, slot: solve(self.starts[i], slot), len(self.starts), slots,
                          self.idle_work, listing)

    def further(self, busy: bool) -> list:
        """The starts that follow the given ones (called once, by the first thread left
        without a start; ``busy``: whether a solve still runs meanwhile)."""
        return []

    idle_work = None
    """``idle_work(done, busy)``, when set: work for a thread left without a start while
    another solves (``done``: the results so far by index; see :func:`run_starts`)."""


__all__ = ["StartExecutor", "pool", "run_starts"]
