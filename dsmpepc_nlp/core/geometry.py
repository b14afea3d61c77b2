"""Where a body-frame point of a robot is in the world: one formula for numpy and CasADi."""

from __future__ import annotations

import numpy as np


def body_to_world(pose, cx, cy, ops=np):
    """World ``(x, y)`` of the body-frame point ``(cx, cy)`` of a robot at ``pose = (x, y, phi)``.

    ``ops`` is any namespace with ``cos`` and ``sin`` (numpy, or ``casadi`` for symbols);
    the arguments broadcast.
    """
    cos, sin = ops.cos(pose[2]), ops.sin(pose[2])
    return pose[0] + cos * cx - sin * cy, pose[1] + sin * cx + cos * cy


def footprint_points(poses, footprint) -> np.ndarray:
    """World positions of footprint circles, ``(..., C, 2)``, for poses ``(..., 3)``.

    ``footprint`` holds body-frame circles ``(cx, cy[, radius])``, shape ``(C, 2 or 3)``.
    """
    poses = np.asarray(poses, dtype=float)
    circles = np.asarray(footprint, dtype=float)
    x, y = body_to_world((poses[..., 0:1], poses[..., 1:2], poses[..., 2:3]),
                         circles[:, 0], circles[:, 1])
    return np.stack([x, y], axis=-1)
