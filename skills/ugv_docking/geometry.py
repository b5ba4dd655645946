"""Imaging of the benchmark's border H_GS by the child's up-tilted camera (Zhao et al., §2 and §3.2, eqs. 1-6),
and its inverse: the relative pose (α, x_e, y_e) from the features (u_h, v_h, k_h).

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


def ground_point(u: float, v: float, h: float, theta: float, k_x: float, k_y: float, u_0: float, v_0: float
                 ) -> tuple[float, float]:
    """E = (x_e, y_e) in {R} (m): the ground projection of the point of H_GS imaged at (u, v) (px).

    Eqs. (1) and (4) solved for the point h above the camera: with
    ``t = (v - v_0) / k_y`` and {C}'s ``y = d sin θ - h cos θ``, ``z = d cos θ + h sin θ``,
    ``d = h (cos θ + t sin θ) / (sin θ - t cos θ)``, then ``x = (u - u_0) z / k_x``.
    Raises ``ValueError`` for a ray that does not rise to h in front of the camera.
    """
    t = (v - v_0) / k_y
    s, c = math.sin(theta), math.cos(theta)
    if s - t * c <= 0.0:
        raise ValueError(f"the ray through v = {v:.1f} px does not reach the height of H_GS ahead")
    d = h * (c + t * s) / (s - t * c)
    return (u - u_0) * (d * c + h * s) / k_x, d


def entry_angle(k_h: float, x_e: float, y_e: float, h: float, theta: float, k_x: float, k_y: float) -> float:
    """α ∈ (0, π) (rad) whose k̄_h (eq. 6) at E = (x_e, y_e) (m, {R}) is the measured slope ``k_h``.

    Eq. (6) with ``A = k_y h / (k_x cos θ)`` and ``Y = y_e + h tan θ`` reads
    ``k_h (x_e cos α + Y sin α) = -A cos α``, so ``cot α = -k_h Y / (k_h x_e + A)``.
    """
    a = k_y * h / (k_x * math.cos(theta))
    y = y_e + h * math.tan(theta)
    return math.atan2(abs(k_h * x_e + a), -k_h * y * math.copysign(1.0, k_h * x_e + a))
