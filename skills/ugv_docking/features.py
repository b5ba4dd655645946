"""Benchmark features in one child-camera frame (Zhao et al., §3.1): I_h = (u_h, v_h), k_h, s_u and N_G.

The benchmark is a 2×2 red/green checkerboard, red top-left and bottom-right
as the approaching child sees it; H_GS is its horizontal colour border and
I_h the crossing of the two borders. :func:`extract_features` follows §3.1
with whole-array operations only (numpy shifted masks, OpenCV connected
components), no per-pixel Python loop:

1. main colour of every pixel: red (green) where that channel exceeds both
   others by :attr:`FeatureParams.colour_margin` ("loose colour attributes");
2. midpoint candidates: a pixel (i, j) (row i, column j) whose main colour is
   red and (i, j+8), (i+8, j+8), (i+8, j) green, red, green — four shifted
   masks ANDed; the crossing then lies inside the 8×8 square spanned by the
   four, so each candidate stands for that square's centre (i+4, j+4);
3. candidates grouped by 8-connected components, the largest group kept if it
   has N_G ≥ T_N pixels; I_h is the mean of its squares' centres;
4. lateral border points: (u, v) with red at (u, v-2) and green at (u, v+2)
   (left of I_h), or green above and red below (right of I_h); the
   connected runs of them that reach I_h's 8×8 square are H_GS. Each
   column's border points are averaged into one point (u_i, v_i); s_u is the
   horizontal length of H_GS, ``u_max - u_min + 1`` (px), and k_h the least
   squares slope of eq. (5) through the (u_i, v_i).

Frames: image pixels, u right (column), v down (row), origin at the top-left
pixel's centre; k_h = dv/du (so a border rising to the right is negative, as in
Remark 1). Units: pixels, k_h dimensionless. The input is the ``rgb`` array of the
:class:`~marsupial.api.readings.CameraImage` that the child's ``camera`` port
delivers (``robot.sensor("camera").read().data.rgb``).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

T_N = 32  # threshold on the candidate group's size N_G, Table 1


@dataclass(frozen=True)
class FeatureParams:
    """Settings of :func:`extract_features` (pixels and 0-255 intensities).

    Attributes:
        offset_px: spacing of the midpoint checks, the "+8" of §3.1 (px).
        border_px: vertical half-spacing of the lateral border check, the "±2" of §3.1 (px).
        min_group: T_N, the smallest candidate group accepted as the benchmark (pixels, Table 1).
        colour_margin: a channel is a pixel's main component when it exceeds the two others by
            this much (0-255). Chosen: the rendered red and green blocks exceed their other
            channels by > 100 under the camera's exposure and white-balance errors, the grey
            floor, walls and robot bodies by < 25.
    """

    offset_px: int = 8
    border_px: int = 2
    min_group: int = T_N
    colour_margin: int = 50

    def __post_init__(self) -> None:
        if self.offset_px < 1 or self.border_px < 1:
            raise ValueError(f"offset_px and border_px must be >= 1 px, got {self.offset_px}, {self.border_px}")
        if self.min_group < 1:
            raise ValueError(f"min_group (T_N) must be >= 1, got {self.min_group}")
        if not 0 <= self.colour_margin < 255:
            raise ValueError(f"colour_margin must be within [0, 255), got {self.colour_margin}")


@dataclass(frozen=True)
class BenchmarkFeatures:
    """The benchmark's image features in one frame (§2, §3.1).

    Attributes:
        u_h, v_h: I_h, the crossing of the colour borders (px; u right, v down).
        k_h: imaging slope of H_GS, dv/du of the least-squares line, eq. (5) (dimensionless).
        s_u: horizontal length of H_GS, columns from its leftmost to its rightmost border point (px).
        n_g: N_G, the size of the chosen candidate group (pixels).
        image_width: W, the width of the frame (px), for the centring test of eq. (7).
    """

    u_h: float
    v_h: float
    k_h: float
    s_u: int
    n_g: int
    image_width: int


def main_colours(rgb: np.ndarray, margin: int) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks ``(h, w)`` of the pixels whose main component is red, and green (§3.1).

    ``rgb`` is ``(h, w, 3)`` uint8; a channel is the main one where it exceeds both
    other channels by more than ``margin`` (0-255).
    """
    r, g, b = cv2.split(rgb)
    red = cv2.subtract(r, cv2.max(g, b)) > margin  # saturating: 0 where red is not the largest
    green = cv2.subtract(g, cv2.max(r, b)) > margin
    return red, green


