"""Planner configuration: frozen, validated dataclasses whose defaults are docs/method.md's.

Longer than the usual 400 lines: every tunable value of the method and of the solvers is a field
here, with its unit, its source (paper, IROS 2012 or "our choice") and its validation, so that
one file answers "what are the defaults and where do they come from".
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from .errors import MAX_SIZE, MAX_SPEED, InputError, shown


def _fail(owner: str, name: str, value, allowed: str) -> None:
    raise InputError(f"{owner}.{name} = {shown(value)}: must be {allowed}")


def _finite(owner, name, value, *, low=-math.inf, high=math.inf, low_open=False, allow_inf=False):
    """Check a real number against an interval; raise InputError naming the field otherwise."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        _fail(owner, name, value, "a real number")
    if math.isnan(number) or (math.isinf(number) and not allow_inf):
        allowed = "a number or inf, not NaN" if allow_inf else "a finite number"
        _fail(owner, name, value, allowed)
    too_low = number <= low if low_open else number < low
    if too_low or number > high:
        left = "(" if low_open else "["
        _fail(owner, name, value, f"in {left}{low}, {high}]")
    return number


def _validate_fields(instance, rules: dict) -> None:
    owner = type(instance).__name__
    for name, kwargs in rules.items():
        object.__setattr__(instance, name, _finite(owner, name, getattr(instance, name), **kwargs))


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

    def __post_init__(self):
        _validate_fields(self, {
            "v_limit": dict(low=0.0, low_open=True, high=MAX_SPEED),
            "omega_limit": dict(low=0.0, low_open=True),
            "accel_limit": dict(low=0.0, low_open=True, allow_inf=True),
            "alpha_limit": dict(low=0.0, low_open=True, allow_inf=True),
        })
        try:
            circles = tuple(tuple(float(c) for c in circle) for circle in self.footprint)
        except TypeError:
            _fail("RobotConfig", "footprint", self.footprint,
                  "a sequence of (cx, cy, radius) triples")
        if not circles or any(len(c) != 3 for c in circles):
            _fail("RobotConfig", "footprint", self.footprint,
                  "a non-empty sequence of (cx, cy, radius) triples")
        for cx, cy, radius in circles:
            if not all(abs(v) <= MAX_SIZE for v in (cx, cy, radius)) or not radius > 0:
                _fail("RobotConfig", "footprint", self.footprint,
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
    r_thresh: float = 1.2
    """Distance to the target below which speed falls linearly to zero, m."""

    def __post_init__(self):
        _validate_fields(self, {
            "k1": dict(low=0.0, low_open=True),
            "k2": dict(low=0.0, low_open=True),
            "beta": dict(low=0.0),
            "lam": dict(low=1.0),
            "r_thresh": dict(low=0.0, low_open=True),
        })


@dataclass(frozen=True)
class HorizonConfig:
    """Planning horizon (paper, section V-A: T = 5 s at 0.2 s)."""

    dt: float = 0.2
    """Step length and replanning period, s."""
    n_steps: int = 25
    """Number of steps N in the horizon."""

    def __post_init__(self):
        _validate_fields(self, {"dt": dict(low=0.0, low_open=True, high=5.0)})
        if isinstance(self.n_steps, bool) or not isinstance(self.n_steps, int) or not (
            1 <= self.n_steps <= 500
        ):
            _fail("HorizonConfig", "n_steps", self.n_steps, "an integer in [1, 500]")

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
        _validate_fields(self, {
            "r_min": dict(low=0.0, low_open=True),
            "r_max": dict(low=0.0, low_open=True),
            "theta_max": dict(low=0.0, high=math.pi),
            "delta_max": dict(low=0.0, high=math.pi),
        })
        if self.r_max <= self.r_min:
            _fail("BoundsConfig", "r_max", self.r_max, f"greater than r_min = {self.r_min}")


TERM_NAMES = ("progress", "action", "collision", "heading", "terminal")
"""The cost terms, in the order of docs/method.md section 5.3."""
TERM_WEIGHTS = {"progress": "w_progress", "action": "w_action", "collision": "c_collision",
                "heading": "c_heading", "terminal": "w_terminal"}
"""Each term's weight field in :class:`CostConfig`."""


@dataclass(frozen=True)
class CostConfig:
    """Weights and widths of the MPEPC / DS-MPEPC cost (docs/method.md sections 3-5)."""

    sigma_static: float = 0.1
    """Width of the collision-probability bell for the map, m (IROS 2012)."""
    sigma_dynamic: float = 0.2
    """Width of the collision-probability bell for moving objects, m (IROS 2012)."""
    c_heading: float = 0.2
    """Weight of the terminal heading error against the NF descent direction, 1/rad (IROS 2012)."""
    c_v: float = 0.2
    """Action weight on v^2, s/m^2 per second of horizon (IROS 2012)."""
    c_w: float = 0.1
    """Action weight on omega^2, s/rad^2 per second of horizon (IROS 2012)."""
    c_collision: float = 0.1
    """Cost of a collision per step, weighted by 1 - survivability (IROS 2012)."""
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
    0.98, no collision (docs/results.md)."""
    localisation_std: float = 0.03
    """Standard deviation of the robot's position on the map, m (with
    ``sigma_static_from_map``): a 2-D lidar's localisation on an indoor map (our choice)."""
    ttc_range: float = 8.0
    """Range of the static time-to-collision ray march, m: beyond it 1/TTC = 0 (our choice)."""
    ttg_along_nf: bool = False
    """Our extension, not the paper's (default off): measure the terminal time to goal along the
    navigation function, ``TTG = NF(p_N) / (v_N u . e)`` with ``e`` the unit NF descent
    direction at the horizon's end, instead of the straight line ``|g - p_N| / (v_N u . g^)``.
    Why: the straight line measures through walls. Behind a wall it calls a trajectory that
    drives along the only route 'not approaching the goal' (``C_TTG = 1``, the terminal reward a
    stop facing free space also earns, docs/method.md section 5.4) and one facing the wall
    'approaching' it; the NF measures the route the robot will drive, as the progress term does
    (:func:`~dsmpepc_nlp.core.costs.inverse_ttg_along_nf`). Without a map both are the same."""

    def __post_init__(self):
        positive = dict(low=0.0, low_open=True)
        _validate_fields(self, {
            "sigma_static": positive,
            "sigma_dynamic": positive,
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
        for name in ("ttg_along_nf", "sigma_static_from_map"):
            if not isinstance(getattr(self, name), bool):
                _fail("CostConfig", name, getattr(self, name), "True or False")
        try:
            disabled = tuple(self.disabled) if not isinstance(self.disabled, str) else None
        except TypeError:
            disabled = None
        if disabled is None or any(name not in TERM_NAMES for name in disabled):
            _fail("CostConfig", "disabled", self.disabled,
                  f"a sequence of term names from {', '.join(TERM_NAMES)}")
        object.__setattr__(self, "disabled", disabled)

    def weight(self, name: str) -> float:
        """The weight of term ``name``: ``w_progress``, ``w_action``, ``c_collision``,
        ``c_heading`` or ``w_terminal``."""
        return getattr(self, TERM_WEIGHTS[name])


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
        _validate_fields(self, {name.name: dict(low=0.0) for name in dataclasses.fields(self)})

    @classmethod
    def exact(cls) -> SmoothingConfig:
        """All temperatures 0: the exact (non-smooth) forms."""
        return cls(**{f.name: 0.0 for f in dataclasses.fields(cls)})

    def scaled(self, factor: float) -> SmoothingConfig:
        """Every temperature times ``factor`` (for convergence studies)."""
        return dataclasses.replace(
            self, **{f.name: getattr(self, f.name) * factor for f in dataclasses.fields(self)}
        )


@dataclass(frozen=True)
class DockingConfig:
    """Docking near a fixed goal (IROS 2012, docs/method.md section 7.1)."""

    radius: float = 2.0
    """Within this distance of a fixed goal the target pose is the goal itself, m (IROS 2012);
    see ``radius_from_reach``."""
    radius_from_reach: bool = True
    """Our extension (off in :meth:`PlannerConfig.paper`): dock within the horizon's reach,
    ``v_limit * n_steps * dt`` (5 m by default), or ``radius`` if that is larger. Once the goal
    is within reach, every trajectory that arrives by the horizon's end earns the same
    progress, and the action cost then prefers the slowest of them: a robot that does not
    dock slows down to arrive just as the horizon ends (docs/method.md section 7.1)."""
    min_survival: float = 0.9
    """Dock only while the docking trajectory's survivability is above this (our choice)."""
    arrival_radius: float = 0.1
    """Our extension (0 in :meth:`PlannerConfig.paper`): the docking trajectory's survivability
    is read where it first comes within this distance of the goal, m, not at the horizon's end.
    Standing at the goal after arriving is the next task's risk, and counting it kept robots
    short of a goal with a person standing beside it (docs/method.md section 7.1). 0: read at
    the horizon's end."""

    def __post_init__(self):
        _validate_fields(self, {"radius": dict(low=0.0), "min_survival": dict(low=0.0, high=1.0),
                                "arrival_radius": dict(low=0.0)})
        if not isinstance(self.radius_from_reach, bool):
            _fail("DockingConfig", "radius_from_reach", self.radius_from_reach, "True or False")


@dataclass(frozen=True)
class StallConfig:
    """The planner's stall monitor and its escalation ladder (our extension, docs/method.md
    section 7.5; off in :meth:`PlannerConfig.paper`).

    A robot that moved less than ``min_displacement`` over its last ``window`` of plans while
    farther than ``docking.arrival_radius`` from its goal is stalled; each such window raises
    the ladder one level, up to ``levels``, and level ``k`` plans with the progress weight
    times ``gain ** k``: progress is worth more of the risk the cost weighs it against. A
    window with progress puts the ladder back to 0. The simulator's deadlock rule does not
    know of it: a robot the ladder cannot free still deadlocks.
    """

    window: float = 2.0
    """Stall window, s, counted in plans of ``horizon.dt`` each (our choice: a fifth of the
    simulator's 10 s deadlock window, so the ladder's levels come well before it)."""
    min_displacement: float = 0.2
    """Least net displacement over the window, m, of a robot that is not stalled: the
    simulator's deadlock rate (1 m in 10 s), so a robot slower than what that rule calls
    stuck escalates long before the rule fires (our choice)."""
    levels: int = 3
    """The ladder's highest level; 0 turns the monitor off."""
    gain: float = 2.0
    """Level ``k`` multiplies the progress weight by ``gain ** k``."""

    def __post_init__(self):
        _validate_fields(self, {"window": dict(low=0.0, low_open=True),
                                "min_displacement": dict(low=0.0, low_open=True),
                                "gain": dict(low=1.0)})
        if isinstance(self.levels, bool) or not isinstance(self.levels, int) or self.levels < 0:
            _fail("StallConfig", "levels", self.levels, "an integer >= 0")

    def progress_gain(self, level: int) -> float:
        """The progress weight's factor at ``level`` (1 at level 0)."""
        return self.gain ** level


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

    def __post_init__(self):
        expected = {
            "robot": RobotConfig, "control_law": ControlLawConfig, "horizon": HorizonConfig,
            "bounds": BoundsConfig, "cost": CostConfig, "smoothing": SmoothingConfig,
            "docking": DockingConfig, "stall": StallConfig,
        }
        for name, kind in expected.items():
            if not isinstance(getattr(self, name), kind):
                _fail("PlannerConfig", name, getattr(self, name), f"a {kind.__name__}")
        for name in ("anticipatory_pc", "terminal_cost"):
            if not isinstance(getattr(self, name), bool):
                _fail("PlannerConfig", name, getattr(self, name), "True or False")

    @classmethod
    def paper(cls, variant: str = "ds-mpepc", **changes) -> PlannerConfig:
        """The paper's method and values and none of our extensions (docs/method.md section
        8 lists them): ``variant`` one of :data:`VARIANTS`. The product's defaults
        (``PlannerConfig()``) add what the benchmarks showed to help (README, "Defaults")."""
        switches = VARIANTS.get(variant)
        if switches is None:
            raise InputError(f"variant = {variant!r}: must be one of {', '.join(VARIANTS)}")
        cost = changes.pop("cost", CostConfig(sigma_static_from_map=False, ttg_along_nf=False))
        changes.setdefault("docking", DockingConfig(arrival_radius=0.0, radius_from_reach=False))
        changes.setdefault("stall", StallConfig(levels=0))
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
        _validate_fields(self, {name: {} for name in ("x", "y", "phi", "v", "omega")})

    @property
    def pose(self) -> tuple:
        """``(x, y, phi)``."""
        return (self.x, self.y, self.phi)

    def as_array(self):
        """``[x, y, phi, v, omega]`` as a float numpy array."""
        import numpy as np

        return np.array([self.x, self.y, self.phi, self.v, self.omega], dtype=float)


SOLVER_METHODS = ("ipopt", "newton", "sampling")


SOLVER_NAMES = ("nlp", "fast", "sampling")
"""The solvers by name, as on the command line (:meth:`SolverConfig.named`): the one list."""


@dataclass(frozen=True)
class SolverConfig:
    """How a plan is searched for: the NLP plugin and its options, or the sampling planner.

    ``SolverConfig()`` is IPOPT (default), ``SolverConfig.fast()`` the fast NLP configuration,
    ``SolverConfig.sampling()`` the batched exact-cost sampler alone.
    """

    method: str = "ipopt"
    """``ipopt`` (CasADi ``nlpsol`` on the compiled graph), ``newton`` (our trust-region Newton
    on the 4-D box over the same compiled graph) or ``sampling``."""
    max_iter: int = 40
    """Iteration limit per start."""
    tol: float = 1e-5
    """Convergence tolerance passed to the plugin."""
    options: tuple = ()
    """Extra ``(key, value)`` pairs for ``casadi.nlpsol`` (plugin options as ``"ipopt.key"``)."""
    n_spread: int = 4
    """Starts spread over the z box in addition to the structured ones."""
    n_samples: int = 4096
    """Samples of z for the sampling planner (low-discrepancy)."""
    seed: int = 0
    """Seed of the low-discrepancy sequence and of the spread starts."""
    pair_budget: int = 2_000_000
    """Largest (trajectory, pose, footprint circle, obstacle circle) count the numpy exact cost
    handles in one chunk: keeps its temporaries near 100 MB however crowded the world."""
    parallel_rows: int = 64
    """Smallest batch the compiled exact evaluator spreads over every core; smaller batches run
    on the calling thread, where waking the thread pool would cost more than it saves."""
    n_screen: int = 256
    """Low-discrepancy z costed exactly with the named starts before any solve (the landscape
    is multimodal: the NLP only runs from the best of them)."""
    n_solved: int = 3
    """Starts the NLP runs from (the warm start, then the best distinct others); fewer lost
    BARN worlds (docs/nlp.md, "Pass 8")."""
    solve_threads: int = 2
    """Threads the solves of one plan run on at once (IPOPT: each with its own ``nlpsol``,
    which releases Python's lock while it runs; ``newton``: its compiled loop, which does too);
    1 runs them one after another. Every solve is the same whatever the count; only the
    plan's wall time changes. Two is this project's 2-core reference machine."""
    distinct: float = 0.05
    """Two starts closer than this share of the box (max norm) count as one."""
    fd_step: float = 1e-6
    """Forward-difference step of the Hessian of the gradient, as a share of each variable's
    range (``hessian="differences"``)."""
    hessian: str = "quasi-newton"
    """The Hessian the solvers use: ``quasi-newton`` (gradients only: IPOPT's limited-memory
    update; for ``newton`` symmetric rank-one updates started from the differences),
    ``differences`` of the compiled gradient (4 more gradients per Hessian) or ``exact``
    (compiled forward over reverse; minutes to compile, no faster than the differences)."""
    pose_object_buckets: tuple = (0, 4, 12)
    """Object counts the graph is compiled for at every pose; a cycle uses the smallest that
    holds the objects in its reach (the largest when none does). Each is compiled on first
    use and cached."""
    polish_rounds: int = 8
    """Rounds of the exact-cost polish after the solves: the best candidate's 24 neighbours
    (a step of ``polish_step`` along one variable, or along all four at once; share of each
    range) are costed exactly and the best kept, then the step halves; 0 turns it off
    (docs/nlp.md, "Pass 6")."""
    polish_step: float = 0.04
    """First step of the polish, as a share of each variable's range."""
    polish_starts: int = 5
    """Best distinct candidates (solved or screened, by exact cost) the polish starts from."""
    polish_margin: float = 1.0
    """Candidates whose exact cost trails the best one's by more than this are not polished
    (``inf``: every one of the ``polish_starts``): no polish gain measured ever came near it
    (docs/nlp.md, "Pass 6")."""
    polish_ahead: bool = True
    """Polish on the thread the solves leave idle: three solves on two threads end with one
    thread waiting for the last solve, and there it walks from the seeds known so far (the
    screened starts and the finished solves). The final polish continues those walks whose
    seed is still a seed. Every walk is the same wherever it runs, so the plan is the same
    either way (held by a test); only the wall time changes."""
    screen_ahead: bool = True
    """Solve from the warm start at once, while a second thread costs the other starts
    exactly (the screen): the warm start is solved whatever the screen finds, and the solves
    from the best other starts follow it (with ``solve_threads`` above 1). Every solve and
    record is the same either way (held by a test); only the wall time changes."""
    trust_radius: float = 0.25
    """Initial trust radius of ``newton``, as a share of each variable's range."""
    soft_turn: float = 0.6
    """|delta| of the soft-turn starts, rad (about a third of the box)."""
    hard_turn: float = 1.5
    """|delta| of the hard-turn starts, rad (near the box's edge)."""
    turn_distance: float = 2.0
    """Target distance r of the turn starts, m."""

    def __post_init__(self):
        if self.method not in SOLVER_METHODS:
            _fail("SolverConfig", "method", self.method, f"one of {', '.join(SOLVER_METHODS)}")
        for name, low in (("max_iter", 1), ("n_spread", 0), ("n_samples", 1), ("seed", 0),
                          ("pair_budget", 1), ("parallel_rows", 1),
                          ("n_screen", 0), ("n_solved", 1), ("solve_threads", 1),
                          ("polish_rounds", 0),
                          ("polish_starts", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                _fail("SolverConfig", name, value, f"an integer >= {low}")
        positive = dict(low=0.0, low_open=True)
        _validate_fields(self, {"tol": positive, "distinct": dict(low=0.0, high=1.0),
                                "fd_step": positive, "polish_step": dict(low=0.0, high=1.0),
                                "polish_margin": dict(low=0.0, allow_inf=True),
                                "trust_radius": dict(low=0.0, low_open=True, high=1.0),
                                "soft_turn": dict(low=0.0), "hard_turn": dict(low=0.0),
                                "turn_distance": positive})
        for name in ("polish_ahead", "screen_ahead"):
            if not isinstance(getattr(self, name), bool):
                _fail("SolverConfig", name, getattr(self, name), "True or False")
        hessians = ("differences", "exact", "quasi-newton")
        if self.hessian not in hessians:
            _fail("SolverConfig", "hessian", self.hessian, " or ".join(map(repr, hessians)))
        try:
            buckets = tuple(sorted({int(b) for b in self.pose_object_buckets}))
        except (TypeError, ValueError):
            buckets = ()
        if not buckets or buckets[0] < 0 or any(
                isinstance(b, bool) or b != int(b) for b in self.pose_object_buckets):
            _fail("SolverConfig", "pose_object_buckets", self.pose_object_buckets,
                  "a non-empty sequence of integers >= 0")
        object.__setattr__(self, "pose_object_buckets", buckets)
        try:
            options = tuple((str(k), v) for k, v in
                            (self.options.items() if isinstance(self.options, dict)
                             else self.options))
        except (TypeError, ValueError):
            _fail("SolverConfig", "options", self.options, "a dict or sequence of (key, value)")
        object.__setattr__(self, "options", options)

    @classmethod
    def fast(cls, **changes) -> SolverConfig:
        """Trust-region Newton on the 4-D box: exact box-QP step, quasi-Newton (SR1) Hessian.

        On 4 variables it needs no barrier and no per-call ``nlpsol`` overhead; ``tol`` is the
        predicted decrease counted as converged (1e-3, against the 0.01 cost tolerance). The
        exact polish starts from the 3 best candidates instead of 5: two fifths of the polish
        saved for about the same plans (docs/nlp.md, "Pass 6").
        """
        changes.setdefault("tol", 1e-3)
        changes.setdefault("polish_starts", 3)
        return cls(method="newton", **changes)

    @classmethod
    def sampling(cls, **changes) -> SolverConfig:
        """The batched exact-cost sampling planner alone."""
        return cls(method="sampling", **changes)

    @classmethod
    def named(cls, name: str) -> SolverConfig:
        """One of :data:`SOLVER_NAMES`: ``nlp`` (IPOPT), ``fast`` or ``sampling``."""
        makers = dict(zip(SOLVER_NAMES, (cls, cls.fast, cls.sampling)))
        if name not in makers:
            raise InputError(f"solver = {name!r}: must be one of {', '.join(makers)}")
        return makers[name]()
