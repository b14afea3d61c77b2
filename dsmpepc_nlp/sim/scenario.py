"""Scenario files: the YAML schema, its strict validation, and loading into simulator objects.

A scenario file is a YAML mapping (units: m, s, rad; angles counter-clockwise from +x)::

    name: t-corridor                 # str, required
    description: "..."               # str, optional
    duration: 30.0                   # s, > 0, required: the simulated time
    map: t-corridor.map.yaml         # optional ROS map_server YAML, relative to this file
    start_noise: 0.0                 # m, >= 0, optional: std of a seeded perturbation of starts
    robots:                          # required, at least one: the planning robots
      - name: mover                  # str, optional (default robot<i>), unique
        start: [x, y, phi]           # required
        goal:                        # required: exactly one of position / follow
          position: [x, y]           #   a fixed goal, docked near it
          tolerance: 0.25            #   m, > 0, optional (default 0.25)
        # goal: {follow: 0, distance: 1.0, tolerance: 1.0}
        #   follow pedestrian 0 at 1.0 m; success: at most distance + tolerance behind at the end
        footprint: [[cx, cy, r], ...]  # optional body circles (default: the config's robot)
        v_limit: 1.0                 # m/s, > 0, optional (default: the config's)
    parked_robots:                   # optional: robots that never move (dynamic obstacles)
      - pose: [x, y, phi]
        footprint: [[cx, cy, r], ...]
    pedestrians:                     # optional
      - radius: 0.3                  # m, > 0, optional (default 0.3)
        waypoints: [[t, x, y], ...]  #   timestamped, t strictly increasing; or instead:
        # start: [x, y]
        # velocity: [vx, vy]         #   constant velocity from t = 0

Every violation (unknown key, missing field, wrong type, non-finite number, non-positive radius,
bad reference) raises :class:`ScenarioError` naming the file, the field path
(``robots[1].goal.position``) and what is allowed. ``scenarios/README.md`` holds the same schema.

Numbers must also be plausible (``core/errors.py``): positions and headings within
``MAX_COORDINATE`` (1e6), ``duration`` and waypoint times within ``MAX_DURATION`` (one day),
``v_limit`` and velocities within ``MAX_SPEED`` (100 m/s), radii, footprint offsets, tolerances,
following distances and ``start_noise`` within ``MAX_SIZE`` (100 m). A start whose footprint
overlaps the map, another robot, a parked robot or a pedestrian at t = 0 is an error; with
``start_noise`` each noisy start is re-drawn until it is in free space (:func:`start_states`).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from pathlib import Path

import numpy as np

from ..core.config import RobotConfig, RobotState
from ..core.errors import MAX_COORDINATE, MAX_DURATION, MAX_SIZE, MAX_SPEED, InputError, shown
from ..core.files import YamlError, load_yaml
from ..core.world import OccupancyGrid
from .checks import check_against_map, start_conflict
from .types import Agent, FixedGoal, FollowGoal, ParkedRobot, Pedestrian, Scenario

SCENARIO_DIR = Path(__file__).resolve().parent.parent / "scenarios"
"""Where the built-in scenarios live: package data (``dsmpepc_nlp/scenarios/``), so an installed
wheel has them; the repository's top-level ``scenarios`` is a link to the same folder."""

DEFAULT_GOAL_TOLERANCE = 0.25
"""Distance to a fixed goal that counts as reached, m (our choice)."""
DEFAULT_FOLLOW_DISTANCE = 1.0
"""Default following distance, m (our choice)."""
DEFAULT_FOLLOW_TOLERANCE = 1.0
"""How much farther than the following distance a follower may end, m (our choice)."""
DEFAULT_PEDESTRIAN_RADIUS = 0.3
"""Pedestrian body radius, m (our choice)."""


class ScenarioError(InputError):
    """A scenario file that breaks the schema; the message names file, field and what is allowed."""


# ---------------------------------------------------------------------------------------------
# a small strict reader


