"""Scenario families: the paper's scenes generated over their geometry, for the claim map.

The paper gives no dimensions for its T-corridor (Fig. 4) or narrow corridor (Fig. 5), so one
hand-made geometry cannot tell whether the method or the geometry decides an outcome. A family
builds the same scene for every value of one or two geometry axes (a *cell*), as a scenario
mapping (the YAML schema of :mod:`.scenario`) plus its occupancy grid, so a cell can be saved
as ``NAME.yaml`` + ``NAME.map.yaml`` + ``NAME.map.pgm`` and opened with ``dsmpepc run FILE``
like any built-in. Every cell carries ``start_noise`` (0.1 m): seeds differ.

Families (geometry ours, from the paper's descriptions; all lengths m):

``t-corridor``
    A 2 m wide corridor going up; a side corridor opens to the right. A parked round robot
    stands in the side corridor's entrance against its lower wall (0.05 m off it); the axis
    ``gap`` is the free width between that robot and the entrance's upper wall, the only way
    past it. Beyond the 1 m long entrance the side corridor has the width ``width`` (second
    axis), measured up from the same lower wall, so a wide gap can open onto a narrow corridor
    and the other way round.
``narrow-corridor``
    Two 0.6 x 0.4 m robots (two circles each) drive in opposite directions through a 12.6 m
    corridor of width ``width``; the second axis ``length`` is the corridor's length.
``doorway``
    A round robot crosses a wall through a door of width ``door``; its start is shifted
    ``offset`` sideways from the door, so the straight line to its goal (on the door's axis
    behind the wall) runs into the wall: the situation of the terminal cost's hazard
    (docs/method.md section 5.4).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from ..core.errors import InputError
from ..core.world import OccupancyGrid
from .scenario import load_scenario

RESOLUTION = 0.05
"""Cell side of every generated map, m; every wall lies on a cell boundary."""
START_NOISE = 0.1
"""Start-position noise of every generated cell, m (std; the seeds of a cell differ by it)."""
WALL = 0.2
"""Thickness of the outer walls, m."""
ROUND_BODY = ((0.0, 0.0, 0.3),)
"""The default round robot, 0.6 m across."""
RECT_BODY = ((-0.1, 0.0, 0.2), (0.1, 0.0, 0.2))
"""A 0.6 m x 0.4 m robot as a row of two circles (non-circular agents, paper section V-C)."""
PARKED_CLEARANCE = 0.05
"""Distance between the T-corridor's parked robot and the wall it stands against, m."""


def carve(extent, free=(), resolution=RESOLUTION) -> OccupancyGrid:
    """A grid over ``[0, w] x [0, h]``, occupied except the ``free`` rectangles ``(x0, y0, x1,
    y1)`` (m); a cell is free when its centre lies inside one of them."""
    nx, ny = round(extent[0] / resolution), round(extent[1] / resolution)
    gx, gy = np.meshgrid((np.arange(nx) + 0.5) * resolution, (np.arange(ny) + 0.5) * resolution)
    occupied = np.ones((ny, nx), dtype=bool)
    for x0, y0, x1, y1 in free:
        occupied[(gx > x0) & (gx < x1) & (gy > y0) & (gy < y1)] = False
    return OccupancyGrid(occupied, resolution)


def _snap(value: float) -> float:
    """``value`` on the map's cell boundaries (walls are drawn there), rounded for the YAML."""
    return round(round(value / RESOLUTION) * RESOLUTION, 6)


def _body(circles) -> list:
    return [list(c) for c in circles]


# ---------------------------------------------------------------------------------------------
# the families


