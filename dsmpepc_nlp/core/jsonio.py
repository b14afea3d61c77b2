"""Strict JSON of results: one sanitiser for everything the package writes or prints.

Strict JSON has no NaN or infinity and no numpy scalars. Metrics use NaN for "not applicable"
and results hold numpy numbers, so every JSON the package writes (result tables, command
output, episode metadata) goes through :func:`json_clean` first.
"""

from __future__ import annotations

import json
import math


def json_clean(value, nonfinite=None):
    """``value`` with numpy scalars made Python ones and non-finite floats replaced, recursively.

    Parameters
    ----------
    value : object
        Nested dicts, lists, tuples and scalars (dict keys become strings, tuples lists).
    nonfinite : None or callable
        What a NaN or infinity becomes: None (the default; JSON ``null``) or ``nonfinite(x)``,
        e.g. ``str`` to keep ``"inf"`` for a configuration that must read back exactly.
    """
    if hasattr(value, "item") and not isinstance(value, (list, tuple, dict, str)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None if nonfinite is None else nonfinite(value)
    if isinstance(value, dict):
        return {str(k): json_clean(v, nonfinite) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_clean(v, nonfinite) for v in value]
    return value


def dumps(value, indent=1) -> str:
    """Strict JSON (no NaN) of :func:`json_clean` ``(value)``."""
    return json.dumps(json_clean(value), indent=indent, allow_nan=False)
