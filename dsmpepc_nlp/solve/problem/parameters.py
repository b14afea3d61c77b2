"""The configuration's numbers as one parameter block of the compiled graph.

A compiled library is keyed by the graph's structure, never by a number a user may tune: the
weights, widths, limits, gains, step length, footprint circles and smoothing temperatures enter the
graph as the ``settings`` parameter block (bound once per cycle with the rest of the world), so
that changing any of them compiles nothing. The two DS-MPEPC switches are 0/1 entries too
(``switch.anticipatory_pc`` scales ``a``, ``switch.terminal_cost`` the terminal weight: at 1 the
same numbers as the switch's form, at 0 exactly MPEPC's), so MPEPC, DS-MPEPC and the ablations
share one library; the graph then always computes the anticipatory factor and the terminal ray,
which MPEPC multiplies by 0. What stays structural (and so in the key, :func:`structure`): the
horizon's step count, the footprint's circle count, the disabled terms, and the few values at which
a formula takes another form (:data:`SPECIAL`: a smoothing temperature of 0 is the exact form; an
infinite rate limit is no limit; ``lam = 2`` squares the curvature; a footprint circle's offset of
0 leaves nothing to rotate).
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math

import numpy as np

from ...core.config import PlannerConfig
from ...core.cost_config import SmoothingConfig

SECTIONS = ("robot", "control_law", "horizon", "cost", "smoothing")
"""Sections of :class:`PlannerConfig` whose float fields the graph may read."""

SPECIAL = {"robot.accel_limit": (math.inf,), "robot.alpha_limit": (math.inf,),
           "control_law.lam": (2.0,)}
"""Values at which a formula changes form, so the value is structure (every smoothing
temperature also has one: 0, the exact form)."""

FOOTPRINT = ("cx", "cy", "radius")

SWITCHES = ("anticipatory_pc", "terminal_cost")
"""The DS-MPEPC switches, entries ``switch.NAME`` (0 or 1) of the block."""


def names(config: PlannerConfig) -> tuple:
    """The settings block's entries, in order: ``section.field`` for every float field of
    :data:`SECTIONS`, then ``footprint.i.cx|cy|radius`` for each circle, then the switches."""
    return _names(len(config.robot.footprint), SECTIONS)


@functools.lru_cache(maxsize=16)
def _names(circles: int, sections: tuple) -> tuple:
    """:func:`names` for a footprint of ``circles`` (the rest is the classes' fields): once."""
    out, default = [], PlannerConfig()
    for section in sections:
        for field in dataclasses.fields(getattr(default, section)):
            if field.type == "float":
                out.append(f"{section}.{field.name}")
    for i in range(circles):
        out.extend(f"footprint.{i}.{part}" for part in FOOTPRINT)
    out.extend(f"switch.{name}" for name in SWITCHES)
    return tuple(out)


def _value(config: PlannerConfig, name: str) -> float:
    head, *rest = name.split(".")
    if head == "switch":
        return float(getattr(config, rest[0]))
    if head == "footprint":
        return config.robot.footprint[int(rest[0])][FOOTPRINT.index(rest[1])]
    return getattr(getattr(config, head), rest[0])


def values(config: PlannerConfig) -> np.ndarray:
    """The settings block of ``config`` (float64, in :func:`names` order)."""
    return np.array([float(_value(config, name)) for name in names(config)])


def is_special(name: str, value) -> bool:
    """True where ``value`` of entry ``name`` is structure (see :data:`SPECIAL`)."""
    if name.startswith("smoothing."):
        return value == 0
    if name.startswith("footprint.") and not name.endswith(".radius"):
        return value == 0      # a circle on the body's axis or centre: no offset to rotate
    return value in SPECIAL.get(name, ())


def _own_smoothing(config: PlannerConfig, smoothing) -> bool:
    """True when the graph's temperatures are the configuration's (they are then parameters);
    an override (e.g. :meth:`SmoothingConfig.exact`) is built in as constants."""
    return smoothing is None or smoothing == config.smoothing


def structure(config: PlannerConfig, smoothing: SmoothingConfig | None = None) -> tuple:
    """What of ``config`` (and a smoothing override) shapes the graph: the key of a compiled
    library, with every number that is a parameter left out."""
    own = _own_smoothing(config, smoothing)
    special = tuple((name, _value(config, name)) for name in names(config)
                    if is_special(name, _value(config, name))
                    and (own or not name.startswith("smoothing.")))
    baked = None if own else dataclasses.astuple(smoothing)
    cost = config.cost
    return ("settings-v3", names(config), config.horizon.n_steps, tuple(cost.disabled),
            special, baked)


def symbolic(config: PlannerConfig, settings, smoothing: SmoothingConfig | None = None):
    """``(config, smoothing)`` whose parameter numbers are entries of ``settings`` (a CasADi
    vector in :func:`names` order); special values stay numbers.

    The copies are not validated (their fields are symbols) and live only while a graph is
    built. ``bounds``, ``docking`` and ``stall`` are None: the graph must not read them, and a
    read fails loudly instead of building a number into the library.
    """
    index = {name: i for i, name in enumerate(names(config))}

    def entry(name, value):
        return value if is_special(name, value) else settings[index[name]]

    sections = {}
    for section in SECTIONS:
        original = getattr(config, section)
        mirror = copy.copy(original)
        for field in dataclasses.fields(original):
            if field.type == "float":
                name = f"{section}.{field.name}"
                object.__setattr__(mirror, field.name, entry(name, getattr(original, field.name)))
        sections[section] = mirror
    footprint = tuple(tuple(entry(f"footprint.{i}.{part}", value)
                            for part, value in zip(FOOTPRINT, circle))
                      for i, circle in enumerate(config.robot.footprint))
    object.__setattr__(sections["robot"], "footprint", footprint)
    # The switches as factors: on, the switch's own numbers (a * 1 and w * 1 are a and w to
    # the bit); off, the factor 1 - 0 * a * e = 1 and the terminal term 0 * raw = 0 exactly.
    cost = sections["cost"]
    object.__setattr__(cost, "a", cost.a * settings[index["switch.anticipatory_pc"]])
    object.__setattr__(cost, "w_terminal",
                       cost.w_terminal * settings[index["switch.terminal_cost"]])
    mirror = copy.copy(config)
    object.__setattr__(mirror, "anticipatory_pc", True)
    object.__setattr__(mirror, "terminal_cost", True)
    for section, value in sections.items():
        object.__setattr__(mirror, section, value)
    object.__setattr__(mirror, "bounds", None)
    object.__setattr__(mirror, "docking", None)
    object.__setattr__(mirror, "stall", None)
    own = _own_smoothing(config, smoothing)
    return mirror, (sections["smoothing"] if own else smoothing)


__all__ = ["SECTIONS", "SPECIAL", "is_special", "names", "structure", "symbolic", "values"]
