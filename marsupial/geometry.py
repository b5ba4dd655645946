"""Rigid-body helpers shared by the world and the skills: quaternions, headings, rotations (numpy only).

Quaternions are ``[x, y, z, w]`` (pybullet's order); angles rad; rotation
matrices 3×3 with columns the rotated frame's axes in the reference frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TypeAlias

import numpy as np

#: a vector argument: a sequence of floats or a numpy array (m, rad, as the parameter says)
Vector: TypeAlias = Sequence[float] | np.ndarray


def rotation_matrix(quaternion: Vector) -> np.ndarray:
    """3×3 rotation matrix of an ``[x, y, z, w]`` quaternion (normalised first)."""
    x, y, z, w = (float(v) for v in quaternion)
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def quaternion_from_matrix(R: np.ndarray) -> np.ndarray:
    """``[x, y, z, w]`` quaternion of a 3×3 rotation matrix (w ≥ 0)."""
    m = np.asarray(R, dtype=float)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    out = np.array(q)
    return -out if out[3] < 0 else out


def yaw_of(quaternion: Vector) -> float:
    """Heading (rad) about the reference z axis of an ``[x, y, z, w]`` quaternion."""
    x, y, z, w = quaternion
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def yaw_of_rotation(R: np.ndarray) -> float:
    """Heading (rad) of the rotation ``R``: the angle of its x axis about z."""
    return math.atan2(R[1, 0], R[0, 0])


def quaternion_from_yaw(yaw: float) -> np.ndarray:
    """``[x, y, z, w]`` quaternion of a turn of ``yaw`` rad about z."""
    return np.array([0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)])



def rot_z(angle: float) -> np.ndarray:
    """3×3 rotation by ``angle`` rad about z."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def heading_rotation(yaw: float) -> np.ndarray:
    """``R_heading_ref`` (2×2): reference x-y into the heading frame of a vehicle with heading ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, s], [-s, c]])


def transform(position: Vector, R: np.ndarray) -> np.ndarray:
    """4×4 homogeneous transform of a position (m) and a 3×3 rotation."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = position
    return T