class _Reader:
    def __init__(self, source: str):
        self.source = source

    def fail(self, path: str, problem: str):
        raise ScenarioError(f"scenario {self.source}: {path or 'the document'}: {problem}")

    def mapping(self, value, path, required=(), optional=()):
        if value is None and not path:
            self.fail(path, "the file is empty; must be a mapping with "
                      f"{', '.join(required)}")
        if not isinstance(value, dict):
            self.fail(path, f"got {type(value).__name__}; must be a mapping")
        allowed = (*required, *optional)
        for key in value:
            if key not in allowed:
                close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
                hint = f"did you mean {close[0]!r}? " if close else ""
                self.fail(f"{path}.{key}" if path else str(key),
                          f"unknown key; {hint}allowed keys: {', '.join(allowed)}")
        for key in required:
            if key not in value:
                self.fail(f"{path}.{key}" if path else key, "missing required field")
        return value

    def number(self, value, path, *, low=None, low_open=False, high=None):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            hint = ""
            if isinstance(value, str) and _looks_numeric(value):
                hint = f" (write it as a YAML number such as {float(value):.1e})"
            self.fail(path, f"{shown(value)} is not a number{hint}")
        value = float(value)
        if not math.isfinite(value):
            self.fail(path, f"{shown(value)}: must be a finite number")
        if low is not None and (value <= low if low_open else value < low):
            self.fail(path, f"{shown(value)}: must be {'>' if low_open else '>='} {low}")
        if high is not None and value > high:
            self.fail(path, f"{shown(value)}: must be <= {high:g}")
        return value

    def vector(self, value, path, size, names, bound=MAX_COORDINATE):
        if not isinstance(value, (list, tuple)) or len(value) != size:
            self.fail(path, f"{shown(value)}: must be a list of {size} numbers "
                      f"[{', '.join(names)}]")
        numbers = tuple(self.number(v, f"{path}[{i}]") for i, v in enumerate(value))
        for i, v in enumerate(numbers):
            if abs(v) > bound:
                self.fail(f"{path}[{i}]", f"{v!r}: must be within [-{bound:g}, {bound:g}]")
        return numbers

    def string(self, value, path):
        if not isinstance(value, str) or not value:
            self.fail(path, f"{shown(value)}: must be a non-empty string")
        return value

    def integer(self, value, path, low=0):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            self.fail(path, f"{shown(value)}: must be an integer >= {low}")
        return value

    def items(self, value, path, *, min_items=0):
        if not isinstance(value, list):
            self.fail(path, f"got {type(value).__name__}; must be a list")
        if len(value) < min_items:
            self.fail(path, f"has {len(value)} entries; must have at least {min_items}")
        return value

    def footprint(self, value, path):
        circles = self.items(value, path, min_items=1)
        out = []
        for i, c in enumerate(circles):
            cx, cy, r = self.vector(c, f"{path}[{i}]", 3, ("cx", "cy", "radius"), MAX_SIZE)
            if r <= 0:
                self.fail(f"{path}[{i}][2]", f"radius {r!r}: must be > 0")
            out.append((cx, cy, r))
        return tuple(out)


def _looks_numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


# ---------------------------------------------------------------------------------------------
# loading


def builtin_names() -> list:
    """Names of the scenarios shipped in ``scenarios/``, sorted."""
    if not SCENARIO_DIR.is_dir():
        return []
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml") if not p.name.endswith(".map.yaml"))


def resolve(name_or_path) -> Path:
    """The file of a built-in name (``t-corridor``) or of a path; ScenarioError if neither. A
    folder is never a scenario, so a built-in's name stays the built-in beside a folder of that
    name (``--out hall`` of an earlier run)."""
    text = str(name_or_path)
    path = Path(text)
    candidate = SCENARIO_DIR / f"{text}.yaml"
    if path.is_dir() and path.suffix not in (".yaml", ".yml") and candidate.is_file():
        return candidate
    if path.suffix in (".yaml", ".yml") or path.exists():
        if path.is_dir():
            raise ScenarioError(f"scenario {text!r}: is a folder; expected a scenario YAML file "
                                "or a built-in name")
        if not path.is_file():
            raise ScenarioError(f"scenario {text!r}: file not found")
        return path
    if candidate.is_file():
        return candidate
    known = ", ".join(builtin_names()) or "(none installed)"
    raise ScenarioError(f"scenario {text!r}: not a file and not a built-in; built-ins: {known}")


