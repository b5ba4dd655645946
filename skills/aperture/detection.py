"""Aperture detection (Arora & Papachristos, §IV-B; Algorithm 1 part 1) from eye-in-hand depth frames.

1. An N-frame sliding window of dense point clouds D_S^N, each frame placed
   with the pose its camera had (the MMS's base estimate composed with the
   arm's forward kinematics at the encoder angles: :func:`eye_in_hand_frame`),
   all expressed in F_I: a frame coincident with the newest sensor frame F_S
   by position and azimuth, and inertially aligned (gravity-levelled).
2. RANSAC of the major model plane αx + βy + γz = δ with the constraint
   arccos(n̂·ẑ) ≤ θ_p = 45° (ẑ of F_I), which keeps the ground plane out.
3. Fronto-parallel view: the cloud rotated by R_fp, the rotation taking -n̂
   onto ẑ (the plane perpendicular to the depth axis), and projected with a
   pinhole of the camera's focal length into a floating-point depth image I.
4. I_binary (the model plane's pixels) → dilation → Canny → contours A_S.
5. A contour is a candidate aperture when it is hollow (its inside lies
   deeper than the plane by more than d_C) and wider than the MAV (its area
   exceeds that of C_m at the plane depth, :func:`~.silhouette.mav_contour`).

Frames and units: metres, radians. F_I axes (OpenCV-like, levelled): z
horizontal along the sensor's azimuth, y down (gravity), x = y × z to the
right; origin at the newest frame's optical centre. The navigation frame is
that of the base estimate (``odom``). Image I: pixels (u right, v down) of
a virtual camera at F_I's origin looking along -n̂.

Interpretations (the paper gives no more detail): n̂ is oriented toward the
sensor and the constraint is applied to |n̂·ẑ| (a plane's normal has no
sign); the window's frames are assumed taken while the base stands (its
estimate at the newest frame places all of them) with the encoder angles of
each frame's stamp given by the caller. The dilation grows the plane mask, so
the contours lie about ``dilation_px`` inside the openings (conservative).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from marsupial.api.silhouette import MAV_URDF, mav_contour
from marsupial.geometry import rotation_matrix

CAMERA_LINK = "camera_link"  # link of the MMS's eye-in-hand camera (mms.urdf); its optical frame is R_link_optical


@dataclass(frozen=True)
class DetectionParams:
    """Parameters of aperture detection (§IV-B); θ_p from the paper, the others chosen (the paper gives none).

    Attributes:
        n_frames: N, frames of the sliding window D_S^N.
        theta_p: θ_p (rad), largest angle of the plane normal from F_I's ẑ (§IV-B: 45°).
        plane_tolerance_m: RANSAC inlier distance from the plane (m), also the model plane's band in I.
        ransac_iterations: plane hypotheses drawn.
        ransac_sample: points scored per hypothesis (a random subset of the cloud).
        d_c: d_C, depth beyond the plane (m) that makes a region hollow (Definition 1).
        dilation_px: radius (px) of the dilation of I_binary.
        canny_thresholds: hysteresis thresholds of Canny on I_binary (0/255).
        stride_px: every how many depth pixels a point is taken (1: all).
        max_image_px: the fronto-parallel image is at most this wide and high (px).
        seed: RANSAC's random seed (the detection is deterministic).
    """

    n_frames: int = 3
    theta_p: float = math.radians(45.0)
    plane_tolerance_m: float = 0.01
    ransac_iterations: int = 200
    ransac_sample: int = 4000
    d_c: float = 0.05
    dilation_px: int = 1
    canny_thresholds: tuple[float, float] = (50.0, 150.0)
    stride_px: int = 1
    max_image_px: int = 1280
    seed: int = 0


@dataclass(frozen=True)
class DepthFrame:
    """One eye-in-hand depth frame and the camera pose it was taken from, as the robot's computer knows it.

    Attributes:
        depth: ``(h, w)`` metres along the optical axis (``CameraImage.depth``); values ≥ ``far`` are no return.
        K: 3×3 intrinsics (px).
        position: optical centre in the navigation frame (m).
        rotation: ``R_nav_optical`` (OpenCV optical frame: x right, y down, z along the axis).
        far: the camera's far clip (m): depth at or beyond it measured nothing.
    """

    depth: np.ndarray
    K: np.ndarray
    position: np.ndarray
    rotation: np.ndarray
    far: float = 10.0


@dataclass(frozen=True)
class InertialFrame:
    """F_I: at ``position`` (nav frame, m), z horizontal along the sensor's azimuth, y down; ``R_nav_I`` its axes."""

    position: np.ndarray
    R_nav_I: np.ndarray

    def to_nav(self, p_I: np.ndarray) -> np.ndarray:
        """Points ``(..., 3)`` of F_I in the navigation frame (m)."""
        return np.asarray(p_I) @ self.R_nav_I.T + self.position


