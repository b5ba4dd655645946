"""RGB / depth / segmentation camera rendered with pybullet's TinyRenderer.

Frames: the camera's optical frame follows OpenCV (x right, y down,
z forward along the optical axis). A camera is mounted on a robot link with
a position (m) and a rotation ``R_link_optical`` (columns: the optical axes
in the link frame); :data:`OPTICAL_FORWARD`, :data:`OPTICAL_DOWN` and
:data:`OPTICAL_UP` cover the usual mounts.

Speed: TinyRenderer's cost grows with the pixels that geometry covers
(≈20 ms for a 320×240 frame filled by the floor, ≈4 ms for an empty one).
The scene's flat floor therefore has no visual shape in headless worlds;
the camera fills it in analytically (ray–plane intersection in numpy) where
nothing else was drawn, with the same colour, depth and segmentation id.
Everything after the render works in place on pybullet's own arrays in
float32: the floor is computed only inside the image rectangle where it can
appear (nothing when it is out of view), its colour is written as one packed
32-bit RGBA value per pixel, and RGBA → RGB is a single OpenCV conversion.

Image realism (every figure scaled by ``world.noise_scale``; values and
sources in ``docs/world.md``): a per-run white balance (one gain per colour
channel, 1σ ``white_balance_std``), a per-frame exposure gain (1σ
``exposure_std``), additive pixel noise (1σ ``config.noise_std`` in 0-255
intensity), and depth noise growing with depth (``depth_noise_per_m``);
frame drops and latency come from :class:`SensorConfig`. The gains are one
saturating per-channel OpenCV ``multiply``, the pixel noise a saturating
``add`` and ``subtract`` of the positive and negative parts of a slice of a
pre-drawn noise bank at a seeded random offset (a fresh full-frame draw
would cost ten times more), all in place.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np
import pybullet

from marsupial.api.model import Intrinsics

from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..robots.base import Robot

OPTICAL_FORWARD = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
"""Optical frame looking along the link's +x, image up = link +z."""
OPTICAL_DOWN = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""Optical frame looking along the link's -z, image up = link +x."""
OPTICAL_UP = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
"""Optical frame looking along the link's +z, image up = link -x."""


def projection_matrix(intrinsics: Intrinsics) -> list[float]:
    """OpenGL projection matrix (column-major) for TinyRenderer that renders exactly the intrinsics' ``K``.

    TinyRenderer samples each pixel at its corner rather than its centre,
    which alone would put the rendered principal point at ``(w/2, h/2 - 1)``;
    shifting normalised device coordinates by half a pixel (-0.5 px in u,
    +0.5 px in v) places it at ``K``'s ``((w-1)/2, (h-1)/2)``.
    """
    i = intrinsics
    projection = list(pybullet.computeProjectionMatrixFOV(i.fov_v_deg, i.width / i.height, i.near, i.far))
    projection[8] += 1.0 / intrinsics.width  # x_ndc += -1/w · w_clip (w_clip = -z_eye): -0.5 px in u
    projection[9] += 1.0 / intrinsics.height  # y_ndc += -1/h · w_clip: +0.5 px in v (rows grow downwards)
    return projection


@dataclass(frozen=True)
class CameraFrame:
    """One rendered frame.

    Attributes:
        rgb: ``(h, w, 3)`` uint8.
        depth: ``(h, w)`` float32, metres along the optical axis (``far`` where empty).
        segmentation: ``(h, w)`` int32 pybullet body ids (-1 empty), or ``None`` if not requested.
        K: 3×3 intrinsics.
        position: optical-frame origin in the world frame (m).
        rotation: ``R_world_optical`` 3×3.
    """

    rgb: np.ndarray
    depth: np.ndarray
    segmentation: np.ndarray | None
    K: np.ndarray
    position: np.ndarray
    rotation: np.ndarray


NOISE_BANK_SLACK = 65536  # extra noise samples beyond one frame: the range of the random offsets
EXPOSURE_STD = 0.03  # 1σ per-frame exposure gain (chosen: auto-exposure flicker of a few %)
WHITE_BALANCE_STD = 0.03  # 1σ per-run gain of each colour channel (chosen: auto white balance spread)


