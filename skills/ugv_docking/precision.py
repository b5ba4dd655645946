"""Precision analysis of the final docking stage (Zhao et al., §3.4, eqs. 8-16) on the Table 1 parameters.

In the last stage the child sees I_h's ground projection at E = (Δx_e, d_e)
in its frame {R} (Fig. 7) and drives straight in once eq. (7) holds. Its
width deviation Δx_e and entry-direction offset Δα come from the features'
extraction deviations (triple standard deviations, §3.4), the tolerance
margins Δu, Δk of eq. (7) and the camera's optical deviation Δδ; docking
succeeds when eq. (8) holds: ``b_e cos|Δα| / 2 > |Δx_e| + b_c / 2``.

SI units (m, rad) and pixels; the paper's figures are in cm and degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from marsupial.api.model import CAMERA_FOV_V_DEG, CAMERA_RESOLUTION, ENTRANCE_WIDTH_M

from .features import T_N


@dataclass(frozen=True)
class PrecisionParams:
    """The parameters of §3.4, Table 1's values by default.

    Attributes:
        b_e: width of the docking station's entrance b_e (m, Table 1: 19 cm; ``mother_ugv``).
        b_c: width of the child b_c (m, Table 1: 17 cm; ``child_ugv``).
        theta: upward tilt of the camera θ (rad, Table 1: 15°).
        h: height of H_GS above the camera h (m, Table 1: 23 cm).
        width, height: image size W × H (px, Table 1: 640 × 480).
        fov: the camera's field of view θ_f (rad, Table 1: 61°).
        fov_span_px: the image extent θ_f spans (px). Eq. (11) divides by the half
            diagonal, so the paper's default is the diagonal ``√(W² + H²)``; the
            ``child_ugv`` camera has θ_f across its height (480 px, see
            :mod:`marsupial.world.robots.ugv_docking`).
        optical_deviation: optical deviation angle Δδ of the camera (rad, Table 1: < 1.5°).
        t_n: T_N, the smallest candidate group (pixels, Table 1: 32).
        offset_px: spacing of the midpoint checks (px, §3.1: 8).
        border_px: half-spacing of the lateral border check (px, §3.1: 2).
        delta_u: tolerance margin Δu of u_h in eq. (7) (px, Table 1: 5).
        delta_k: tolerance margin Δk of k_h in eq. (7) (Table 1: 0.02).
        d_e: visual perception criterion distance d_e (m, Table 1: 22 cm).
        s_u_e: pre-measured criterion s_u^e of s_u at d_e (px, Table 1: 203).
    """

    b_e: float = ENTRANCE_WIDTH_M
    b_c: float = 0.17
    theta: float = math.radians(15.0)
    h: float = 0.23
    width: int = CAMERA_RESOLUTION[0]
    height: int = CAMERA_RESOLUTION[1]
    fov: float = math.radians(CAMERA_FOV_V_DEG)
    fov_span_px: float = math.hypot(*CAMERA_RESOLUTION)
    optical_deviation: float = math.radians(1.5)
    t_n: int = T_N
    offset_px: int = 8
    border_px: int = 2
    delta_u: float = 5.0
    delta_k: float = 0.02
    d_e: float = 0.22
    s_u_e: int = 203


@dataclass(frozen=True)
class Precision:
    """The figures of §3.4 for one parameter set (see :func:`analyse`).

    Attributes:
        d_uf: D_uf, variance of a candidate square's centre column, eq. (9) (px²).
        e_u: E_u, bound on the standard deviation of u_h, eq. (10) (px).
        d_vi: D_vi, variance of a border point's row, eq. (13) (px²).
        e_k: E_k, standard deviation of k_h, eq. (14).
        delta_epsilon: bound on |Δε|, the bearing of E off the heading, eq. (11) (rad).
        delta_x_e: bound on the width deviation |Δx_e|, eq. (12) (m).
        delta_alpha: bound on the entry-direction offset |Δα|, eq. (16) (rad).
        clearance: ``b_e cos|Δα| / 2`` at the bound, eq. (8)'s left side (m).
        needed: ``|Δx_e| + b_c / 2`` at the bound, eq. (8)'s right side (m).
    """

    d_uf: float
    e_u: float
    d_vi: float
    e_k: float
    delta_epsilon: float
    delta_x_e: float
    delta_alpha: float
    clearance: float
    needed: float

    @property
    def docks(self) -> bool:
        """Eq. (8): the child clears the entrance with the bounded deviations."""
        return self.clearance > self.needed


def square_centre_variance(offset_px: int) -> float:
    """D_uf of eq. (9): variance (px²) of a coordinate uniform over an ``offset_px`` square, ``o²/12``."""
    return offset_px**2 / 12.0  # (1/o²) ∫₀ᵒ∫₀ᵒ (u - o/2)² du dv


def u_h_deviation(d_uf: float, t_n: int) -> float:
    """E_u of eq. (10): ``√(4 D_uf / T_N)`` (px), the bound on u_h's standard deviation over N_G ≥ T_N squares."""
    return math.sqrt(4.0 * d_uf / t_n)


def border_row_variance(border_px: int) -> float:
    """D_vi of eq. (13): variance (px²) of a row uniform within ``±border_px``, ``d²/3``."""
    return border_px**2 / 3.0  # (1/2d) ∫₋ᵈᵈ v² dv


def k_h_deviation(d_vi: float, s_u: int) -> float:
    """E_k of eq. (14): ``√(D_vi / Σ_{i=1}^{s_u} (i - s_u/2)²)``, the standard deviation of k_h over s_u columns."""
    spread = sum((i - s_u / 2.0) ** 2 for i in range(1, s_u + 1))
    return math.sqrt(d_vi / spread)


def bearing_bound(e_u: float, p: PrecisionParams) -> float:
    """|Δε| of eq. (11) (rad): u_h's triple deviation plus Δu through the field of view, plus Δδ."""
    pixels = (3.0 * e_u + p.delta_u) / (p.fov_span_px / 2.0)
    return math.atan(pixels * math.tan(p.fov / 2.0) + math.tan(p.optical_deviation))


def entry_offset_bound(e_k: float, delta_x_e: float, p: PrecisionParams) -> float:
    """|Δα| of eq. (16) (rad), from eq. (15) with k_x ≈ k_y: the offset whose k̄_h stays within 3 E_k + Δk."""
    slope = 3.0 * e_k + p.delta_k
    return math.atan((p.d_e + p.h * math.tan(p.theta)) / abs(p.h / math.cos(p.theta) / slope - abs(delta_x_e)))


def analyse(p: PrecisionParams = PrecisionParams()) -> Precision:
    """Eqs. (9)-(16) and the success condition (8) for the parameters ``p``."""
    d_uf = square_centre_variance(p.offset_px)
    e_u = u_h_deviation(d_uf, p.t_n)
    d_vi = border_row_variance(p.border_px)
    e_k = k_h_deviation(d_vi, p.s_u_e)
    delta_epsilon = bearing_bound(e_u, p)
    delta_x_e = p.d_e * math.tan(delta_epsilon)  # eq. (12): Δx_e = d_e tan(Δε)
    delta_alpha = entry_offset_bound(e_k, delta_x_e, p)
    clearance = p.b_e * math.cos(delta_alpha) / 2.0  # eq. (8)
    needed = delta_x_e + p.b_c / 2.0
    return Precision(d_uf, e_u, d_vi, e_k, delta_epsilon, delta_x_e, delta_alpha, clearance, needed)
