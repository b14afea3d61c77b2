"""``dsmpepc irsim-export barn``: BARN worlds written as IR-SIM world files.

Each world becomes ``barn-N.yaml``, a world that ``dsmpepc irsim`` and ``dsmpepc benchmark
irsim`` run as our own BARN benchmark (:mod:`dsmpepc_nlp.bench.barn`) runs world N:

- **Obstacles**: every cylinder of the field and of the containment box as an IR-SIM circle of
  radius 0.075 m at its centre (the Gazebo world's own geometry), or with ``cylinders="box"`` as
  its 0.15 m bounding square (what our simulator's 0.05 m map draws of it; docs/irsim.md).
- **Robot**: the Clearpath Jackal as IR-SIM's 0.508 x 0.430 m rectangle (the adapter covers it
  with the three circles of our BARN robot), a ``diff`` robot with our BARN robot's limits:
  ``vel_max = [v_limit, omega_limit]``, ``vel_min = [-reverse_limit, -omega_limit]``, ``acce =
  [accel_limit, alpha_limit]``.
- **Task**: the challenge's start (-2.25, 3.0) facing +y, goal (-2.25, 13.0), success within
  1 m (``goal_threshold``), 100 s (``custom.max_time``); ``custom`` also holds the BARN index
  and the scorer's reference path length, which ``benchmark irsim`` reads back.
- **Lidar**: IR-SIM's ``lidar2d`` as our simulator's Hokuyo UST-10 (:class:`LidarSettings`):
  720 beams over 270 degrees, 0.1-30 m, Gaussian range noise 0.001 m, mounted 0.065 m behind
  the centre.

Every world is read and its text built before any file is written; each file is written
atomically, so an error leaves no half-written world, and existing files stay unless
``overwrite``.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from ..bench import barn
from ..core.errors import InputError
from ..core.files import atomic_write_text
from ..sim.sensing import LidarSettings

STEP_TIME = 0.1
"""IR-SIM's step, s (half our planning period of 0.2 s: two steps a plan)."""
MARGIN = 0.5
"""Free margin around the field in the world's extent, m (our BARN map's ``MAP_MARGIN``)."""
ROUND = 6
"""Decimals written for positions and limits (micrometres)."""
CYLINDERS = ("circle", "box")
"""How a cylinder is written: ``circle`` (its true shape, default) or ``box`` (its 0.15 m
bounding square: exactly what our simulator's 0.05 m map draws of it)."""


def lidar_block(lidar: LidarSettings | None = None) -> dict:
    """IR-SIM's ``lidar2d`` sensor with our simulator's lidar parameters (the UST-10)."""
    lidar = LidarSettings() if lidar is None else lidar
    return {"name": "lidar2d", "range_min": lidar.range_min, "range_max": lidar.range_max,
            "angle_range": round(lidar.fov, ROUND), "number": lidar.beams,
            "noise": lidar.range_noise > 0, "std": lidar.range_noise,
            "offset": [lidar.mount_x, 0.0, 0.0]}


def robot_block(v_limit: float = barn.DEFAULT_V_LIMIT) -> dict:
    """The Jackal as an IR-SIM diff robot with our BARN robot's limits, start, goal, lidar."""
    jackal = barn.jackal_robot(v_limit)
    x, y, heading = barn.START
    return {
        "kinematics": {"name": "diff"},
        "shape": {"name": "rectangle", "length": barn.JACKAL_LENGTH, "width": barn.JACKAL_WIDTH},
        "state": [x, y, round(heading, ROUND)],
        "goal": [barn.GOAL[0], barn.GOAL[1], round(heading, ROUND)],
        "vel_min": [-jackal.reverse_limit, -jackal.omega_limit],
        "vel_max": [jackal.v_limit, jackal.omega_limit],
        "acce": [jackal.accel_limit, jackal.alpha_limit],
        "goal_threshold": barn.SUCCESS_RADIUS,
        "arrive_mode": "position",
        "sensors": [lidar_block()],
    }