class Camera(Sensor[CameraFrame]):
    """A camera on ``robot``'s ``link`` at ``offset`` (m, link frame) with ``R_link_optical``.

    ``segmentation=True`` also returns the body-id mask (slightly slower).
    ``config.noise_std`` adds Gaussian noise to RGB intensities (0-255),
    ``depth_noise_per_m`` × depth to depth; ``exposure_std`` and
    ``white_balance_std`` are the per-frame and per-run gain errors (module
    docstring). ``measures_depth``: whether the robot's computer receives the
    depth image (RGB-D cameras) or only colour (the sensor port drops the
    rendered depth of a plain RGB camera).
    """

    def __init__(
        self,
        robot: Robot,
        name: str,
        intrinsics: Intrinsics,
        config: SensorConfig,
        link: str | int = -1,
        offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        R_link_optical: np.ndarray = OPTICAL_FORWARD,
        segmentation: bool = False,
        depth_noise_per_m: float = 0.0,
        measures_depth: bool = True,
        exposure_std: float = EXPOSURE_STD,
        white_balance_std: float = WHITE_BALANCE_STD,
    ):
        super().__init__(robot.world, f"{robot.name}/{name}", config)
        self.robot = robot
        self.measures_depth = bool(measures_depth)
        k = self.noise_scale
        self.exposure_std = exposure_std * k
        self.white_balance = tuple(1.0 + white_balance_std * k * float(g) for g in self.rng.standard_normal(3))
        self._pixel_bank: tuple[np.ndarray, np.ndarray] | None = None  # drawn on the first noisy frame
        self._depth_bank: np.ndarray | None = None
        self.intrinsics = intrinsics
        self.link = robot.link_index(link) if isinstance(link, str) else link
        self.offset = np.asarray(offset, dtype=float)
        self.R_link_optical = np.asarray(R_link_optical, dtype=float)
        self.segmentation = segmentation
        self.depth_noise_per_m = depth_noise_per_m * k
        self._projection = projection_matrix(intrinsics)
        K = self._K = intrinsics.K
        # x of each column's and y of each row's optical ray with z = 1, so depth == ray parameter
        self._ray_x = ((np.arange(intrinsics.width) - K[0, 2]) / K[0, 0]).astype(np.float32)
        self._ray_y = ((np.arange(intrinsics.height) - K[1, 2]) / K[1, 1]).astype(np.float32)
        self._x_first, self._x_last = float(self._ray_x[0]), float(self._ray_x[-1])
        self._y_first, self._y_last = float(self._ray_y[0]), float(self._ray_y[-1])

    @property
    def K(self) -> np.ndarray:
        """3×3 intrinsics of this camera (pixels)."""
        return self._K.copy()

    def optical_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and ``R_world_optical`` of the optical frame now."""
        return self.robot.mounted_frame(self.link, self.offset, self.R_link_optical)

    def measure(self) -> CameraFrame:
        """Render the view now; fill the floor analytically; add seeded noise."""
        intr = self.intrinsics
        position, R = self.optical_pose()
        forward, down = R[:, 2], R[:, 1]
        view = pybullet.computeViewMatrix(list(position), list(position + forward), list(-down))
        flags = 0 if self.segmentation else pybullet.ER_NO_SEGMENTATION_MASK
        _, _, rgba, zbuf, seg = pybullet.getCameraImage(
            intr.width,
            intr.height,
            view,
            self._projection,
            renderer=pybullet.ER_TINY_RENDERER,
            flags=flags,
            physicsClientId=self.world.client_id,
        )
        # pybullet hands over fresh arrays: work on them in place
        rgba = np.asarray(rgba, dtype=np.uint8).reshape(intr.height, intr.width, 4)
        depth = np.asarray(zbuf, dtype=np.float32).reshape(intr.height, intr.width)
        empty = depth >= 1.0 - 1e-7  # z-buffer still at the far plane: nothing drawn
        near, far = intr.near, intr.far
        np.multiply(depth, far - near, out=depth)  # z-buffer -> metres: far·near / (far - (far - near)·z)
        np.subtract(far, depth, out=depth)
        np.divide(far * near, depth, out=depth)
        segmentation = (
            np.asarray(seg, dtype=np.int32).reshape(intr.height, intr.width) if self.segmentation else None
        )
        self._fill_floor(rgba, depth, segmentation, position, R, empty)
        rgb = cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)
        self._add_noise(rgb, depth)
        return CameraFrame(rgb, depth, segmentation, self._K.copy(), position, R)

    def _floor_window(self, r_z: np.ndarray, d: float) -> tuple[slice, slice] | None:
        """Rows and columns bounding the pixels whose rays meet the floor between near and far.

        ``r_z`` is the world-z row of ``R_world_optical`` and ``d`` the floor
        height minus the camera height (m). A ray's world z per unit depth,
        ``r_z · (x, y, 1)``, is linear in the pixel, and the floor is hit at
        depth ``d / (r_z · ray)`` in (near, far) exactly when that value lies
        between ``d / near`` and ``d / far``; the window is widened by a pixel
        so that float32 rounding never loses an edge pixel. ``None``: floor out of view.
        """
        if d == 0.0:
            return None
        lo, hi = sorted((d / self.intrinsics.near, d / self.intrinsics.far))
        lo, hi = lo - 1e-5 * (1.0 + abs(lo)), hi + 1e-5 * (1.0 + abs(hi))
        rx, ry, rz = float(r_z[0]), float(r_z[1]), float(r_z[2])
        x_ends = (rx * self._x_first, rx * self._x_last)  # x term of the first and last column
        y_ends = (ry * self._y_first, ry * self._y_last)
        rows = self._band(ry * self._ray_y, rz + min(x_ends), rz + max(x_ends), lo, hi)
        cols = self._band(rx * self._ray_x, rz + min(y_ends), rz + max(y_ends), lo, hi)
        return None if rows is None or cols is None else (rows, cols)

    @staticmethod
    def _band(values: np.ndarray, low_add: float, high_add: float, lo: float, hi: float) -> slice | None:
        """Slice (widened by one) of the indices whose range ``values + [low_add, high_add]`` meets (lo, hi)."""
        inside = np.flatnonzero((values > lo - high_add) & (values < hi - low_add))
        if inside.size == 0:
            return None
        return slice(max(int(inside[0]) - 1, 0), int(inside[-1]) + 2)

    def _fill_floor(
        self,
        rgba: np.ndarray,
        depth: np.ndarray,
        segmentation: np.ndarray | None,
        position: np.ndarray,
        R: np.ndarray,
        empty: np.ndarray,
    ) -> None:
        floor = self.world.scene.floor
        if floor is None or not floor.analytic:
            return
        window = self._floor_window(R[2], floor.height - float(position[2]))
        if window is None:
            return
        rows, cols = window
        r = R[2].astype(np.float32)
        rays_z = r[0] * self._ray_x[cols] + r[1] * self._ray_y[rows, None]  # world z per unit depth
        rays_z += r[2]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.divide(np.float32(floor.height - position[2]), rays_z, out=rays_z)
        hit = (t > self.intrinsics.near) & (t < self.intrinsics.far) & empty[rows, cols]
        np.copyto(depth[rows, cols], t, where=hit)
        rgba32 = rgba.view(np.uint32)[..., 0]  # one packed RGBA value per pixel
        np.copyto(rgba32[rows, cols], np.array([*floor.rgb, 255], dtype=np.uint8).view(np.uint32), where=hit)
        if segmentation is not None:
            np.copyto(segmentation[rows, cols], floor.body_id, where=hit)

    def _add_noise(self, rgb: np.ndarray, depth: np.ndarray) -> None:
        """Gains (white balance × exposure), pixel noise and depth noise, in place and saturating."""
        gain = 1.0 + self.exposure_std * float(self.rng.standard_normal()) if self.exposure_std > 0 else 1.0
        gains = [g * gain for g in self.white_balance]
        if gains != [1.0, 1.0, 1.0]:
            # one gain per channel (the stubs of some opencv releases do not know the scalar-tuple form)
            cv2.multiply(rgb, (*gains, 0.0), dst=rgb, dtype=cv2.CV_8U)  # type: ignore[call-overload, unused-ignore]
        if self.config.noise_std > 0:
            if self._pixel_bank is None:
                bank = self.rng.standard_normal(rgb.size + NOISE_BANK_SLACK, dtype=np.float32)
                bank *= self.config.noise_std
                np.rint(bank, out=bank)
                np.clip(bank, -255, 255, out=bank)
                # the noise as its positive and negative parts: two saturating uint8 operations, the
                # cheapest exact saturating addition of a signed noise
                self._pixel_bank = (np.maximum(bank, 0).astype(np.uint8), np.maximum(-bank, 0).astype(np.uint8))
            start = int(self.rng.integers(NOISE_BANK_SLACK))
            up, down = (b[start : start + rgb.size].reshape(rgb.shape) for b in self._pixel_bank)
            cv2.add(rgb, up, dst=rgb)
            cv2.subtract(rgb, down, dst=rgb)
        if self.depth_noise_per_m > 0:
            if self._depth_bank is None:
                self._depth_bank = self.rng.standard_normal(depth.size + NOISE_BANK_SLACK, dtype=np.float32)
            start = int(self.rng.integers(NOISE_BANK_SLACK))
            bank = self._depth_bank[start : start + depth.size].reshape(depth.shape)
            noise = bank * np.float32(self.depth_noise_per_m)
            noise *= depth
            depth += noise
