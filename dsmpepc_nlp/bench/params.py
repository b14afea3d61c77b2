"""Configuration fields named on the command line: ``s_ttc=0.25,0.5`` or ``robot.v_limit=1.5``.

``sweep --param`` and ``benchmark barn --set`` name fields of :class:`PlannerConfig` the same
way: ``part.field`` for any part, a bare name for a ``cost`` field; a switch (such as
``ttg_along_nf``) takes 0 or 1. :func:`parse_params` checks the names and numbers,
:func:`configure` builds the variant with them replaced (the configuration validates the
values).
"""

from __future__ import annotations

import dataclasses

from ..core.config import PlannerConfig
from ..core.errors import InputError

SECTIONS = ("robot", "control_law", "horizon", "bounds", "cost", "smoothing", "docking")
"""PlannerConfig parts a parameter may name as ``part.field``; a bare name is a ``cost`` field."""


def _resolve_name(name: str) -> tuple:
    section, _, field = name.rpartition(".")
    section = section or "cost"
    if section not in SECTIONS:
        raise InputError(f"--param {name!r}: section {section!r} must be one of "
                         f"{', '.join(SECTIONS)}")
    kind = type(getattr(PlannerConfig(), section))
    fields = [f.name for f in dataclasses.fields(kind)]
    if field not in fields:
        raise InputError(f"--param {name!r}: {kind.__name__} has no field {field!r} "
                         f"(fields: {', '.join(fields)})")
    return section, field


def parse_params(specs) -> dict:
    """``["s_ttc=0.25,0.5,1", "robot.v_limit=1,1.5"]`` -> ``{name: [values]}`` (floats).

    InputError naming the parameter on an unknown field, a missing ``=``, a repeated name or a
    value that is not a number.
    """
    params: dict = {}
    for spec in specs:
        name, sep, values = str(spec).partition("=")
        name = name.strip()
        if not sep or not name or not values.strip():
            raise InputError(f"--param {spec!r}: expected NAME=V1,V2,...")
        _resolve_name(name)
        if name in params:
            raise InputError(f"--param {name!r}: given twice")
        try:
            params[name] = [float(v) for v in values.split(",") if v.strip()]
        except ValueError:
            raise InputError(f"--param {spec!r}: values must be numbers") from None
    return params


def configure(params: dict, variant: str) -> PlannerConfig:
    """The variant's configuration with the parameters replaced (validated by the config)."""
    config = PlannerConfig.variant(variant)
    changes: dict = {}
    for name, value in params.items():
        section, field = _resolve_name(name)
        if section == "horizon" and field == "n_steps":
            value = int(value)
        elif isinstance(getattr(getattr(config, section), field), bool):
            if value not in (0, 1):
                raise InputError(f"--param {name}={value!r}: a switch takes 0 (off) or 1 (on)")
            value = bool(value)
        changes.setdefault(section, {})[field] = value
    parts = {s: dataclasses.replace(getattr(config, s), **c) for s, c in changes.items()}
    return dataclasses.replace(config, **parts)