def t_corridor(gap: float, width: float) -> tuple:
    """The T-corridor cell: a parked robot leaves ``gap`` m free in the side corridor's entrance;
    the side corridor is ``width`` m wide beyond it. Returns ``(mapping, grid)``."""
    r = ROUND_BODY[0][2]
    x_side, y_low = 2.2, 6.0                    # main corridor x in [0.2, 2.2]; side from x 2.2
    top_entrance = _snap(y_low + PARKED_CLEARANCE + 2 * r + gap)
    top_side = _snap(y_low + width)
    height = max(top_entrance, top_side) + 2.0
    grid = carve((11.0, height), free=[(WALL, WALL, x_side, height - WALL),
                                       (x_side, y_low, x_side + 1.0, top_entrance),
                                       (x_side + 1.0, y_low, 11.0 - WALL, top_side)])
    parked_y = round(y_low + PARKED_CLEARANCE + r, 6)
    goal_y = round((y_low + top_side) / 2, 6)
    doc = {
        "name": cell_name("t-corridor", gap, width),
        "description": f"T-corridor family: a parked robot leaves a {gap:g} m gap in the side "
                       f"corridor's entrance; the side corridor is {width:g} m wide beyond it.",
        "duration": 30.0, "start_noise": START_NOISE,
        "robots": [{"name": "mover", "start": [1.2, 1.0, round(math.pi / 2, 6)],
                    "goal": {"position": [9.5, goal_y]}, "footprint": _body(ROUND_BODY)}],
        "parked_robots": [{"pose": [x_side + 0.5, parked_y, round(math.pi / 2, 6)],
                           "footprint": _body(ROUND_BODY)}],
    }
    return doc, grid


def narrow_corridor(width: float, length: float) -> tuple:
    """Two non-circular robots pass each other in a corridor ``width`` m wide, ``length`` long."""
    y0 = 1.0
    y1 = _snap(y0 + width)
    x1 = _snap(WALL + length)
    grid = carve((x1 + WALL, y1 + 1.0), free=[(WALL, y0, x1, y1)])
    mid = round((y0 + y1) / 2, 6)
    doc = {
        "name": cell_name("narrow-corridor", width, length),
        "description": f"Narrow-corridor family: two 0.6 x 0.4 m robots pass each other in a "
                       f"{width:g} m wide, {length:g} m long corridor.",
        "duration": 30.0, "start_noise": START_NOISE,
        "robots": [
            {"name": "east", "start": [WALL + 1.0, mid, 0.0],
             "goal": {"position": [round(x1 - 1.0, 6), mid]}, "footprint": _body(RECT_BODY)},
            {"name": "west", "start": [round(x1 - 1.0, 6), mid, round(math.pi, 6)],
             "goal": {"position": [WALL + 1.0, mid]}, "footprint": _body(RECT_BODY)},
        ],
    }
    return doc, grid


def doorway(door: float, offset: float) -> tuple:
    """A round robot crosses a 0.2 m wall through a ``door`` m wide door, starting ``offset`` m
    to the side of the door's axis; its goal is on the axis, 2.5 m behind the wall."""
    width, wall_y = 8.0, 4.0
    centre = width / 2
    x0 = _snap(centre - door / 2)
    x1 = round(x0 + _snap(door), 6)
    grid = carve((width, 8.0), free=[(WALL, WALL, width - WALL, wall_y),
                                     (WALL, wall_y + 0.2, width - WALL, 8.0 - WALL),
                                     (x0, wall_y - 0.01, x1, wall_y + 0.21)])
    doc = {
        "name": cell_name("doorway", door, offset),
        "description": f"Doorway family: a round robot starts {offset:g} m beside a {door:g} m "
                       "wide door and crosses the wall to a goal behind it.",
        "duration": 20.0, "start_noise": START_NOISE,
        "robots": [{"name": "mover", "start": [round(centre + offset, 6), 1.5,
                                               round(math.pi / 2, 6)],
                    "goal": {"position": [centre, wall_y + 2.7]}, "footprint": _body(ROUND_BODY)}],
    }
    return doc, grid


@dataclass(frozen=True)
class Family:
    """A scenario family: its builder and its two geometry axes (name, default values, quick
    values; the quick grid is the small one tests and ``--quick`` use)."""

    name: str
    build: Callable[[float, float], tuple[dict, OccupancyGrid | None]]
    """``build(value, value2) -> (scenario document, map)``."""
    axis: str
    values: tuple
    quick: tuple
    axis2: str
    values2: tuple
    quick2: tuple
    limits: tuple = ((0.1, 10.0), (0.1, 10.0))
    """Allowed ``(low, high)`` of each axis, m: outside them a start or goal would leave the
    map or the scene would no longer be the family's."""