@dataclass(frozen=True)
class FrontoParallelView:
    """The fronto-parallel depth image I of the model plane and how its pixels map to F_I.

    Attributes:
        depth: ``(h, w)`` float32 I: depth (m) of the nearest point at or behind the plane, NaN where none.
        binary: ``(h, w)`` uint8 I_binary: 255 on the model plane.
        K: 3×3 intrinsics of the virtual camera (px; focal length of the sensor's).
        R_fp: rotation F_I → fronto-parallel frame (``p_fp = R_fp p_I``); the plane is at z = ``plane_depth``.
        plane_depth: distance (m) of the plane from F_I's origin.
    """

    depth: np.ndarray
    binary: np.ndarray
    K: np.ndarray
    R_fp: np.ndarray
    plane_depth: float

    def pixel_to_I(self, pixels: np.ndarray) -> np.ndarray:
        """Pixels ``(..., 2)`` of I to points of the model plane in F_I (m)."""
        px = np.asarray(pixels, dtype=float)
        d = self.plane_depth
        fp = np.stack(((px[..., 0] - self.K[0, 2]) * d / self.K[0, 0],
                       (px[..., 1] - self.K[1, 2]) * d / self.K[1, 1], np.full(px.shape[:-1], d)), axis=-1)
        return fp @ self.R_fp  # R_fp^T p_fp, row-wise


@dataclass(frozen=True)
class ApertureCandidate:
    """One candidate aperture of A_S that is hollow and wider than the MAV (§IV-B).

    Attributes:
        contour_px: C_a, ``(n, 2)`` px in the fronto-parallel image I (``view``).
        area_px: its area (px²).
        mav_area_px: the area of C_m at the plane depth (px²) it was compared with.
        depth_beyond_m: median depth of its inside beyond the plane (m; ``inf`` when nothing returned).
        normal_I: n̂, unit normal of the model plane in F_I, toward the sensor.
        centre_I: the contour's centroid on the plane in F_I (m).
        frame: F_I (to map ``normal_I`` and ``centre_I`` to the navigation frame).
        view: the fronto-parallel image it was found in.
    """

    contour_px: np.ndarray
    area_px: float
    mav_area_px: float
    depth_beyond_m: float
    normal_I: np.ndarray
    centre_I: np.ndarray
    frame: InertialFrame
    view: FrontoParallelView = field(repr=False)

    @property
    def normal_nav(self) -> np.ndarray:
        """n̂ in the navigation frame."""
        return self.frame.R_nav_I @ self.normal_I

    @property
    def centre_nav(self) -> np.ndarray:
        """The aperture's centre in the navigation frame (m)."""
        return self.frame.to_nav(self.centre_I)

    @property
    def box_centre_nav(self) -> np.ndarray:
        """The centre of C_a's bounding box in I, on the plane, in the navigation frame (m): the point a view
        of the whole opening is centred on (a U's centroid lies off it, toward its bar)."""
        mid = (self.contour_px.min(axis=0) + self.contour_px.max(axis=0)) / 2.0
        return self.frame.to_nav(self.view.pixel_to_I(mid))

    def mask(self) -> np.ndarray:
        """The aperture's region in I (uint8, 255 inside C_a): the input of :func:`~.profile.profile_analysis`."""
        mask = np.zeros(self.view.binary.shape, np.uint8)
        cv2.drawContours(mask, [self.contour_px.reshape(-1, 1, 2).astype(np.int32)], -1, 255, thickness=cv2.FILLED)
        return mask


