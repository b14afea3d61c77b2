"""The solves of a plan on threads (``solve/threads.py``): order, the idle thread, errors."""

import threading

import pytest

from dsmpepc_nlp.solve.threads import run_starts


def test_the_idle_thread_is_lent_while_the_last_start_solves():
    """Two threads, three starts: the last start waits until the idle work has seen it
    running, so the idle thread is always lent, once, with the two finished starts."""
    released = threading.Event()
    seen = []

    def solve(i, slot):
        if i == 2:
            assert released.wait(5.0), "the idle thread was never lent"
        return 10 * i

    def idle(done, busy):
        seen.append((dict(done), busy()))
        released.set()
        for _ in range(500):                  # it returns once the last solve has ended
            if not busy():
                break
            threading.Event().wait(0.01)
        seen.append(busy())

    assert run_starts(solve, 3, 2, idle) == [0, 10, 20]
    assert seen == [({0: 0, 1: 10}, True), False]


def test_one_thread_runs_the_starts_in_order_and_lends_nothing():
    lent = []
    assert run_starts(lambda i, slot: (i, slot), 3, 1, lambda *a: lent.append(a)) == \
        [(0, 0), (1, 0), (2, 0)]
    assert lent == []


def test_an_error_of_a_solve_reaches_the_caller():
    def solve(i, slot):
        if i == 1:
            raise RuntimeError("solver broke")
        return i

    with pytest.raises(RuntimeError, match="solver broke"):
        run_starts(solve, 3, 2)
