"""Sensing profiles: what a simulated robot senses of the world, and how its commands are executed.

The default, ``oracle``, is the simulator as it always was: the planner is told the true map,
every person's true position and velocity, its own true pose, and its command is executed at
once. The other built-ins replace one part of that truth each with what a robot has:

- ``lidar``: the static world only through a simulated 2D lidar (:class:`LidarSettings`; rays
  cast against the true map, the people and the other robots, which occlude), integrated into the
  product's local map (:class:`~dsmpepc_nlp.perception.LocalMap`), with no prior map.
- ``tracked``: people only through a detector (:class:`DetectorSettings`: field of view, range,
  occlusion by walls and other people, position noise, misses, false detections, latency), fed
  to the product's tracker (:class:`~dsmpepc_nlp.perception.PeopleTracker`).
- ``realistic``: both, plus localisation error (:class:`LocalisationSettings`: slow drift and
  jitter) and a plant (:class:`PlantSettings`) that obeys the robot's acceleration limits,
  applies each command one control period late and tracks it with noise.

A profile is data: :func:`load_profile` reads a built-in name or a YAML file with the scenario
files' strict validation (unknown keys with a did-you-mean, every value checked). The simulated
sensors themselves are :mod:`.senses`. Every draw is seeded from the episode's generator.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from dataclasses import dataclass
from pathlib import Path

import yaml

from ..core.errors import InputError, shown
from ..core.validation import validate_fields
from ..perception import TrackerConfig
from ..perception.local_map import MARK_BEYOND

UST10_FOV = 4.712389
"""Hokuyo UST-10's field of view, rad (270 degrees, +-2.356 rad: the BARN Challenge's Jackal)."""


@dataclass(frozen=True)
class LidarSettings:
    """A 2D lidar and the local map its scans are integrated into."""

    beams: int = 720
    """Beams per scan (Hokuyo UST-10, the BARN Challenge's Jackal)."""
    fov: float = UST10_FOV
    """Field of view, rad, centred on the heading (UST-10: 270 degrees)."""
    range_min: float = 0.1
    """Shortest range, m (UST-10)."""
    range_max: float = 30.0
    """Longest range, m (UST-10); a beam that hits nothing returns ``inf`` (ROS's LaserScan)."""
    range_noise: float = 0.001
    """Standard deviation of the Gaussian range noise, m (the BARN simulation's UST-10)."""
    mount_x: float = -0.065
    """Sensor position along the body, m (the BARN Jackal's: 0.065 m behind the centre)."""
    window: float = 20.0
    """Side of the square local map that rolls with the robot, m (our choice)."""
    resolution: float = 0.05
    """Cell side of the local map, m (Nav2's costmap default)."""
    mark_beyond: float = MARK_BEYOND
    """A return marks the local map's cell this far beyond it, m
    (:class:`~dsmpepc_nlp.perception.LocalMapConfig`'s ``mark_beyond``; 0.0: the return's own
    cell, the choice before 2026-12-06)."""
    object_margin: float = 0.1
    """m: a return within an object's radius plus this of a moving object the planner is given
    (a person, another robot) is not marked into the map: the planner plans round it as a
    moving object already (our choice, as people-aware costmaps do)."""

    def __post_init__(self):
        if isinstance(self.beams, bool) or not isinstance(self.beams, int) or self.beams < 2:
            raise InputError(f"LidarSettings.beams={shown(self.beams)}: expected an integer >= 2")
        validate_fields(self, {
            "fov": dict(low=0.0, low_open=True, high=2.0 * math.pi),
            "range_min": dict(low=0.0),
            "range_max": dict(low=0.0, low_open=True, high=1000.0),
            "range_noise": dict(low=0.0, high=1.0),
            "mount_x": dict(low=-10.0, high=10.0),
            "window": dict(low=1.0, high=200.0),
            "resolution": dict(low=0.01, high=1.0),
            "mark_beyond": dict(low=0.0, high=1.0),
            "object_margin": dict(low=0.0, high=10.0),
        })
        if self.mark_beyond > self.resolution:
            raise InputError(f"LidarSettings.mark_beyond={shown(self.mark_beyond)}: expected at "
                             f"most one cell, resolution ({shown(self.resolution)})")
        if not self.range_min < self.range_max:
            raise InputError(f"LidarSettings.range_min={shown(self.range_min)}: expected below "
                             f"range_max ({shown(self.range_max)})")


@dataclass(frozen=True)
class DetectorSettings:
    """A people detector: what it sees, how well, and how late."""

    fov: float = UST10_FOV
    """Field of view, rad, centred on the heading (our choice: the lidar's, a detector on it)."""
    range: float = 10.0
    """Farthest detection, m (our choice: leg and body detectors on 2D lidars reach 5-15 m)."""
    position_noise: float = 0.1
    """Standard deviation of each detected position, per axis, m (our choice; the noise an
    outside tester gave walkers in IR-SIM)."""
    miss_rate: float = 0.1
    """Probability that a visible person is not detected in a cycle (our choice)."""
    false_rate: float = 0.2
    """Mean false detections per cycle (Poisson), anywhere in range and view (our choice)."""
    latency: float = 0.0
    """Age of the detections handed over, s, rounded to whole control periods (our choice: none;
    the detector is simulated once a control period, so a latency shorter than half of one,
    0.1 s at 0.2-0.25 s, rounds to none)."""

    def __post_init__(self):
        validate_fields(self, {
            "fov": dict(low=0.0, low_open=True, high=2.0 * math.pi),
            "range": dict(low=0.0, low_open=True, high=1000.0),
            "position_noise": dict(low=0.0, high=10.0),
            "miss_rate": dict(low=0.0, high=1.0),
            "false_rate": dict(low=0.0, high=100.0),
            "latency": dict(low=0.0, high=10.0),
        })


@dataclass(frozen=True)
class LocalisationSettings:
    """Where the robot believes it is: a slow drift and a jitter on the true pose."""

    drift: float = 0.02
    """Random-walk density of the position error, m per sqrt(s): 0.1 m after 25 s (our choice,
    an odometry-class estimate between map corrections)."""
    heading_drift: float = 0.005
    """Random-walk density of the heading error, rad per sqrt(s) (our choice)."""
    jitter: float = 0.02
    """Standard deviation of the white position noise each cycle, m (our choice)."""
    heading_jitter: float = 0.01
    """Standard deviation of the white heading noise each cycle, rad (our choice)."""

    def __post_init__(self):
        validate_fields(self, {name: dict(low=0.0, high=10.0)
                               for name in ("drift", "heading_drift", "jitter",
                                            "heading_jitter")})


@dataclass(frozen=True)
class PlantSettings:
    """How a command is executed: late, within the robot's limits, with noise."""

    delay: int = 1
    """Control periods between a plan and the execution of its command (our choice: one)."""
    limits: bool = True
    """Execute within the robot's ``accel_limit`` and ``alpha_limit`` from the actual speed."""
    noise: float = 0.05
    """Relative standard deviation of the executed speed and turn rate (our choice: 5 %)."""

    def __post_init__(self):
        if isinstance(self.delay, bool) or not isinstance(self.delay, int) \
                or not 0 <= self.delay <= 10:
            raise InputError(f"PlantSettings.delay={shown(self.delay)}: expected an integer in "
                             "[0, 10]")
        if not isinstance(self.limits, bool):
            raise InputError(f"PlantSettings.limits={shown(self.limits)}: expected true or "
                             "false")
        validate_fields(self, {"noise": dict(low=0.0, high=1.0)})


SECTIONS = {"lidar": LidarSettings, "detector": DetectorSettings,
            "localisation": LocalisationSettings, "plant": PlantSettings}
"""A profile's parts, by the key a profile file names them with."""
SETTINGS = {**SECTIONS, "tracker": TrackerConfig}
"""Every section a profile file may hold: the parts, and the tracker's settings (the
product's :class:`~dsmpepc_nlp.perception.TrackerConfig`, its defaults when not given)."""


@dataclass(frozen=True)
class SensingProfile:
    """What the robot senses and how it is driven; None for a part means the truth."""

    name: str = "oracle"
    lidar: LidarSettings | None = None
    detector: DetectorSettings | None = None
    localisation: LocalisationSettings | None = None
    plant: PlantSettings | None = None
    tracker: TrackerConfig | None = None
    """The people tracker's settings with a detector (None: ``TrackerConfig()``)."""

    @property
    def is_oracle(self) -> bool:
        """True when nothing is sensed: the simulator's truth, as before profiles."""
        return all(getattr(self, key) is None for key in SECTIONS)

    def as_dict(self) -> dict:
        """JSON-able: the name and every part's fields (None for a true part)."""
        return {"name": self.name, **{key: None if getattr(self, key) is None
                                      else dataclasses.asdict(getattr(self, key))
                                      for key in SETTINGS}}

    def with_lidar(self, **changes) -> SensingProfile:
        """This profile with its lidar's fields changed (no lidar: unchanged)."""
        if self.lidar is None:
            return self
        return dataclasses.replace(self, lidar=dataclasses.replace(self.lidar, **changes))


PROFILE_TRACKER = TrackerConfig(confirm_hits=2)
"""The built-in profiles' tracker: a track is confirmed after 2 detections in a row, not the
tracker's default 3. The simulated detector reports once a control period (0.2-0.25 s), so 3
hits kept a person out of the plan for 0.5-0.75 s; chosen on CrowdNav circle crossing's tuning
cases (``--seed 1``, 80 cases, ``tracked``: 19 won, 10 lost against 3;
docs/experiments/2026-12-06-sensing-profiles.md)."""

BUILTIN_PROFILES = {
    "oracle": SensingProfile("oracle"),
    "lidar": SensingProfile("lidar", lidar=LidarSettings()),
    "tracked": SensingProfile("tracked", detector=DetectorSettings(), tracker=PROFILE_TRACKER),
    "realistic": SensingProfile("realistic", lidar=LidarSettings(),
                                detector=DetectorSettings(),
                                localisation=LocalisationSettings(), plant=PlantSettings(),
                                tracker=PROFILE_TRACKER),
}
"""The named profiles; ``oracle`` is every command's default."""


def load_profile(name_or_path) -> SensingProfile:
    """A built-in profile by name, or a YAML profile file (:func:`parse_profile`)."""
    if isinstance(name_or_path, SensingProfile):
        return name_or_path
    text = str(name_or_path)
    if text in BUILTIN_PROFILES:
        return BUILTIN_PROFILES[text]
    path = Path(text)
    if path.suffix not in (".yaml", ".yml") and not path.exists():
        close = difflib.get_close_matches(text, list(BUILTIN_PROFILES), n=1, cutoff=0.6)
        hint = f"did you mean {close[0]!r}? " if close else ""
        raise InputError(f"sensing {text!r}: not a built-in profile and not a file; {hint}"
                         f"built-ins: {', '.join(BUILTIN_PROFILES)}")
    try:
        data = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise InputError(f"sensing profile {text!r}: file not found") from None
    except (OSError, yaml.YAMLError) as exc:
        raise InputError(f"sensing profile {text!r}: cannot read ({exc})") from None
    return parse_profile(data, source=text, default_name=path.stem)


def parse_profile(data, source: str = "<mapping>", default_name: str = "custom") \
        -> SensingProfile:
    """A profile from a mapping: optional ``name``, ``base`` (a built-in to start from) and
    the parts ``lidar``, ``detector``, ``localisation``, ``plant``, each a mapping of its
    fields, ``true`` (its defaults) or ``false``/``null`` (the truth), and ``tracker`` (the
    tracker's settings)."""
    where = f"sensing profile {source}"
    if not isinstance(data, dict):
        raise InputError(f"{where}: got {type(data).__name__}; must be a mapping")
    _known(data, ("name", "base", *SETTINGS), where)
    base = BUILTIN_PROFILES["oracle"]
    if "base" in data:
        if data["base"] not in BUILTIN_PROFILES:
            raise InputError(f"{where}: base: {shown(data['base'])}: must be one of "
                             f"{', '.join(BUILTIN_PROFILES)}")
        base = BUILTIN_PROFILES[data["base"]]
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise InputError(f"{where}: name: {shown(name)}: must be a non-empty string")
    parts = {key: _part(data[key], kind, getattr(base, key), f"{where}: {key}")
             if key in data else getattr(base, key) for key, kind in SETTINGS.items()}
    return SensingProfile(name, **parts)


def _known(mapping: dict, allowed, where: str) -> None:
    for key in mapping:
        if key not in allowed:
            close = difflib.get_close_matches(str(key), list(allowed), n=1, cutoff=0.6)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise InputError(f"{where}: {key}: unknown key; {hint}allowed keys: "
                             f"{', '.join(allowed)}")


def _part(value, kind, base, where: str):
    """One part of a profile file: a mapping of ``kind``'s fields over ``base`` (or the
    defaults), ``true`` for the defaults, ``false`` or null for the truth."""
    if value is None or value is False:
        return None
    if value is True:
        return base if base is not None else kind()
    if not isinstance(value, dict):
        raise InputError(f"{where}: {shown(value)}: must be a mapping of fields, true or false")
    fields = [f.name for f in dataclasses.fields(kind)]
    _known(value, fields, where)
    start = base if base is not None else kind()
    try:
        return dataclasses.replace(start, **value)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


__all__ = ["BUILTIN_PROFILES", "DetectorSettings", "LidarSettings", "LocalisationSettings",
           "PlantSettings", "SensingProfile", "load_profile", "parse_profile"]