def eye_in_hand_frame(onboard: Any, depth: np.ndarray, K: np.ndarray, q: np.ndarray,
                      camera: str = "camera") -> DepthFrame:
    """A :class:`DepthFrame` posed from the MMS's onboard interface: base estimate ∘ arm FK(q) ∘ camera mount.

    ``onboard``: the MMS's interface (``arm_base_pose()``, ``arm_kinematics``, ``sensor(camera)``); ``q``: the
    arm's encoder angles (rad) when the frame was taken; ``depth``, ``K``: the frame's ``CameraImage`` fields.
    """
    p_M, q_M = onboard.arm_base_pose()
    R_M = rotation_matrix(q_M)
    p_link, R_link = onboard.arm_kinematics.forward(q, CAMERA_LINK)
    port = onboard.sensor(camera)
    position = p_M + R_M @ (p_link + R_link @ np.asarray(port.offset, dtype=float))
    rotation = R_M @ R_link @ np.asarray(port.R_link_optical, dtype=float)
    return DepthFrame(np.asarray(depth), np.asarray(K), position, rotation, float(port.intrinsics.far))


def inertial_frame(frame: DepthFrame) -> InertialFrame:
    """F_I of ``frame``: at its optical centre, z along the optical axis's azimuth (levelled), y down."""
    axis = frame.rotation[:, 2]
    forward = np.array([axis[0], axis[1], 0.0])
    if np.linalg.norm(forward) < 1e-6:  # looking straight up or down: the image's up sets the azimuth
        forward = np.array([-frame.rotation[0, 1], -frame.rotation[1, 1], 0.0])
    z = forward / np.linalg.norm(forward)
    y = np.array([0.0, 0.0, -1.0])
    return InertialFrame(frame.position.copy(), np.c_[np.cross(y, z), y, z])


def window_cloud(frames: Sequence[DepthFrame], params: DetectionParams) -> tuple[np.ndarray, InertialFrame]:
    """D_S^N in F_I: the measured points (m) of the last ``n_frames`` frames, in F_I of the newest."""
    window = list(frames)[-params.n_frames :]
    frame_I = inertial_frame(window[-1])
    clouds = []
    for f in window:
        z = f.depth[:: params.stride_px, :: params.stride_px].astype(float)
        v, u = np.mgrid[0 : f.depth.shape[0] : params.stride_px, 0 : f.depth.shape[1] : params.stride_px]
        ok = (z > 0) & (z < f.far * 0.999) & np.isfinite(z)
        z, u, v = z[ok], u[ok], v[ok]
        optical = np.stack(((u - f.K[0, 2]) * z / f.K[0, 0], (v - f.K[1, 2]) * z / f.K[1, 1], z), axis=1)
        nav = optical @ f.rotation.T + f.position
        clouds.append((nav - frame_I.position) @ frame_I.R_nav_I)
    return np.concatenate(clouds), frame_I