def load_scenario(name_or_path) -> Scenario:
    """Read, validate and build a :class:`~dsmpepc_nlp.sim.types.Scenario`.

    Parameters
    ----------
    name_or_path : str or Path
        A built-in name (see :func:`builtin_names`) or the path of a YAML file.

    Raises
    ------
    ScenarioError
        For a missing file, invalid YAML, or anything the schema does not allow.
    """
    path = resolve(name_or_path)
    try:
        data = load_yaml(path.read_text())
    except OSError as exc:
        raise ScenarioError(f"scenario {str(path)!r}: cannot read ({exc.strerror})") from None
    except YamlError as exc:
        problem = str(exc).replace("\n", " ")
        raise ScenarioError(f"scenario {str(path)!r}: invalid YAML ({problem})") from None
    return parse_scenario(data, source=str(path), folder=path.parent)


def parse_scenario(data, source: str = "<mapping>", folder=None) -> Scenario:
    """Validate a scenario mapping (as YAML gives it) and build the Scenario; see the schema."""
    r = _Reader(repr(source))
    r.mapping(data, "", required=("name", "duration", "robots"),
              optional=("description", "map", "start_noise", "parked_robots", "pedestrians"))
    name = r.string(data["name"], "name")
    description = data.get("description", "")
    if not isinstance(description, str):
        r.fail("description", f"{description!r}: must be a string")
    duration = r.number(data["duration"], "duration", low=0.0, low_open=True, high=MAX_DURATION)
    start_noise = r.number(data.get("start_noise", 0.0), "start_noise", low=0.0, high=MAX_SIZE)
    grid, map_path = None, None
    if "map" in data:
        map_name = r.string(data["map"], "map")
        map_file = (Path(folder) if folder is not None else Path.cwd()) / map_name
        try:
            grid = OccupancyGrid.from_yaml(map_file)
        except ValueError as exc:
            r.fail("map", str(exc))
        map_path = str(map_file)
    pedestrians = tuple(_pedestrian(r, p, f"pedestrians[{i}]") for i, p in
                        enumerate(r.items(data.get("pedestrians", []), "pedestrians")))
    agents = tuple(_agent(r, a, f"robots[{i}]", i, len(pedestrians)) for i, a in
                   enumerate(r.items(data["robots"], "robots", min_items=1)))
    names = [a.name for a in agents]
    for i, n in enumerate(names):
        if names.index(n) != i:
            r.fail(f"robots[{i}].name", f"{n!r} is used twice; names must be unique")
    parked = []
    for i, p in enumerate(r.items(data.get("parked_robots", []), "parked_robots")):
        where = f"parked_robots[{i}]"
        r.mapping(p, where, required=("pose", "footprint"))
        parked.append(ParkedRobot(r.vector(p["pose"], f"{where}.pose", 3, ("x", "y", "phi")),
                                  r.footprint(p["footprint"], f"{where}.footprint")))
    parked = tuple(parked)
    starts = [a.start.pose for a in agents]
    for i in range(len(agents)):
        problem = start_conflict(i, starts, agents, grid, parked, pedestrians)
        if problem:
            s = agents[i].start
            r.fail(f"robots[{i}].start", f"[{s.x}, {s.y}, {s.phi}]: {problem}; a start must be "
                   "in free space")
    if grid is not None:
        check_against_map(r, grid, agents, pedestrians, duration)
    return Scenario(name=name, agents=agents, grid=grid, pedestrians=pedestrians,
                    parked=parked, duration=duration, start_noise=start_noise,
                    map_path=map_path, description=description)


