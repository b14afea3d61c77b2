"""The solves of a plan on threads (``optimize/threads.py``): order, the idle thread, errors."""

import threading

import pytest

from dsmpepc_nlp.solve.optimize.threads import run_starts


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


def test_the_further_starts_are_listed_once_while_the_first_solves():
    """``more``: the thread without a start lists the further starts while the first start
    solves (it waits until they are listed, and the listing is told so); every start's result
    comes back in order, the listing once, and the other thread takes the listed starts too."""
    listed = threading.Event()
    calls, slots = [], {}

    def solve(i, slot):
        if i == 0:
            assert listed.wait(5.0), "the further starts were not listed meanwhile"
        slots[i] = slot
        return 10 * i

    def more(busy):
        calls.append(busy)
        listed.set()
        return 2

    assert run_starts(solve, 1, 2, more=more) == [0, 10, 20]
    assert calls == [True] and slots[0] != slots[1]      # listed while start 0 solved


def test_an_error_while_listing_reaches_the_caller_and_nothing_is_listed_twice():
    calls = []

    def more(busy):
        calls.append(1)
        raise RuntimeError("screen broke")

    with pytest.raises(RuntimeError, match="screen broke"):
        run_starts(lambda i, slot: i, 1, 2, more=more)
    assert calls == [1]


def test_one_thread_lists_the_further_starts_after_its_own():
    alone = []

    def more(busy):
        alone.append(not busy)
        return 2

    assert run_starts(lambda i, slot: (i, slot), 1, 1, more=more) == [(0, 0), (1, 0), (2, 0)]
    assert alone == [True]                       # nothing solved while it listed


def test_an_executor_lists_further_starts_once_and_keeps_them_for_a_second_loop():
    """``StartExecutor``: the starts it is given, then the ones ``further`` lists (once, by
    the first thread left without a start), in order; a second ``map`` without starts (a
    solver falling back to another loop) runs all of them again without listing again."""
    from dsmpepc_nlp.solve.optimize.threads import StartExecutor

    asked = []

    class Listing(StartExecutor):
        open_ended = True

        def further(self, busy):
            asked.append(busy)
            return ["c", "d"]

    executor = Listing(2)
    assert executor.slots(1) == 2
    assert executor.map(lambda start, slot: start.upper(), ["a", "b"]) == ["A", "B", "C", "D"]
    assert executor.map(lambda start, slot: (start, slot), threads=1) == \
        [("a", 0), ("b", 0), ("c", 0), ("d", 0)]
    assert len(asked) == 1
    plain = StartExecutor(4)
    assert plain.slots(2) == 2 and plain.map(lambda start, slot: start, [1, 2, 3]) == [1, 2, 3]
