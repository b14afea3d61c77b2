"""The cost's configuration: the weights and widths of the MPEPC / DS-MPEPC cost (its terms
are :mod:`.terms`) and the smoothing temperatures of its smooth form."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from .terms import TERM_NAMES, TERMS
from .validation import check_booleans, fail, validate_fields


@dataclass(frozen=True)
class CostConfig:
    """Weights and widths of the MPEPC / DS-MPEPC cost (docs/method.md sections 3-5)."""

    sigma_static: float = 0.1
    """Width of the collision-probability bell for the map, m (IROS 2012)."""
    sigma_dynamic: float = 0.2
    """Width of the collision-probability bell for moving objects now, m (IROS 2012)."""
    sigma_dynamic_growth: float = 0.0
    """Growth of that width with the look-ahead t, m/s: the bell at a pose t seconds ahead is
    ``sigma_dynamic + sigma_dynamic_growth * t`` wide (:func:`~dsmpepc_nlp.core.costs.
    dynamic_sigma`; docs/method.md section 3.2). An extension of ours, off (the paper's constant
    width): the constant-velocity prediction's error does grow with t (0.15-0.18 m per second
    of look-ahead, RMS per axis, on ETH/UCY's eth and hotel), but a bell that wide lost on
    CrowdNav's tuning episodes (docs/experiments/2026-11-25-robots-that-get-there.md)."""
    c_heading: float = 0.2
    """Weight of the terminal heading error against the NF descent direction, 1/rad (IROS 2012)."""
    c_v: float = 0.2
    """Action weight on v^2, s/m^2 per second of horizon (IROS 2012)."""
    c_w: float = 0.1
    """Action weight on omega^2, s/rad^2 per second of horizon (IROS 2012)."""
    c_collision: float = 0.3
    """Cost of a collision per step, weighted by 1 - survivability. IROS 2012 and the paper:
    0.1 (:meth:`PlannerConfig.paper`); ours 0.3, chosen on CrowdNav's tuning episodes: at 0.1
    the term weighs little against progress, and the robot took passes that people then walked
    into (docs/method.md section 8, docs/experiments/2026-11-25-heavier-collision-weight.md)."""
    w_progress: float = 1.0
    """Weight of the progress term (the paper: 1; docs/method.md section 5.3)."""
    w_action: float = 1.0
    """Weight of the action term on top of ``c_v`` and ``c_w`` (the paper: 1; docs/method.md
    section 5.3)."""
    w_terminal: float = 1.0
    """Weight of the terminal term (the paper: 1); counted only with ``terminal_cost``."""
    disabled: tuple = ()
    """Names of terms switched off (their breakdown entry is 0): any of ``TERM_NAMES``."""
    a: float = 0.7
    """Largest reduction of the collision probability by the anticipatory factor (paper)."""
    s_ttc: float = 0.5
    """Width sigma_{1/TTC} of the inverse time-to-collision bells, 1/s (paper)."""
    s_ttg: float = 1e-3
    """Width sigma_{1/TTG} of the inverse time-to-goal bell, 1/s (paper)."""
    sigma_static_from_map: bool = True
    """Our extension, not the paper's (on by default, off in :meth:`PlannerConfig.paper`): with
    a map, the static bell's width is the uncertainty of the distance the planner reads,
    ``sqrt(resolution^2 / 12 + localisation_std^2)`` (the map's quantisation, a uniform error
    over a cell, and the robot's localisation), instead of ``sigma_static``, a constant from
    another robot's office map (docs/method.md section 3.2). BARN's 300 worlds: success 0.66 ->
    0.98, no collision (docs/experiments/2026-11-24-static-bell-from-the-map.md)."""
    localisation_std: float = 0.03
    """Standard deviation of the robot's position on the map, m (with
    ``sigma_static_from_map``): a 2-D lidar's localisation on an indoor map (our choice)."""
    ttc_range: float = 8.0
    """Range of the static time-to-collision ray march, m: beyond it 1/TTC = 0 (our choice)."""
    def __post_init__(self):
        positive = dict(low=0.0, low_open=True)
        validate_fields(self, {
            "sigma_static": positive,
            "sigma_dynamic": positive,
            "sigma_dynamic_growth": dict(low=0.0),
            "c_heading": dict(low=0.0),
            "c_v": dict(low=0.0),
            "c_w": dict(low=0.0),
            "c_collision": dict(low=0.0),
            "a": dict(low=0.0, high=1.0),
            "s_ttc": positive,
            "s_ttg": positive,
            "ttc_range": positive,
            "localisation_std": dict(low=0.0),
            "w_progress": dict(low=0.0),
            "w_action": dict(low=0.0),
            "w_terminal": dict(low=0.0),
        })
        check_booleans(self, ("sigma_static_from_map",))
        try:
            disabled = tuple(self.disabled) if not isinstance(self.disabled, str) else None
        except TypeError:
            disabled = None
        if disabled is None or any(name not in TERM_NAMES for name in disabled):
            fail("CostConfig", "disabled", self.disabled,
                  f"a sequence of term names from {', '.join(TERM_NAMES)}")
        object.__setattr__(self, "disabled", disabled)

    def weight(self, name: str) -> float:
        """The weight of term ``name``: the field its :class:`~.terms.Term` names."""
        return getattr(self, next(term.weight for term in TERMS if term.name == name))


@dataclass(frozen=True)
class SmoothingConfig:
    """Temperatures of the smooth stand-ins used by the NLP, each in the unit of what it smooths.

    0 everywhere gives the exact cost; the NLP graph uses these values. See ``smooth.py``.
    """

    distance: float = 0.02
    """Soft-min / soft-clip temperature for distances, m."""
    speed: float = 0.02
    """Relative soft-min temperature for the speed caps of the law, dimensionless
    (the smooth speed is within a factor 2^-t of the exact one)."""
    acceleration: float = 0.01
    """Soft-clip temperature of the acceleration limit, m/s."""
    rate: float = 0.02
    """Soft-clip temperature of the turn-rate-change limit, rad/s."""
    curvature: float = 0.01
    """Smoothing of |kappa| in the omega limit, 1/m."""
    inverse_time: float = 0.02
    """Soft-clip temperature for inverse times 1/TTC and 1/TTG, 1/s."""
    angle: float = 0.01
    """Smoothing of the |sin| in the heading error, dimensionless."""

    def __post_init__(self):
        validate_fields(self, {name.name: dict(low=0.0) for name in dataclasses.fields(self)})

    @classmethod
    def exact(cls) -> SmoothingConfig:
        """All temperatures 0: the exact (non-smooth) forms."""
        return cls(**{f.name: 0.0 for f in dataclasses.fields(cls)})

    def scaled(self, factor: float) -> SmoothingConfig:
        """Every temperature times ``factor`` (for convergence studies)."""
        return dataclasses.replace(
            self, **{f.name: getattr(self, f.name) * factor for f in dataclasses.fields(self)}
        )