FAMILIES = {
    "t-corridor": Family("t-corridor", t_corridor, "gap",
                         (0.7, 0.85, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0), (0.7, 1.2, 2.0),
                         "width", (1.8, 2.6), (1.8,), ((0.1, 4.0), (0.8, 5.0))),
    "narrow-corridor": Family("narrow-corridor", narrow_corridor, "width",
                              (1.0, 1.2, 1.4, 1.6, 1.8, 2.0, 2.2), (1.0, 1.4, 2.2),
                              "length", (12.6,), (12.6,), ((0.45, 5.0), (3.0, 40.0))),
    "doorway": Family("doorway", doorway, "door",
                      (0.7, 0.8, 0.9, 1.0, 1.2, 1.4, 1.6), (0.8, 1.2, 1.6),
                      "offset", (1.5, 3.0), (1.5,), ((0.1, 7.0), (0.0, 3.4))),
}
"""Every family by name."""


def family(name: str) -> Family:
    """The family called ``name``; InputError naming the known ones otherwise."""
    if name not in FAMILIES:
        raise InputError(f"family {name!r}: must be one of {', '.join(FAMILIES)}")
    return FAMILIES[name]


def cell_name(name: str, x: float, y: float) -> str:
    """The scenario name of a cell, e.g. ``t-corridor-gap1.20-width1.80``."""
    f = FAMILIES.get(name)
    axes = (f.axis, f.axis2) if f else ("x", "y")
    return f"{name}-{axes[0]}{x:.2f}-{axes[1]}{y:.2f}"


def generate(name: str, x: float, y: float) -> tuple:
    """The cell ``(x, y)`` of family ``name``: ``(mapping, grid)``, the mapping in the YAML
    schema without its ``map`` key (:func:`save` writes both and checks them)."""
    f = family(name)
    for axis, value, (low, high) in zip((f.axis, f.axis2), (x, y), f.limits):
        value = float(value)
        if not (low <= value <= high) or abs(value - _snap(value)) > 1e-9:
            raise InputError(f"family {name}: {axis} = {value!r}: must be a multiple of "
                             f"{RESOLUTION} m from {low:g} to {high:g} m (the map's cells)")
    return f.build(float(x), float(y))


class _Dumper(yaml.SafeDumper):
    def ignore_aliases(self, data):  # repeated footprints written out, not as anchors
        return True


def save(name: str, x: float, y: float, folder) -> Path:
    """Write a cell as ``<cell name>.yaml`` + its map files in ``folder``; the YAML's path.

    The file is read back with :func:`~dsmpepc_nlp.sim.scenario.load_scenario` before this
    returns, so a cell whose starts or goals fall in a wall fails here with the loader's message.
    """
    doc, grid = generate(name, x, y)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    stem = doc["name"]
    grid.to_yaml(folder / f"{stem}.map.yaml")
    doc = {**doc, "map": f"{stem}.map.yaml"}
    doc = {k: doc[k] for k in ("name", "description", "duration", "map", "start_noise",
                               "robots", "parked_robots") if k in doc}
    text = yaml.dump(doc, Dumper=_Dumper, sort_keys=False, default_flow_style=None, width=100)
    path = folder / f"{stem}.yaml"
    path.write_text(f"# {doc['description']}\n# Generated by dsmpepc_nlp.sim.families.\n" + text)
    load_scenario(path)
    return path


def cells(names, *, quick: bool = False) -> list:
    """``(family, x, y)`` for every cell of the named families (the quick grid when asked)."""
    out = []
    for name in names:
        f = family(name)
        xs, ys = (f.quick, f.quick2) if quick else (f.values, f.values2)
        out.extend((name, float(x), float(y)) for y in ys for x in xs)
    return out


def parse_cells(text: str, option: str = "cells") -> list:
    """``FAMILY:X:Y`` items, comma-separated (``t-corridor:1.0:1.8,doorway:0.9:1.5``), as
    ``(family, x, y)``, each checked by :func:`generate`; InputError naming ``option``."""
    out = []
    for item in (part.strip() for part in str(text).split(",")):
        name, *values = item.split(":")
        try:
            x, y = (float(v) for v in values)
        except ValueError:
            raise InputError(f"{option} {item!r}: expected FAMILY:X:Y with two numbers "
                             "(e.g. t-corridor:1.0:1.8)") from None
        generate(name, x, y)
        out.append((name, x, y))
    return list(dict.fromkeys(out))
