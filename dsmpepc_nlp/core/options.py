"""Checked conversions of command-line values: integers and numbers within a stated range.

Every option of the command line converts its text through one of these, so a bad value stops
the command before anything runs or is stored, with one message naming the option (argparse
adds it), the value and the allowed range.
"""

from __future__ import annotations

import argparse
import math

from .deadline import budget_from_text


def integer(low: int, high: int | None = None):
    """An argparse ``type``: an integer in ``[low, high]`` (no upper bound when None)."""
    allowed = f">= {low}" if high is None else f"from {low} to {high}"

    def convert(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: must be an integer {allowed}") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"{value}: must be an integer {allowed}")
        return value

    convert.__name__ = "integer"
    return convert


def number(low: float, *, low_open: bool = False, high: float | None = None, unit: str = ""):
    """An argparse ``type``: a finite float ``> low`` (``low_open``) or ``>= low``, ``<= high``."""
    allowed = f"{'>' if low_open else '>='} {low:g}{unit}"
    if high is not None:
        allowed += f" and <= {high:g}{unit}"

    def convert(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: must be a number {allowed}") from None
        ok = math.isfinite(value) and (value > low if low_open else value >= low) \
            and (high is None or value <= high)
        if not ok:
            raise argparse.ArgumentTypeError(f"{text}: must be a finite number {allowed}")
        return value

    convert.__name__ = "number"
    return convert


seed = integer(0)
"""A seed: an integer >= 0."""
positive = integer(1)
"""A count of at least one (samples, workers, episodes, cycles)."""
nonnegative = integer(0)
"""A count that may be zero."""


def time_budget(text: str):
    """An argparse ``type`` for a plan's time budget: ``auto``, ``none`` (no deadline) or
    seconds > 0 (``SolverConfig.time_budget``)."""
    try:
        return budget_from_text(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None

