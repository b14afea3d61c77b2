"""The package's one exception type for bad input, and the small checks that raise it."""

import math

import numpy as np


class InputError(ValueError):
    """Bad input: the message names the source (file), the field, the value and what is allowed.

    A ``ValueError``, so ``except ValueError`` keeps working; the command line prints it on one
    line and exits with status 2.
    """


def finite_vector(name, value, size):
    """``value`` as a float array of shape ``(size,)``; InputError unless finite."""
    arr = np.array(value, dtype=float)
    if arr.shape != (size,) or not np.all(np.isfinite(arr)):
        raise InputError(f"{name}={value!r}: expected {size} finite numbers")
    return arr


def positive_number(name, value, allow_zero=False):
    """``value`` as a float > 0 (>= 0 with ``allow_zero``); InputError otherwise."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}={value!r}: expected a finite number") from None
    ok = math.isfinite(x) and (x >= 0.0 if allow_zero else x > 0.0)
    if not ok or isinstance(value, bool):
        allowed = "finite and >= 0" if allow_zero else "finite and > 0"
        raise InputError(f"{name}={value!r}: expected a number {allowed}")
    return x


class MissingExtra(InputError, ImportError):
    """An optional dependency (an extra such as ``orca`` or ``sweep``) that is not installed;
    the message says how to install it. An ImportError too, so ``except ImportError`` works."""
