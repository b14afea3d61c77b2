"""The package's one exception type for bad input, and the small checks that raise it."""

import math

import numpy as np


class InputError(ValueError):
    """Bad input: the message names the source (file), the field, the value and what is allowed.

    A ``ValueError``, so ``except ValueError`` keeps working; the command line prints it on one
    line and exits with status 2.
    """


# Plausible magnitudes: the ranges every position, duration, speed, size and resolution read from
# a file or a configuration must lie in. Finite is not enough: 1e308 passes ``isfinite`` and
# then overflows (a cycle count, a grid extent, a squared distance). Generous for any robot.

MAX_COORDINATE = 1.0e6
"""Largest ``|x|``, ``|y|`` (m) of a position (start, goal, origin, waypoint), and ``|phi|``
(rad) of a heading."""
MAX_DURATION = 86_400.0
"""Longest duration (s): one day; also bounds waypoint times."""
MAX_SPEED = 100.0
"""Largest speed (m/s): a robot's ``v_limit``, a pedestrian's velocity components."""
MAX_SIZE = 100.0
"""Largest radius or length (m): footprint circles and offsets, tolerances, following
distance, ``start_noise``."""
RESOLUTION_RANGE = (1.0e-4, 100.0)
"""Map cell side (m), inclusive."""


def shown(value, limit: int = 120) -> str:
    """``repr(value)`` for a message, without numpy's spelling: numpy scalars as Python numbers
    (``0.0``, not ``np.float64(0.0)``), arrays as lists, anything long cut at ``limit``."""
    if isinstance(value, np.generic):
        value = value.item()
    elif isinstance(value, np.ndarray):
        value = value.tolist() if value.size <= 16 else f"<array of shape {value.shape}>"
    elif isinstance(value, (list, tuple)) and any(isinstance(v, np.generic) for v in value):
        value = type(value)(v.item() if isinstance(v, np.generic) else v for v in value)
    text = value if isinstance(value, str) and value.startswith("<array") else repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def finite_vector(name, value, size, bound=math.inf):
    """``value`` as a float array of shape ``(size,)``; InputError unless finite and
    ``|value| <= bound`` elementwise."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}={shown(value)}: expected {size} finite numbers") from None
    if arr.shape != (size,) or not np.all(np.isfinite(arr)):
        raise InputError(f"{name}={shown(value)}: expected {size} finite numbers")
    if np.any(np.abs(arr) > bound):
        raise InputError(f"{name}={shown(value)}: expected {size} numbers in "
                         f"[-{bound:g}, {bound:g}]")
    return arr


def finite_number(name, value, what: str = "a finite number") -> float:
    """``value`` as a finite float (not a bool); InputError naming ``name`` and ``what`` is
    allowed otherwise."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if isinstance(value, bool) or not math.isfinite(x):
        raise InputError(f"{name}={shown(value)}: expected {what}")
    return x


def number_in(name, value, low, high):
    """``value`` as a float in ``[low, high]``; InputError naming ``name`` otherwise."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if isinstance(value, bool) or not low <= x <= high:
        raise InputError(f"{name}={shown(value)}: expected a number in [{low:g}, {high:g}]")
    return x


def positive_number(name, value, allow_zero=False):
    """``value`` as a float > 0 (>= 0 with ``allow_zero``); InputError otherwise."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}={shown(value)}: expected a finite number") from None
    ok = math.isfinite(x) and (x >= 0.0 if allow_zero else x > 0.0)
    if not ok or isinstance(value, bool):
        allowed = "finite and >= 0" if allow_zero else "finite and > 0"
        raise InputError(f"{name}={shown(value)}: expected a number {allowed}")
    return x


class MissingExtra(InputError, ImportError):
    """An optional dependency (an extra such as ``orca`` or ``sweep``) that is not installed;
    the message says how to install it. An ImportError too, so ``except ImportError`` works."""


def seconds(t: float) -> str:
    """A logged time (s) as a message or a caption writes it: to the hundredth, with at least
    one decimal (4.75, not 4.8: CrowdNav plans every 0.25 s; 5.2 and 9.0, not 5.20 and 9.00)."""
    text = f"{float(t):.2f}".rstrip("0")
    return text + "0" if text.endswith(".") else text