def midpoint_candidates(red: np.ndarray, green: np.ndarray, offset: int) -> np.ndarray:
    """Midpoint candidates of §3.1 as a uint8 mask ``(h - o, w - o)`` for o = ``offset`` (px).

    1 at (i, j) (row i, column j) where (i, j), (i, j+o), (i+o, j+o) and
    (i+o, j) are red, green, red and green: four shifted views ANDed.
    """
    o = offset
    return (red[:-o, :-o] & green[:-o, o:] & red[o:, o:] & green[o:, :-o]).view(np.uint8)


def _largest_group(candidates: np.ndarray) -> tuple[int, float, float] | None:
    """N_G and the mean column and row of the largest 8-connected candidate group (``None``: no candidate)."""
    x, y, w, h = cv2.boundingRect(candidates)
    if w == 0:
        return None
    _, _, stats, centroids = cv2.connectedComponentsWithStats(candidates[y : y + h, x : x + w], connectivity=8)
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return int(stats[k, cv2.CC_STAT_AREA]), float(centroids[k, 0]) + x, float(centroids[k, 1]) + y


def border_points(
    red: np.ndarray, green: np.ndarray, u_h: float, v_h: float, params: FeatureParams
) -> tuple[np.ndarray, np.ndarray]:
    """H_GS as one point per image column: ``(u_i, v_i)`` arrays (px), u increasing.

    Lateral border points (red above / green below, or green above / red
    below, at ``±border_px``) are grouped into 8-connected runs; the runs whose
    bounding box reaches the ``offset_px`` square around I_h = (u_h, v_h) are
    kept, and the rows of each column's points averaged.
    """
    d = params.border_px
    above, below = slice(None, -2 * d), slice(2 * d, None)
    border = ((red[above] & green[below]) | (green[above] & red[below])).view(np.uint8)  # row r is v = r + d
    x, y, w, h = cv2.boundingRect(border)
    if w == 0:
        return np.empty(0), np.empty(0)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(border[y : y + h, x : x + w], connectivity=8)
    left, top = stats[1:, cv2.CC_STAT_LEFT] + x, stats[1:, cv2.CC_STAT_TOP] + y + d
    right, bottom = left + stats[1:, cv2.CC_STAT_WIDTH] - 1, top + stats[1:, cv2.CC_STAT_HEIGHT] - 1
    half = params.offset_px / 2
    reach = (left <= u_h + half) & (right >= u_h - half) & (top <= v_h + half) & (bottom >= v_h - half)
    keep = np.flatnonzero(np.concatenate(([False], reach)))
    if keep.size == 0:
        return np.empty(0), np.empty(0)
    rows, cols = np.nonzero(np.isin(labels, keep))
    counts = np.bincount(cols)
    used = np.flatnonzero(counts)
    v_i = np.bincount(cols, weights=rows)[used] / counts[used] + (y + d)
    return used.astype(float) + x, v_i


def least_squares_slope(u: np.ndarray, v: np.ndarray) -> float:
    """k_h of eq. (5): the least-squares slope dv/du through the points ``(u_i, v_i)`` (px); needs two columns."""
    du = u - u.mean()
    return float(du @ (v - v.mean()) / (du @ du))


def extract_features(rgb: np.ndarray, params: FeatureParams = FeatureParams()) -> BenchmarkFeatures | None:
    """The benchmark's features (u_h, v_h, k_h, s_u, N_G) in an ``(h, w, 3)`` uint8 RGB frame (§3.1).

    ``None`` when the benchmark is not captured: no candidate group of
    ``min_group`` (T_N) pixels, or fewer than two columns of H_GS.
    """
    red, green = main_colours(rgb, params.colour_margin)
    group = _largest_group(midpoint_candidates(red, green, params.offset_px))
    if group is None or group[0] < params.min_group:
        return None
    n_g, mean_j, mean_i = group
    u_h, v_h = mean_j + params.offset_px / 2, mean_i + params.offset_px / 2  # the squares' centres, §3.4
    u_i, v_i = border_points(red, green, u_h, v_h, params)
    if u_i.size < 2:
        return None
    s_u = int(u_i[-1] - u_i[0]) + 1
    return BenchmarkFeatures(u_h, v_h, least_squares_slope(u_i, v_i), s_u, n_g, int(rgb.shape[1]))