def ransac_plane(points: np.ndarray, params: DetectionParams) -> tuple[np.ndarray, float] | None:
    """The major plane n̂·p = δ of ``points`` (F_I, m) with arccos(|n̂·ẑ|) ≤ θ_p; n̂ toward the origin (δ < 0).

    Hypotheses from random triples, all scored at once on a random subset, the best refined by least squares
    on its inliers. ``None`` when no hypothesis satisfies the constraint.
    """
    rng = np.random.default_rng(params.seed)
    triples = points[rng.integers(0, len(points), size=(params.ransac_iterations, 3))]
    normals = np.cross(triples[:, 1] - triples[:, 0], triples[:, 2] - triples[:, 0])
    norm = np.linalg.norm(normals, axis=1)
    keep = norm > 1e-9
    normals, anchors = normals[keep] / norm[keep, None], triples[keep, 0]
    keep = np.abs(normals[:, 2]) >= math.cos(params.theta_p)  # arccos(n̂·ẑ) ≤ θ_p (§IV-B)
    normals, anchors = normals[keep], anchors[keep]
    if not len(normals):
        return None
    deltas = np.einsum("ij,ij->i", normals, anchors)
    sample = points[rng.choice(len(points), size=min(params.ransac_sample, len(points)), replace=False)]
    score = (np.abs(sample @ normals.T - deltas) <= params.plane_tolerance_m).sum(axis=0)
    best = int(np.argmax(score))
    inliers = points[np.abs(points @ normals[best] - deltas[best]) <= params.plane_tolerance_m]
    centroid = inliers.mean(axis=0)
    normal = np.linalg.svd(inliers - centroid, full_matrices=False)[2][2]  # least squares on the inliers
    if abs(normal[2]) < math.cos(params.theta_p):
        normal = normals[best]
    delta = float(normal @ centroid)
    if delta > 0:  # toward the sensor at the origin
        normal, delta = -normal, -delta
    return normal, delta


def fronto_parallel_rotation(normal: np.ndarray) -> np.ndarray:
    """R_fp ≡ q_{(-n̂)→ẑ}: the smallest rotation taking -n̂ onto ẑ (§IV-B), as a matrix."""
    a = -np.asarray(normal, dtype=float)
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(a, z), float(a @ z)
    if c < -1.0 + 1e-12:  # opposite: half a turn about x
        return np.diag([1.0, -1.0, -1.0])
    vx = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)  # Rodrigues


def fronto_parallel_view(points: np.ndarray, normal: np.ndarray, delta: float, f: float,
                         params: DetectionParams) -> FrontoParallelView | None:
    """I and I_binary: the points at or behind the plane rotated by R_fp and projected with focal length ``f`` (px).

    The virtual camera's principal point is placed so that the plane's inliers fill the image (at most
    ``max_image_px`` each way). ``None`` when no point lies on the plane.
    """
    R_fp = fronto_parallel_rotation(normal)
    d = -delta
    fp = points @ R_fp.T
    fp = fp[fp[:, 2] >= d - params.plane_tolerance_m]  # what lies in front of the plane would occlude it
    uv = f * fp[:, :2] / fp[:, 2:3]
    on_plane = np.abs(fp[:, 2] - d) <= params.plane_tolerance_m
    if not on_plane.any():
        return None
    lo, hi = uv[on_plane].min(axis=0), uv[on_plane].max(axis=0)
    half = params.max_image_px / 2.0
    centre = (lo + hi) / 2.0
    lo, hi = np.maximum(lo, centre - half), np.minimum(hi, centre + half)
    pad = 4.0
    K = np.array([[f, 0.0, pad - lo[0]], [0.0, f, pad - lo[1]], [0.0, 0.0, 1.0]])
    w, h = (int(math.ceil(x)) for x in hi - lo + 2 * pad + 1)
    u = np.rint(uv[:, 0] + K[0, 2]).astype(np.intp)
    v = np.rint(uv[:, 1] + K[1, 2]).astype(np.intp)
    inside = (u >= 0) & (u < w) & (v >= 0) & (v < h)
    flat = np.full(h * w, np.inf)
    np.minimum.at(flat, v[inside] * w + u[inside], fp[inside, 2])  # z-buffer: the nearest point per pixel
    depth = flat.reshape(h, w)
    binary = np.where(np.abs(depth - d) <= params.plane_tolerance_m, 255, 0).astype(np.uint8)
    depth[~np.isfinite(depth)] = np.nan
    return FrontoParallelView(depth.astype(np.float32), binary, K, R_fp, d)


