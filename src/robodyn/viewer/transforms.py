"""Homogeneous transforms (4, 4) the scene is built from: rotations, translations, quaternions."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


def rotation_x(angle: float) -> Array:
    """Rotation by ``angle`` [rad] about x, shape (4, 4)."""
    c, s = np.cos(angle), np.sin(angle)
    m = np.eye(4)
    m[1:3, 1:3] = [[c, -s], [s, c]]
    return m


def translation(xyz: Any) -> Array:
    """Translation by ``xyz`` [m], shape (4, 4)."""
    m = np.eye(4)
    m[:3, 3] = xyz
    return m


def translations(xyz: Array) -> Array:
    """One translation per row of ``xyz`` (k, 3) [m], shape (k, 4, 4)."""
    out = np.tile(np.eye(4), (len(xyz), 1, 1))
    out[:, :3, 3] = xyz
    return out


def quaternion_matrix(w: float, x: float, y: float, z: float) -> Array:
    """Rotation matrix (3, 3) of the unit quaternion w + x i + y j + z k."""
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
