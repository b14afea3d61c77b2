"""Configuration fields named on the command line: ``s_ttc=0.25,0.5`` or ``robot.v_limit=1.5``.

``sweep --param`` and ``benchmark barn --set`` name fields of :class:`PlannerConfig` the same
way: ``part.field`` for any part, a bare name for a ``cost`` field; a switch (such as
``sigma_static_from_map``) takes 0 or 1. :func:`parse_params` checks the names and numbers,
:func:`configure` builds the variant with them replaced (the configuration validates the
values). ``bench --ipopt-option KEY=VALUE`` names IPOPT options the same way
(:func:`parse_ipopt_options`).
"""

from __future__ import annotations

import dataclasses

from ..core.config import IROS_RAMP, PlannerConfig
from ..core.errors import InputError
from ..core.solver_config import SolverConfig

SECTIONS = ("robot", "control_law", "horizon", "bounds", "cost", "smoothing", "docking",
            "stall")
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


def overrides(specs) -> tuple:
    """``--set NAME=VALUE`` pairs; each name once, with one value."""
    params = parse_params(specs)
    for name, values in params.items():
        if len(values) != 1:
            raise InputError(f"--set {name}: give one value, not {len(values)}")
    return tuple((name, values[0]) for name, values in params.items())


def named_solver(name: str, n_samples: int | None = None, time_budget="auto"):
    """``SolverConfig.named(name)`` with ``n_samples`` replaced when given and the plans'
    ``time_budget``: the solver every benchmark's ``--solver``, ``--samples`` and
    ``--time-budget`` name."""
    solver = dataclasses.replace(SolverConfig.named(name), time_budget=time_budget)
    return dataclasses.replace(solver, n_samples=n_samples) if n_samples else solver


def solver_of(settings):
    """The solver a benchmark's ``settings`` name (their ``solver``, ``n_samples`` and
    ``time_budget``: :func:`named_solver`)."""
    return named_solver(settings.solver, settings.n_samples, settings.time_budget)


def robot_with(robot, pairs: tuple):
    """``robot`` (a :class:`RobotConfig`: a benchmark's own body, which the simulator puts in
    place of the configuration's) with the ``robot.*`` fields of the ``--set`` pairs replaced,
    so that ``--set robot.v_limit=0.5`` reaches the robot that drives (validated by the
    config)."""
    fields = {name.split(".", 1)[1]: value for name, value in pairs if name.startswith("robot.")}
    return dataclasses.replace(robot, **fields) if fields else robot


def config_meta(preset: str, pairs: tuple, sensing: str = "oracle",
                time_budget="auto") -> dict:
    """What a benchmark table stores of its configuration: the preset, the ``--set`` pairs,
    the sensing profile (``--sensing``) and the plans' time budget (``--time-budget``), each
    only when given (tables written before any existed keep their meaning)."""
    meta = {} if preset == "product" else {"preset": preset}
    if time_budget != "auto":
        meta["time_budget"] = "none" if time_budget is None else float(time_budget)
    if pairs:
        meta["overrides"] = {k: v for k, v in pairs}
    if sensing != "oracle":
        meta["sensing"] = sensing
    return meta


PRESETS = ("product", "paper")
"""``product``: the package's defaults (``PlannerConfig.variant``); ``paper``: the paper's values
and none of our extensions (``PlannerConfig.paper``)."""


def preset_config(preset: str, variant: str) -> PlannerConfig:
    """The configuration of ``variant`` under ``preset`` (one of :data:`PRESETS`)."""
    if preset not in PRESETS:
        raise InputError(f"--preset {preset!r}: must be one of {', '.join(PRESETS)}")
    return PlannerConfig.paper(variant) if preset == "paper" else PlannerConfig.variant(variant)


def configure(params: dict, variant: str, preset: str = "product") -> PlannerConfig:
    """The variant's configuration under ``preset`` with the parameters replaced (validated by
    the config)."""
    return replaced(preset_config(preset, variant), params)


def replaced(config: PlannerConfig, params: dict) -> PlannerConfig:
    """``config`` with the parameters ``{name: value}`` replaced (validated by the config)."""
    changes: dict = {}
    for name, value in params.items():
        section, field = _resolve_name(name)
        current = getattr(getattr(config, section), field)
        if isinstance(current, bool):
            if value not in (0, 1):
                raise InputError(f"--param {name}={value!r}: a switch takes 0 (off) or 1 (on)")
            value = bool(value)
        elif isinstance(current, int):
            if value != int(value):
                raise InputError(f"--param {name}={value!r}: must be a whole number")
            value = int(value)
        changes.setdefault(section, {})[field] = value
    parts = {s: dataclasses.replace(getattr(config, s), **c) for s, c in changes.items()}
    law_changes = changes.get("control_law", {})
    law = parts.get("control_law", config.control_law)
    if "r_thresh" in law_changes and law.r_thresh_from_robot:
        raise InputError(f"--param control_law.r_thresh={law.r_thresh!r}: the ramp is derived "
                         "from the robot (v_limit^2 / accel_limit) while "
                         "control_law.r_thresh_from_robot is on; set that to 0 as well")
    if config.control_law.r_thresh_from_robot and not law.r_thresh_from_robot \
            and "r_thresh" not in law_changes:    # switched off: IROS 2012's, not the derived
        parts["control_law"] = dataclasses.replace(law, r_thresh=IROS_RAMP)
    return dataclasses.replace(config, **parts)


def planner_config(settings, variant: str) -> PlannerConfig:
    """The configuration a benchmark's ``settings`` (with ``preset`` and ``overrides``, the
    ``--preset`` and ``--set`` of its command) give ``variant``: the one door of every table."""
    return configure(dict(settings.overrides), variant, settings.preset)


def parse_ipopt_options(specs) -> tuple:
    """``("ipopt.KEY", value)`` pairs from ``KEY=VALUE`` strings (numbers parsed), each
    checked by building a one-variable IPOPT problem with it."""
    import casadi as ca

    pairs = []
    for spec in specs:
        key, sep, text = spec.partition("=")
        if not sep or not key.strip() or not text.strip():
            raise InputError(f"bench --ipopt-option = {spec!r}: must be KEY=VALUE "
                             "(e.g. max_soc=4)")
        value = text.strip()
        for kind in (int, float):
            try:
                value = kind(value)
                break
            except ValueError:
                continue
        pairs.append((f"ipopt.{key.strip()}", value))
    if pairs:
        x = ca.MX.sym("x")
        try:
            ca.nlpsol("check", "ipopt", {"x": x, "f": x * x},
                      {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
                       **dict(pairs)})
        except RuntimeError as error:
            raise InputError(f"bench --ipopt-option = {specs!r}: IPOPT rejects it "
                             f"({str(error).strip().splitlines()[-1][:160]})") from None
    return tuple(pairs)
