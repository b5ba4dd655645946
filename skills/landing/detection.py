"""Detection and localisation of the red landing platform (Palafox et al. 2019, §3.2, Algorithm 1).

:func:`detect_platform` runs Algorithm 1 on one downward camera frame with
OpenCV, whole-array operations only:

1. RGB → HSV (line 3);
2. red mask, both ends of the hue circle (line 4);
3. Gaussian blur of the mask (line 5);
4. Canny edges (line 6);
5. probabilistic Hough lines on the edges (line 7): a platform must show
   straight sides, so a frame without a line has no platform;
6. polygon fitting (line 8): the outer contour of the edge image, closed
   along the image border where the platform leaves the view; its convex
   hull (the platform is a convex square, and a gap in the Canny edges
   would otherwise fold the contour onto itself, with a near-zero area and
   a meaningless centroid) simplified by ``cv2.approxPolyDP``;
7. centroid from the first-order moments of the polygon (line 9).

Only the region of interest around the mask's bounding box (plus a margin)
goes through steps 3-6. The centroid ``(u, v)`` is lifted to the camera
frame with the inverse pinhole model, eq. (3): ``X = Z (u - c_x) / f_x``,
``Y = Z (v - c_y) / f_y`` with ``Z`` the height from the sonar. Frames taken
while the IMU reports a tilt beyond :attr:`DetectionParams.max_tilt` are
discarded (§3.2).

Beyond the paper, for the last metre of a landing: a platform larger than
the view is cut by the image border, and the centroid of its visible part
is pulled towards the image centre. When the platform's side length is
given (:attr:`DetectionParams.platform_side_m`), each side that is really
seen fixes the centre at half a side (``side · f / Z`` pixels) inside it, so
the polygon is completed to the full square before its moments are taken
(:attr:`Detection.truncated` tells that this happened). When no side is
seen along one of the square's axes (the platform spans the whole view that
way), its centre cannot be located along it and the frame gives no
detection, rather than the visible part's centroid.

Frames: image pixels ``(u, v)`` (u right, v down); the camera frame is
OpenCV's optical frame (x right, y down, z along the optical axis), metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

HSV = tuple[int, int, int]


@dataclass(frozen=True)
class DetectionParams:
    """Settings of :func:`detect_platform` (OpenCV units: H 0-179, S and V 0-255, pixels).

    The paper gives the steps of Algorithm 1 but not their settings; the
    values here are those of the authors' public detection node where it has
    them (HSV red range, polygon tolerance, smallest blob, tilt threshold) and
    OpenCV's usual ones otherwise.

    Attributes:
        red_low, red_high: HSV range of red at the low end of the hue circle (H ≥ 0).
        red_wrap_low, red_wrap_high: HSV range of red at the high end (H ≤ 179).
        blur_ksize: Gaussian blur kernel size (odd, px), sigma from the size.
        canny_low, canny_high: Canny hysteresis thresholds on the blurred 0/255 mask.
        hough_threshold: accumulator votes for a Hough line.
        hough_min_length_px: shortest Hough segment (px).
        hough_max_gap_px: largest gap bridged inside a Hough segment (px).
        approx_epsilon: ``approxPolyDP`` tolerance as a fraction of the contour perimeter.
        min_area_px: smallest polygon area accepted as the platform (px²).
        max_tilt: frames are discarded when the IMU tilt (angle between the body z
            axis and the vertical) exceeds this (rad). The paper names no value; the
            authors' node drops a frame when the x or y component of the IMU
            orientation quaternion reaches π/36, i.e. at a roll or pitch of
            2·asin(π/36) ≈ 10.0°, which is the default.
        platform_side_m: side of the square platform (m) to complete a platform cut
            by the image border; ``None`` keeps the centroid of the visible part (paper).
        roi_margin_px: margin around the mask's bounding box for blur, Canny and Hough (px).
        min_side_support_px: edge pixels along a side needed to count it as seen (completion).
    """

    red_low: HSV = (0, 100, 100)
    red_high: HSV = (10, 255, 255)
    red_wrap_low: HSV = (170, 100, 100)
    red_wrap_high: HSV = (179, 255, 255)
    blur_ksize: int = 5
    canny_low: float = 50.0
    canny_high: float = 150.0
    hough_threshold: int = 15
    hough_min_length_px: float = 10.0
    hough_max_gap_px: float = 3.0
    approx_epsilon: float = 0.02
    min_area_px: float = 50.0
    max_tilt: float = 2.0 * math.asin(math.pi / 36.0)  # ≈ 10°, authors' node (§3.2 gives no value)
    platform_side_m: float | None = None
    roi_margin_px: int = 4
    min_side_support_px: int = 8

    def __post_init__(self) -> None:
        if self.blur_ksize < 1 or self.blur_ksize % 2 == 0:
            raise ValueError(f"blur_ksize must be a positive odd number of pixels, got {self.blur_ksize}")
        if not 0.0 < self.approx_epsilon < 1.0:
            raise ValueError(f"approx_epsilon must be a fraction of the perimeter in (0, 1), got {self.approx_epsilon}")
        if not 0.0 < self.max_tilt < math.pi / 2:
            raise ValueError(f"max_tilt must be in (0, pi/2) rad, got {self.max_tilt}")
        if self.platform_side_m is not None and self.platform_side_m <= 0.0:
            raise ValueError(f"platform_side_m must be > 0 m or None, got {self.platform_side_m}")


@dataclass(frozen=True)
class Detection:
    """The platform found in one frame.

    Attributes:
        centroid_px: ``(u, v)`` of the platform centre (px).
        polygon: ``(N, 2)`` polygon vertices (px); the completed square when truncated.
        area_px: polygon area (px²).
        position_camera: platform centre in the camera's optical frame (m), eq. (3).
        truncated: the platform was cut by the image border.
        lines: ``(M, 4)`` Hough segments ``u1, v1, u2, v2`` (px).
    """

    centroid_px: np.ndarray
    polygon: np.ndarray
    area_px: float
    position_camera: np.ndarray
    truncated: bool
    lines: np.ndarray

    def position_in(self, R_frame_camera: np.ndarray, p_frame_camera: np.ndarray) -> np.ndarray:
        """Platform centre in another frame (m), given the camera's pose in it.

        ``P_frame = R_frame_camera · P_camera + p_frame_camera``: with the body
        frame's camera mount this is ``P_body = T_body_cam P_cam`` (§3.3.1), with
        the camera's world pose (``CameraFrame.rotation``, ``.position``) it is
        ``P_world = T_world_cam P_cam`` (§3.3.2).
        """
        return np.asarray(R_frame_camera, dtype=float) @ self.position_camera + np.asarray(p_frame_camera, dtype=float)


def tilt_of(quaternion: np.ndarray) -> float:
    """Tilt (rad) of a body with world orientation ``[x, y, z, w]``: angle between its z axis and the vertical."""
    x, y, _, _ = (float(c) for c in quaternion)
    return math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y))))


def detect_platform(
    rgb: np.ndarray,
    K: np.ndarray,
    height_m: float,
    tilt_rad: float,
    params: DetectionParams = DetectionParams(),
) -> Detection | None:
    """Find the red platform in an RGB frame (Algorithm 1) and locate it in the camera frame.

    Args:
        rgb: ``(h, w, 3)`` uint8 image.
        K: 3×3 camera matrix (px).
        height_m: ``Z``, distance from the optical centre to the platform plane
            along the optical axis (m), from the sonar.
        tilt_rad: IMU tilt of the vehicle (rad), see :func:`tilt_of`.
        params: detection settings.

    Returns:
        The :class:`Detection`, or ``None`` when the frame is discarded (tilt
        beyond ``params.max_tilt``, no valid height), shows no platform, or
        (with ``params.platform_side_m``) shows a platform cut by the border
        whose centre cannot be located (no side seen along one axis).
    """
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
        raise ValueError(f"rgb must be an (h, w, 3) uint8 image, got {rgb.shape} {rgb.dtype}")
    if not tilt_rad <= params.max_tilt or not (math.isfinite(height_m) and height_m > 0.0):
        return None
    p = params
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)  # line 3
    mask = cv2.inRange(hsv, p.red_low, p.red_high)  # line 4, both ends of the hue circle
    cv2.bitwise_or(mask, cv2.inRange(hsv, p.red_wrap_low, p.red_wrap_high), dst=mask)
    bx, by, bw, bh = cv2.boundingRect(mask)
    if bw * bh < p.min_area_px:
        return None
    rows, cols = mask.shape
    x0, y0 = max(bx - p.roi_margin_px, 0), max(by - p.roi_margin_px, 0)
    x1, y1 = min(bx + bw + p.roi_margin_px, cols), min(by + bh + p.roi_margin_px, rows)
    mask_roi = mask[y0:y1, x0:x1]
    blurred = cv2.GaussianBlur(mask_roi, (p.blur_ksize, p.blur_ksize), 0)  # line 5
    edges = cv2.Canny(blurred, p.canny_low, p.canny_high)  # line 6
    lines = cv2.HoughLinesP(  # line 7
        edges, 1.0, math.pi / 180.0, p.hough_threshold,
        minLineLength=p.hough_min_length_px, maxLineGap=p.hough_max_gap_px,
    )
    if lines is None:
        return None
    lines = lines.reshape(-1, 4).astype(float) + (x0, y0, x0, y0)
    # line 8: outer contour of the edges, closed along the image border the platform crosses
    edge_px = cv2.findNonZero(edges) if p.platform_side_m is not None else None  # the sides, before closing
    border = _close_along_image_border(edges, blurred, (x0 == 0, y0 == 0, x1 == cols, y1 == rows))
    contours, _ = cv2.findContours(edges, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    hulls = [cv2.convexHull(c) for c in contours]  # a gap in the edges must not fold the outline onto itself
    k = max(range(len(contours)), key=lambda i: cv2.contourArea(hulls[i]))
    contour, hull = contours[k], hulls[k]
    polygon = cv2.approxPolyDP(hull, p.approx_epsilon * cv2.arcLength(hull, True), True)
    polygon = polygon.reshape(-1, 2).astype(float) + (x0, y0)
    truncated = border and bool(_on_border(contour.reshape(-1, 2) + (x0, y0), cols, rows).any())
    if truncated and p.platform_side_m is not None and edge_px is not None:
        side_px = p.platform_side_m * 0.5 * (K[0, 0] + K[1, 1]) / height_m
        contour_px = contour.reshape(-1, 2).astype(float) + (x0, y0)
        edge_px = edge_px.reshape(-1, 2).astype(float) + (x0, y0)
        completed = _complete_square(polygon, contour_px, edge_px, lines, side_px, cols, rows, p.min_side_support_px)
        if completed is None:
            return None
        polygon = completed
    m = cv2.moments(polygon.astype(np.float32))  # line 9: first-order moments of the polygon area
    if m["m00"] < p.min_area_px:
        return None
    u, v = m["m10"] / m["m00"], m["m01"] / m["m00"]
    position_camera = height_m * np.array([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], 1.0])  # eq. (3)
    return Detection(np.array([u, v]), polygon, float(m["m00"]), position_camera, bool(truncated), lines)


def _close_along_image_border(
    edges: np.ndarray, blurred: np.ndarray, at_border: tuple[bool, bool, bool, bool]
) -> bool:
    """Draw the blurred mask's support on the image border into ``edges`` (in place); True if any was drawn.

    ``at_border``: the region's left, top, right and bottom sides lie on the
    image border. Canny finds no edge where the platform leaves the view, so
    the outline is closed there by the border itself; the blurred mask
    reaches the Canny edges of the sides that cross the border, the mask
    itself may stop a pixel or two short of them.
    """
    left, top, right, bottom = at_border
    sides = ((left, (slice(None), 0)), (top, (0, slice(None))), (right, (slice(None), -1)), (bottom, (-1, slice(None))))
    drawn = False
    for on_border, index in sides:
        support = blurred[index] > 0
        if on_border and support.any():
            edges[index][support] = 255
            drawn = True
    return drawn


def _on_border(points: np.ndarray, width: int, height: int) -> np.ndarray:
    """Which of the ``(N, 2)`` pixel points lie on the border of a ``width`` × ``height`` image."""
    u, v = points[:, 0], points[:, 1]
    return (u <= 0) | (v <= 0) | (u >= width - 1) | (v >= height - 1)


def _complete_square(
    polygon: np.ndarray,
    contour: np.ndarray,
    edge_px: np.ndarray,
    lines: np.ndarray,
    side_px: float,
    width: int,
    height: int,
    min_support: int,
) -> np.ndarray | None:
    """The full square of side ``side_px`` whose seen sides match a platform cut by the image border.

    The square's orientation comes from the Hough segments (length-weighted
    mean of 4·angle, as the sides repeat every 90°), refined by line fits of
    the edge pixels of the seen sides. Along each of the square's two axes a
    side is *seen* when at least ``min_support`` edge pixels lie at the
    extreme of the outline's points off the image border: two seen sides put
    the centre halfway between them, one puts it ``side_px / 2`` inside it.
    Returns ``None`` when no side is seen along one axis: the centre is then
    not observable that way.
    """
    edge_px = edge_px[~_on_border(edge_px, width, height)]
    contour = contour[~_on_border(contour, width, height)]
    m = cv2.moments(polygon.astype(np.float32))
    visible_centroid = np.array([m["m10"], m["m01"]]) / max(m["m00"], 1e-9)
    du, dv = lines[:, 2] - lines[:, 0], lines[:, 3] - lines[:, 1]
    theta = _mean_side_angle(np.arctan2(dv, du), np.hypot(du, dv))
    fits = [
        cv2.fitLine(edge_px[support].astype(np.float32), cv2.DIST_L2, 0, 0.01, 0.01)[:2, 0]
        for axis in _axes(theta)
        for _, support in _seen_sides(axis, contour, edge_px, visible_centroid, min_support)
    ]
    if fits:
        directions = np.asarray(fits)
        theta = _mean_side_angle(np.arctan2(directions[:, 1], directions[:, 0]), np.ones(len(directions)))
    centre = np.zeros(2)
    for axis in _axes(theta):
        sides = [
            (inward, float((edge_px[support] @ axis).mean()))
            for inward, support in _seen_sides(axis, contour, edge_px, visible_centroid, min_support)
        ]
        if len(sides) == 2:
            along = 0.5 * (sides[0][1] + sides[1][1])
        elif len(sides) == 1:
            inward, offset = sides[0]
            along = offset + inward * 0.5 * side_px
        else:
            return None
        centre += along * axis
    half = 0.5 * side_px
    return centre + np.array([[-half, -half], [half, -half], [half, half], [-half, half]]) @ _axes(theta)


def _mean_side_angle(angles: np.ndarray, weights: np.ndarray) -> float:
    """Weighted mean direction (rad) of lines along the sides of a square (angles taken modulo 90°)."""
    return float(np.angle(np.sum(weights * np.exp(4j * angles)))) / 4.0


def _axes(theta: float) -> np.ndarray:
    """The square's two side directions (rows, unit vectors in pixels) for orientation ``theta``."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, s], [-s, c]])


def _seen_sides(
    axis: np.ndarray, contour: np.ndarray, edge_px: np.ndarray, visible_centroid: np.ndarray, min_support: int
) -> list[tuple[float, np.ndarray]]:
    """Sides of the outline perpendicular to ``axis`` that are real platform edges.

    Returns ``(inward, support)`` per seen side: ``inward`` is +1 for the side
    at the outline's minimum along ``axis`` (the platform lies towards +axis)
    and -1 for the one at its maximum; ``support`` selects the edge pixels
    within 2 px of that side. A side counts only when the visible part of
    the platform (``visible_centroid``, px) lies on its inner side: a single
    straight edge across the view is both the outline's minimum and maximum,
    and only the red region beside it tells which side of the platform it is.
    """
    if len(contour) == 0:
        return []
    outline, along = contour @ axis, edge_px @ axis  # outline: off-border contour points
    inside = float(visible_centroid @ axis)
    sides = []
    for inward, extreme in ((1.0, outline.min()), (-1.0, outline.max())):
        support = np.abs(along - extreme) <= 2.0
        if inward * (inside - extreme) > 0.0 and np.count_nonzero(support) >= min_support:
            sides.append((inward, support))
    return sides
