"""Planner configuration: frozen, validated dataclasses whose defaults are docs/method.md's.

The cost's own fields (weights, widths, temperatures, the term table) are in
:mod:`.cost_config`, the solvers' in :mod:`.solver_config`; every field carries its unit, its
source (paper, IROS 2012 or "our choice") and its validation.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from .cost_config import CostConfig, SmoothingConfig
from .errors import MAX_SIZE, MAX_SPEED, InputError
from .loop_config import DockingConfig, StallConfig
from .terms import TERM_NAMES
from .validation import check_booleans, fail, validate_fields


@dataclass(frozen=True)
class RobotConfig:
    """Differential-drive robot: limits and footprint (docs/method.md section 1.1)."""

    v_limit: float = 1.0
    """Largest forward speed, m/s, at most ``MAX_SPEED`` (our choice; MPEPC's wheelchair ran at
    about this speed)."""
    omega_limit: float = 1.5
    """Largest turn rate magnitude, rad/s (our choice)."""
    accel_limit: float = 1.5
    """Largest change of v per second between steps, m/s^2; ``inf`` turns it off (our choice)."""
    alpha_limit: float = 3.0
    """Largest change of omega per second between steps, rad/s^2; ``inf``: off (our choice)."""
    footprint: tuple = ((0.0, 0.0, 0.3),)
    """Circles ``(cx, cy, radius)`` in the body frame, metres; one circle is a round robot."""
    reverse_limit: float = 0.3
    """Largest reversing speed, m/s, >= 0; 0: the robot never reverses. Every negative speed a
    plan commands (the stall ladder's back-up rung and its last resort) is bounded by it, so
    ``Plan.control`` lies in ``[-reverse_limit, v_limit]``. The default is the back-up rung's
    tuned speed (``StallConfig.back_up``), one plan period's braking of the default robot; a
    robot that senses nothing behind it (a 270-degree lidar) should set 0 (our choice)."""

    def __post_init__(self):
        validate_fields(self, {
            "v_limit": dict(low=0.0, low_open=True, high=MAX_SPEED),
            "omega_limit": dict(low=0.0, low_open=True),
            "accel_limit": dict(low=0.0, low_open=True, allow_inf=True),
            "alpha_limit": dict(low=0.0, low_open=True, allow_inf=True),
            "reverse_limit": dict(low=0.0, high=MAX_SPEED),
        })
        try:
            circles = tuple(tuple(float(c) for c in circle) for circle in self.footprint)
        except TypeError:
            fail("RobotConfig", "footprint", self.footprint,
                  "a sequence of (cx, cy, radius) triples")
        if not circles or any(len(c) != 3 for c in circles):
            fail("RobotConfig", "footprint", self.footprint,
                  "a non-empty sequence of (cx, cy, radius) triples")
        for cx, cy, radius in circles:
            if not all(abs(v) <= MAX_SIZE for v in (cx, cy, radius)) or not radius > 0:
                fail("RobotConfig", "footprint", self.footprint,
                      f"circles with |cx|, |cy| <= {MAX_SIZE:g} m and 0 < radius <= "
                      f"{MAX_SIZE:g} m")
        object.__setattr__(self, "footprint", circles)

    @property
    def inflation_radius(self) -> float:
        """Radius by which the map is inflated for the navigation function, m.

        The largest footprint circle: a row of circles covering a rectangle passes a corridor
        as wide as one circle, so inflating by the bounding radius would close corridors that
        the robot can drive through lengthwise.
        """
        return max(radius for _, _, radius in self.footprint)

    @property
    def bounding_radius(self) -> float:
        """Radius of the smallest origin-centred circle holding the footprint, m."""
        return max(math.hypot(cx, cy) + radius for cx, cy, radius in self.footprint)


BEHAVIOURS = ("docking", "last-resort", "moves")
"""The behaviours beyond the optimiser a planner may run (``PlannerConfig.behaviours``; what
each does: :mod:`dsmpepc_nlp.solve.behaviours.chain`)."""

IROS_RAMP = 1.2
"""IROS 2012's ``r_thresh``, m: the paper's, and the ramp of a robot without a braking limit."""


@dataclass(frozen=True)
class ControlLawConfig:
    """Gains of the smooth pose-following law (Park and Kuipers 2011; values from IROS 2012)."""

    k1: float = 1.5
    """Weight of the target orientation error in the reference heading, dimensionless."""
    k2: float = 3.0
    """Gain of the heading error, dimensionless."""
    beta: float = 0.4
    """Slow-down with curvature, ``v = v_max / (1 + beta |kappa|^lam)``, m^lam."""
    lam: float = 2.0
    """Exponent of the curvature slow-down, dimensionless."""
    r_thresh: float = IROS_RAMP
    """Distance to the target below which speed falls linearly to zero, m (IROS 2012). With
    ``r_thresh_from_robot`` on (the product's default) it is derived from the robot instead,
    and a value set here is replaced."""
    r_thresh_from_robot: bool = True
    """Our extension (off in :meth:`PlannerConfig.paper`): ``r_thresh`` is the robot's own
    ramp, ``v_limit ** 2 / accel_limit`` (0.67 m for the default robot), the shortest linear
    ramp to a stop that its braking can follow (its deceleration ``v_max ** 2 * rho /
    r_thresh ** 2`` is ``accel_limit`` where the ramp begins). IROS 2012's 1.2 m is another
    robot's: ours spent ~1.5 s on its last metre to a goal at 1.2 (docs/method.md section 1.3).
    With no acceleration limit (``accel_limit`` inf) it is IROS 2012's 1.2 m. The derived value
    is stored in ``r_thresh``: to switch the ramp off, build the law anew
    (``ControlLawConfig(r_thresh_from_robot=False)``, 1.2 m) rather than ``replace`` a derived
    one, which keeps its number (``--set control_law.r_thresh_from_robot=0`` does this)."""

    def __post_init__(self):
        validate_fields(self, {
            "k1": dict(low=0.0, low_open=True),
            "k2": dict(low=0.0, low_open=True),
            "beta": dict(low=0.0),
            "lam": dict(low=1.0),
            "r_thresh": dict(low=0.0, low_open=True),
        })
        check_booleans(self, ("r_thresh_from_robot",))


@dataclass(frozen=True)
class HorizonConfig:
    """Planning horizon (paper, section V-A: T = 5 s at 0.2 s)."""

    dt: float = 0.2
    """Step length and replanning period, s."""
    n_steps: int = 25
    """Number of steps N in the horizon."""

    def __post_init__(self):
        validate_fields(self, {"dt": dict(low=0.0, low_open=True, high=5.0)})
        if isinstance(self.n_steps, bool) or not isinstance(self.n_steps, int) or not (
            1 <= self.n_steps <= 500
        ):
            fail("HorizonConfig", "n_steps", self.n_steps, "an integer in [1, 500]")

    @property
    def duration(self) -> float:
        """Horizon length N * dt, s."""
        return self.n_steps * self.dt


@dataclass(frozen=True)
class BoundsConfig:
    """Box on ``z = (r, theta, delta, v_max)`` (IROS 2012); v_max is bounded by v_limit."""

    r_min: float = 0.05
    """Smallest target distance, m: a small positive floor keeps the law defined."""
    r_max: float = 8.0
    """Largest target distance, m."""
    theta_max: float = 1.0
    """Largest |theta|, target orientation relative to the line of sight, rad."""
    delta_max: float = 1.8
    """Largest |delta|, robot heading relative to the line of sight, rad."""

    def __post_init__(self):
        validate_fields(self, {
            "r_min": dict(low=0.0, low_open=True),
            "r_max": dict(low=0.0, low_open=True),
            "theta_max": dict(low=0.0, high=math.pi),
            "delta_max": dict(low=0.0, high=math.pi),
        })
        if self.r_max <= self.r_min:
            fail("BoundsConfig", "r_max", self.r_max, f"greater than r_min = {self.r_min}")


@dataclass(frozen=True)
class PlannerConfig:
    """Everything a planner needs. MPEPC, DS-MPEPC and the two ablations are the two switches.

    Examples
    --------
    >>> PlannerConfig.mpepc().anticipatory_pc
    False
    >>> import dataclasses
    >>> cfg = dataclasses.replace(PlannerConfig(), cost=CostConfig(s_ttc=0.3))
    """

    robot: RobotConfig = field(default_factory=RobotConfig)
    control_law: ControlLawConfig = field(default_factory=ControlLawConfig)
    horizon: HorizonConfig = field(default_factory=HorizonConfig)
    bounds: BoundsConfig = field(default_factory=BoundsConfig)
    cost: CostConfig = field(default_factory=CostConfig)
    smoothing: SmoothingConfig = field(default_factory=SmoothingConfig)
    docking: DockingConfig = field(default_factory=DockingConfig)
    stall: StallConfig = field(default_factory=StallConfig)
    anticipatory_pc: bool = True
    """DS-MPEPC's collision probability with the time-to-collision factor (paper eq. 5)."""
    terminal_cost: bool = True
    """DS-MPEPC's terminal cost on time to goal and time to collision (paper section IV-B)."""
    behaviours: tuple = BEHAVIOURS
    """The behaviours beyond the optimiser, in the order they run, each one of
    :data:`BEHAVIOURS` at most once: ``docking`` instead of the optimiser near a fixed goal,
    then on the optimiser's plan ``last-resort`` and ``moves``, the first that replaces the
    plan ending the chain (:mod:`dsmpepc_nlp.solve.behaviours.chain`; each also has its own
    fields). The paper preset names ``docking`` alone; ``()`` runs the optimiser alone."""

    def __post_init__(self):
        expected = {
            "robot": RobotConfig, "control_law": ControlLawConfig, "horizon": HorizonConfig,
            "bounds": BoundsConfig, "cost": CostConfig, "smoothing": SmoothingConfig,
            "docking": DockingConfig, "stall": StallConfig,
        }
        for name, kind in expected.items():
            if not isinstance(getattr(self, name), kind):
                fail("PlannerConfig", name, getattr(self, name), f"a {kind.__name__}")
        check_booleans(self, ("anticipatory_pc", "terminal_cost"))
        named = self.behaviours
        if isinstance(named, str) or not isinstance(named, (tuple, list)) \
                or any(not isinstance(n, str) or n not in BEHAVIOURS for n in named) \
                or len(set(named)) != len(named):
            fail("PlannerConfig", "behaviours", named,
                 f"a sequence of distinct names among {', '.join(BEHAVIOURS)}")
        object.__setattr__(self, "behaviours", tuple(named))
        law, robot = self.control_law, self.robot
        if law.r_thresh_from_robot:     # derived on every construction, replace() included
            ramp = (robot.v_limit ** 2 / robot.accel_limit if math.isfinite(robot.accel_limit)
                    else IROS_RAMP)
            if ramp != law.r_thresh:
                object.__setattr__(self, "control_law", dataclasses.replace(law, r_thresh=ramp))

    @classmethod
    def paper(cls, variant: str = "ds-mpepc", **changes) -> PlannerConfig:
        """The paper's method and values and none of our extensions (docs/method.md section
        8 lists them): ``variant`` one of :data:`VARIANTS`. The product's defaults
        (``PlannerConfig()``) add what the benchmarks showed to help (README, "Defaults")."""
        switches = VARIANTS.get(variant)
        if switches is None:
            raise InputError(f"variant = {variant!r}: must be one of {', '.join(VARIANTS)}")
        cost = changes.pop("cost", CostConfig(c_collision=0.1, sigma_static_from_map=False,
                                              sigma_dynamic_growth=0.0))
        changes.setdefault("docking", DockingConfig(arrival_radius=0.0, radius_from_reach=False,
                                                    follow=False, turn_in_place=0.0,
                                                    region_points=0,
                                                    arrival_at_tolerance=False))
        changes.setdefault("stall", StallConfig(levels=0, back_up=0.0, dodge=False,
                                                  turn_to_goal=0.0, doomed_below=0.0,
                                                  threat_until_arrival=False, passive=False))
        changes.setdefault("control_law", ControlLawConfig(r_thresh_from_robot=False))
        changes.setdefault("behaviours", ("docking",))
        return cls(anticipatory_pc=switches[0], terminal_cost=switches[1], cost=cost, **changes)

    def for_map(self, resolution: float | None) -> PlannerConfig:
        """This configuration as it plans on a map of ``resolution`` (m; None: no map): with
        ``cost.sigma_static_from_map``, ``sigma_static`` becomes the map's uncertainty
        ``sqrt(resolution^2 / 12 + localisation_std^2)``; otherwise itself. The one place that
        formula lives: the exact cost, the cycle's kernel and the graph all read it from here."""
        cost = self.cost
        if not cost.sigma_static_from_map or resolution is None:
            return self
        # Kept per instance and resolution: a planner asks every cycle for the same map.
        made = self.__dict__.setdefault("_for_map", {})
        if resolution not in made:
            sigma = math.sqrt(resolution * resolution / 12.0 + cost.localisation_std ** 2)
            made[resolution] = self if sigma == cost.sigma_static else dataclasses.replace(
                self, cost=dataclasses.replace(cost, sigma_static=sigma))
        return made[resolution]

    @classmethod
    def mpepc(cls, **changes) -> PlannerConfig:
        """MPEPC (IROS 2012): distance-only collision probability, no terminal cost."""
        return cls(anticipatory_pc=False, terminal_cost=False, **changes)

    @classmethod
    def ds_mpepc(cls, **changes) -> PlannerConfig:
        """DS-MPEPC (the paper): both switches on."""
        return cls(anticipatory_pc=True, terminal_cost=True, **changes)

    @classmethod
    def variant(cls, name: str, **changes) -> PlannerConfig:
        """One of ``mpepc``, ``ds-mpepc``, ``pc-only``, ``terminal-only``."""
        switches = VARIANTS.get(name)
        if switches is None:
            raise InputError(f"variant = {name!r}: must be one of {', '.join(VARIANTS)}")
        return cls(anticipatory_pc=switches[0], terminal_cost=switches[1], **changes)

    def cost_terms(self) -> tuple:
        """The cost terms as data: ``(name, weight, enabled)`` for each of ``TERM_NAMES``.

        Like Nav2 MPPI's critics: one name, one weight, one switch each; the terminal term is
        on only with the paper's ``terminal_cost`` switch and when not in ``cost.disabled``.
        """
        cost = self.cost
        return tuple((name, cost.weight(name), name not in cost.disabled
                      and (name != "terminal" or self.terminal_cost)) for name in TERM_NAMES)

    @property
    def variant_name(self) -> str:
        """The name of this configuration's pair of switches."""
        for name, switches in VARIANTS.items():
            if switches == (self.anticipatory_pc, self.terminal_cost):
                return name
        raise AssertionError("unreachable: every pair of switches is a variant")

    @property
    def z_lower(self) -> tuple:
        """Lower bounds on z = (r, theta, delta, v_max)."""
        b = self.bounds
        return (b.r_min, -b.theta_max, -b.delta_max, 0.0)

    @property
    def z_upper(self) -> tuple:
        """Upper bounds on z = (r, theta, delta, v_max)."""
        b = self.bounds
        return (b.r_max, b.theta_max, b.delta_max, self.robot.v_limit)

    @property
    def reach(self) -> float:
        """Farthest a trajectory goes from its start, m: horizon duration times v_limit.

        The navigation function's window holds the robot's position plus this much when the
        goal is outside the map (:func:`~dsmpepc_nlp.core.navigation.navigation_window`).
        """
        return self.horizon.duration * self.robot.v_limit


VARIANTS = {
    "mpepc": (False, False),
    "ds-mpepc": (True, True),
    "pc-only": (True, False),
    "terminal-only": (False, True),
}
"""Variant name -> (anticipatory_pc, terminal_cost)."""


@dataclass(frozen=True)
class RobotState:
    """Robot pose and measured velocity in the world frame."""

    x: float
    """Position x, m."""
    y: float
    """Position y, m."""
    phi: float
    """Heading, rad."""
    v: float = 0.0
    """Measured forward speed, m/s."""
    omega: float = 0.0
    """Measured turn rate, rad/s."""

    def __post_init__(self):
        validate_fields(self, {name: {} for name in ("x", "y", "phi", "v", "omega")})

    @property
    def pose(self) -> tuple:
        """``(x, y, phi)``."""
        return (self.x, self.y, self.phi)

    def as_array(self):
        """``[x, y, phi, v, omega]`` as a float numpy array."""
        import numpy as np

        return np.array([self.x, self.y, self.phi, self.v, self.omega], dtype=float)