def _contours(binary: np.ndarray, params: DetectionParams) -> list[np.ndarray]:
    """A_S: contours of Canny(dilate(I_binary)) (§IV-B), ``(n, 2)`` px each.

    The Canny edges are thickened by one pixel before tracing: where two edges meet (a slab across an
    opening) a one-pixel edge loop is not always closed, and its trace then encloses no area.
    """
    r = params.dilation_px
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    dilated = cv2.dilate(binary, kernel)
    edges = cv2.dilate(cv2.Canny(dilated, *params.canny_thresholds), np.ones((3, 3), np.uint8))
    found, _ = cv2.findContours(edges, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    return [c.reshape(-1, 2) for c in found if len(c) >= 3]


def _depth_beyond(view: FrontoParallelView, contour: np.ndarray) -> float:
    """Median depth (m) beyond the plane of the inside of ``contour`` off the plane (``inf``: nothing returned)."""
    inside = np.zeros(view.binary.shape, np.uint8)
    cv2.drawContours(inside, [contour.reshape(-1, 1, 2).astype(np.int32)], -1, 1, thickness=cv2.FILLED)
    region = (inside > 0) & (view.binary == 0)
    if region.sum() < 0.5 * (inside > 0).sum():  # mostly model plane: not a hole
        return 0.0
    beyond = view.depth[region]
    beyond = beyond[np.isfinite(beyond)]
    return float(np.median(beyond) - view.plane_depth) if len(beyond) else math.inf


def detect_apertures(frames: Sequence[DepthFrame], params: DetectionParams | None = None,
                     mav_urdf: str = MAV_URDF) -> list[ApertureCandidate]:
    """Candidate apertures in the sliding window of depth frames (§IV-B), largest first.

    Args:
        frames: the depth frames, oldest first; the last ``params.n_frames`` make D_S^N.
        params: :class:`DetectionParams`.
        mav_urdf: the MAV whose contour C_m (at the plane depth) a candidate must be wider than.

    Returns:
        The hollow contours wider than C_m; nested duplicates (both sides of one Canny edge) are merged,
        keeping the inner one. Empty when no plane satisfies the θ_p constraint.
    """
    params = params or DetectionParams()
    points, frame_I = window_cloud(frames, params)
    plane = ransac_plane(points, params) if len(points) >= 3 else None
    if plane is None:
        return []
    normal, delta = plane
    view = fronto_parallel_view(points, normal, delta, float(frames[-1].K[0, 0]), params)
    if view is None:
        return []
    mav_area = float(cv2.contourArea(mav_contour(view.plane_depth, view.K, mav_urdf).astype(np.float32)))
    candidates: list[ApertureCandidate] = []
    for contour in sorted(_contours(view.binary, params), key=lambda c: cv2.contourArea(c)):
        area = float(cv2.contourArea(contour))
        if area <= mav_area:
            continue
        beyond = _depth_beyond(view, contour)
        if beyond <= params.d_c:  # not hollow (Definition 1)
            continue
        moments = cv2.moments(contour)
        centre_px = np.array([moments["m10"] / moments["m00"], moments["m01"] / moments["m00"]])
        point = (float(centre_px[0]), float(centre_px[1]))
        if any(cv2.pointPolygonTest(c.contour_px.astype(np.float32), point, False) >= 0 for c in candidates):
            continue  # the outer side of an edge already taken from inside
        candidates.append(ApertureCandidate(contour.astype(float), area, mav_area, beyond, normal,
                                            view.pixel_to_I(centre_px), frame_I, view))
    return sorted(candidates, key=lambda c: -c.area_px)
