"""Checks of configuration fields: a bad value raises an InputError naming the class, the
field, the value and what is allowed."""

from __future__ import annotations

import math

from .errors import InputError, shown


def fail(owner: str, name: str, value, allowed: str) -> None:
    raise InputError(f"{owner}.{name} = {shown(value)}: must be {allowed}")


def finite(owner, name, value, *, low=-math.inf, high=math.inf, low_open=False, allow_inf=False):
    """Check a real number against an interval; raise InputError naming the field otherwise."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        fail(owner, name, value, "a real number")
    if math.isnan(number) or (math.isinf(number) and not allow_inf):
        allowed = "a number or inf, not NaN" if allow_inf else "a finite number"
        fail(owner, name, value, allowed)
    too_low = number <= low if low_open else number < low
    if too_low or number > high:
        left = "(" if low_open else "["
        fail(owner, name, value, f"in {left}{low}, {high}]")
    return number


def check_integers(instance, lows: dict) -> None:
    """Each field of ``lows`` an integer (not a bool) of at least its low; None passes for a
    field whose low is given as ``(low, None)``, meaning the field may be left unset."""
    owner = type(instance).__name__
    for name, low in lows.items():
        value = getattr(instance, name)
        if isinstance(low, tuple):
            if value is None:
                continue
            low = low[0]
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            fail(owner, name, value, f"an integer >= {low}")


def check_booleans(instance, names) -> None:
    """Each field of ``names`` True or False (not 0, 1 or a string)."""
    for name in names:
        if not isinstance(getattr(instance, name), bool):
            fail(type(instance).__name__, name, getattr(instance, name), "True or False")


def validate_fields(instance, rules: dict) -> None:
    owner = type(instance).__name__
    for name, kwargs in rules.items():
        object.__setattr__(instance, name, finite(owner, name, getattr(instance, name), **kwargs))
