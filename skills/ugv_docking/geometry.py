"""Imaging of the benchmark's border H_GS by the child's up-tilted camera (Zhao et al., §2 and §3.2, eqs. 1-6).

Frames as in the paper: {C} the camera frame (OpenCV optical frame: x right,
y down, z along the optical axis), {R} the child's ground frame (origin under
the camera, Y_R along the child's heading, X_R to its right). H_GS is a
horizontal segment h above the camera; its projection H'_GS on the ground
passes through E = (x_e, y_e), the projection of I_h, with normal
VE = (cos α, sin α) in {R}, α ∈ (0, π) the entry angle (α = π/2: the child
heads along the entry direction). θ ∈ (0, π/2) is the camera's upward tilt.
Metres and radians; image coordinates in pixels (u right, v down).
"""

from __future__ import annotations

import math


def border_point_image(
    d: float, alpha: float, x_e: float, y_e: float, h: float, theta: float, k_x: float, k_y: float,
    u_0: float, v_0: float,
) -> tuple[float, float]:
    """Image coordinates (u_p, v_p) (px) of the point P of H_GS at forward distance ``d`` (m, Y_R) from the camera.

    Eq. (1) gives P's y and z in {C}, eq. (3) its x, eq. (4) the pinhole
    projection with scale factors ``k_x``, ``k_y`` and principal point ``(u_0, v_0)`` (px).
    """
    c_y = (d + h * math.tan(theta)) * math.sin(theta) - h / math.cos(theta)  # eq. (1)
    c_z = (d + h * math.tan(theta)) * math.cos(theta)
    c_x = x_e - (d - y_e) * math.tan(alpha)  # eq. (3)
    return k_x * c_x / c_z + u_0, k_y * c_y / c_z + v_0  # eq. (4)


def theoretical_slope(alpha: float, x_e: float, y_e: float, h: float, theta: float, k_x: float, k_y: float) -> float:
    """k̄_h of eq. (6): the imaging slope dv/du of H_GS (dimensionless) for the relative pose (α, x_e, y_e).

    ``h`` (m) is H_GS's height above the camera, ``theta`` (rad) the camera's
    upward tilt, ``k_x``, ``k_y`` (px) its scale factors. Under eq. (2)
    (``x_e cos α + y_e sin α > 0``: H_GS faces the camera) the denominator is
    positive, so the sign is that of ``-cos α`` (Remark 1): 0 at α = π/2, negative below.
    """
    c, s = math.cos(alpha), math.sin(alpha)
    return -k_y * h * c / (k_x * (x_e * c + y_e * s + h * math.tan(theta) * s) * math.cos(theta))