def cylinder_shape(cylinders: str = "circle") -> dict:
    """IR-SIM's shape of a cylinder (:data:`CYLINDERS`)."""
    if cylinders == "circle":
        return {"name": "circle", "radius": barn.CYLINDER_RADIUS}
    if cylinders == "box":
        return {"name": "rectangle", "length": barn.CELL, "width": barn.CELL}
    raise InputError(f"--cylinders {cylinders!r}: expected one of {', '.join(CYLINDERS)}")


def world_document(data_dir, index: int, v_limit: float = barn.DEFAULT_V_LIMIT,
                   cylinders: str = "circle") -> dict:
    """The IR-SIM world of BARN world ``index`` of the folder ``data_dir`` (module docstring)."""
    shape = cylinder_shape(cylinders)
    files = barn.world_files(data_dir, index)
    grid = barn.load_grid(files["grid"])
    length = barn.reference_path_length(barn.load_path(files["path"]))
    centres = barn.cylinder_centres(grid)
    xmin, ymin = -4.5 - MARGIN, 0.0 - MARGIN
    xmax, ymax = 0.0 + MARGIN, barn.GOAL[1] + 2.0
    return {
        "world": {"height": ymax - ymin, "width": xmax - xmin, "step_time": STEP_TIME,
                  "sample_time": STEP_TIME, "offset": [xmin, ymin],
                  "collision_mode": "stop", "control_mode": "auto"},
        "custom": {"max_time": barn.TIME_LIMIT, "barn_world": int(index),
                   "reference_path_length": round(length, ROUND)},
        "robot": [robot_block(v_limit)],
        "obstacle": [{
            "number": int(len(centres)), "distribution": {"name": "manual"},
            "shape": shape,
            "state": [[round(float(cx), ROUND), round(float(cy), ROUND), 0.0]
                      for cx, cy in centres]}],
    }


def world_text(data_dir, index: int, v_limit: float = barn.DEFAULT_V_LIMIT,
               cylinders: str = "circle") -> str:
    """:func:`world_document` as YAML, with a header saying where it came from."""
    header = (f"# BARN world {index} as an IR-SIM world, written by 'dsmpepc irsim-export barn'\n"
              f"# (the Jackal, start, goal, 100 s and the UST-10 lidar of 'dsmpepc benchmark "
              f"barn'; docs/irsim.md).\n")
    document = world_document(data_dir, index, v_limit, cylinders)
    return header + yaml.safe_dump(document, sort_keys=False, default_flow_style=None,
                                   width=100)


def export_barn(data_dir, worlds, out_dir, *, v_limit: float = barn.DEFAULT_V_LIMIT,
                cylinders: str = "circle", overwrite: bool = False) -> list[str]:
    """Write ``out_dir/barn-N.yaml`` for every index ``N`` of ``worlds``; the paths written.

    Raises
    ------
    InputError
        A missing or malformed BARN file (naming it), a file already there without
        ``overwrite``, or ``out_dir`` not a folder; nothing is written then.
    """
    data_dir, out_dir = Path(data_dir), Path(out_dir)
    if not data_dir.is_dir():
        raise InputError(f"--data {str(data_dir)!r}: not a folder")
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"--out {str(out_dir)!r}: not a folder")
    cylinder_shape(cylinders)
    texts = {out_dir / f"barn-{int(i)}.yaml": world_text(data_dir, int(i), v_limit, cylinders)
             for i in worlds}
    there = [str(p) for p in texts if p.exists()]
    if there and not overwrite:
        raise InputError(f"--out {str(out_dir)!r}: {len(there)} world file(s) already there "
                         f"({there[0]}, ...); pass --overwrite to replace them")
    out_dir.mkdir(parents=True, exist_ok=True)
    return [str(atomic_write_text(path, text)) for path, text in texts.items()]