def _agent(r, a, where, index, n_pedestrians) -> Agent:
    r.mapping(a, where, required=("start", "goal"),
              optional=("name", "footprint", "v_limit"))
    name = r.string(a.get("name", f"robot{index}"), f"{where}.name")
    x, y, phi = r.vector(a["start"], f"{where}.start", 3, ("x", "y", "phi"))
    goal = a["goal"]
    gpath = f"{where}.goal"
    r.mapping(goal, gpath, optional=("position", "follow", "distance", "tolerance"))
    if ("position" in goal) == ("follow" in goal):
        r.fail(gpath, "must have exactly one of 'position' (fixed goal) or 'follow' "
               "(pedestrian index)")
    if "position" in goal:
        if "distance" in goal:
            r.fail(f"{gpath}.distance", "only allowed with 'follow'")
        tolerance = r.number(goal.get("tolerance", DEFAULT_GOAL_TOLERANCE), f"{gpath}.tolerance",
                             low=0.0, low_open=True, high=MAX_SIZE)
        target = FixedGoal(r.vector(goal["position"], f"{gpath}.position", 2, ("x", "y")),
                           tolerance)
    else:
        k = r.integer(goal["follow"], f"{gpath}.follow")
        if k >= n_pedestrians:
            r.fail(f"{gpath}.follow", f"pedestrian {k} does not exist; the scenario has "
                   f"{n_pedestrians} pedestrian(s), indices from 0")
        target = FollowGoal(
            k, r.number(goal.get("distance", DEFAULT_FOLLOW_DISTANCE), f"{gpath}.distance",
                        low=0.0, high=MAX_SIZE),
            r.number(goal.get("tolerance", DEFAULT_FOLLOW_TOLERANCE), f"{gpath}.tolerance",
                     low=0.0, low_open=True, high=MAX_SIZE))
    robot = None
    if "footprint" in a or "v_limit" in a:
        changes = {}
        if "footprint" in a:
            changes["footprint"] = r.footprint(a["footprint"], f"{where}.footprint")
        if "v_limit" in a:
            changes["v_limit"] = r.number(a["v_limit"], f"{where}.v_limit", low=0.0,
                                          low_open=True, high=MAX_SPEED)
        robot = dataclasses.replace(RobotConfig(), **changes)
    return Agent(name, RobotState(x, y, phi), target, robot)


def _pedestrian(r, p, where) -> Pedestrian:
    r.mapping(p, where, optional=("radius", "waypoints", "start", "velocity"))
    radius = r.number(p.get("radius", DEFAULT_PEDESTRIAN_RADIUS), f"{where}.radius", low=0.0,
                      low_open=True, high=MAX_SIZE)
    if "waypoints" in p:
        for key in ("start", "velocity"):
            if key in p:
                r.fail(f"{where}.{key}", "not allowed together with 'waypoints'")
        rows = r.items(p["waypoints"], f"{where}.waypoints", min_items=1)
        table = np.array([r.vector(w, f"{where}.waypoints[{i}]", 3, ("t", "x", "y"))
                          for i, w in enumerate(rows)])
        late = np.flatnonzero(np.abs(table[:, 0]) > MAX_DURATION)
        if late.size:
            r.fail(f"{where}.waypoints[{late[0]}][0]",
                   f"time {float(table[late[0], 0])!r}: must be within "
                   f"[-{MAX_DURATION:g}, {MAX_DURATION:g}] s")
        bad = np.flatnonzero(np.diff(table[:, 0]) <= 0)
        if bad.size:
            r.fail(f"{where}.waypoints[{bad[0] + 1}][0]",
                   f"time {float(table[bad[0] + 1, 0])!r}: times must be strictly increasing")
        return Pedestrian(table[:, 0], table[:, 1:], radius=radius)
    if "start" not in p or "velocity" not in p:
        r.fail(where, "needs 'waypoints', or both 'start' and 'velocity'")
    start = r.vector(p["start"], f"{where}.start", 2, ("x", "y"))
    velocity = r.vector(p["velocity"], f"{where}.velocity", 2, ("vx", "vy"), MAX_SPEED)
    return Pedestrian.constant(start, velocity, radius)
