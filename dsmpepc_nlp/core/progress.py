"""The one progress facility: tqdm bars on stderr, quiet when stderr is not a terminal.

Long runs (an episode, a benchmark of many runs) show a bar while someone watches; in a log
file, a pipe or a test the bars stay silent and only the one-line results the commands print
remain, so captured output does not fill with redraws.
"""

from __future__ import annotations

import sys
import time

from tqdm import tqdm


def _stream(stream):
    return sys.stderr if stream is None else stream


def is_terminal(stream=None) -> bool:
    """Whether ``stream`` (default stderr) is an interactive terminal."""
    return bool(getattr(_stream(stream), "isatty", lambda: False)())


def bar(total: int, label: str, *, unit: str = "run", stream=None) -> tqdm:
    """A progress bar of ``total`` steps on ``stream`` (stderr), disabled off a terminal."""
    stream = _stream(stream)
    return tqdm(total=total, desc=label, unit=unit, file=stream, leave=True,
                disable=not is_terminal(stream), dynamic_ncols=True)


def say(text: str, stream=None) -> None:
    """One status line on ``stream`` (stderr): what a run is about to do, or what it did."""
    print(text, file=_stream(stream), flush=True)


class EpisodeProgress:
    """``progress(cycle, t, n_cycles, n_active)`` for :func:`~dsmpepc_nlp.sim.simulate.simulate`:
    a bar over the cycles, and :meth:`done` one line with the outcomes."""

    def __init__(self, label: str, stream=None):
        self.label, self.stream = label, _stream(stream)
        self._bar = None
        self.started = time.perf_counter()

    def __call__(self, cycle, t, n_cycles, n_active):
        if self._bar is None:
            self._bar = bar(n_cycles, self.label, unit="cycle", stream=self.stream)
        self._bar.set_postfix_str(f"t = {t:.1f} s, {n_active} moving", refresh=False)
        self._bar.update(1)

    def done(self, text: str) -> None:
        if self._bar is not None:
            self._bar.close()
        elapsed = time.perf_counter() - self.started
        say(f"[{self.label}] {text} ({elapsed:.1f} s wall)", self.stream)
