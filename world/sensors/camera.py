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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pybullet

from .base import Sensor, SensorConfig

if TYPE_CHECKING:
    from ..robots.base import Robot

OPTICAL_FORWARD = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
"""Optical frame looking along the link's +x, image up = link +z."""
OPTICAL_DOWN = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""Optical frame looking along the link's -z, image up = link +x."""
OPTICAL_UP = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
"""Optical frame looking along the link's +z, image up = link -x."""


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics from resolution and vertical field of view.

    ``fy = (height / 2) / tan(fov_v / 2)``, square pixels (``fx = fy``),
    principal point at the image centre ``((w-1)/2, (h-1)/2)`` in OpenCV's
    pixel convention. ``near``/``far`` clip depth (m).
    """

    width: int
    height: int
    fov_v_deg: float
    near: float = 0.02
    far: float = 30.0

    @property
    def K(self) -> np.ndarray:
        """3×3 camera matrix in pixels."""
        f = (self.height / 2.0) / math.tan(math.radians(self.fov_v_deg) / 2.0)
        return np.array([[f, 0.0, (self.width - 1) / 2.0], [0.0, f, (self.height - 1) / 2.0], [0.0, 0.0, 1.0]])

    def projection_matrix(self) -> list[float]:
        """OpenGL projection matrix pybullet expects for these intrinsics."""
        return pybullet.computeProjectionMatrixFOV(
            self.fov_v_deg, self.width / self.height, self.near, self.far
        )


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


class Camera(Sensor[CameraFrame]):
    """A camera on ``robot``'s ``link`` at ``offset`` (m, link frame) with ``R_link_optical``.

    ``segmentation=True`` also returns the body-id mask (slightly slower).
    ``config.noise_std`` adds Gaussian noise to RGB intensities (0-255) and,
    scaled by ``depth_noise_per_m`` × depth, to depth.
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
    ):
        super().__init__(robot.world, f"{robot.name}/{name}", config)
        self.robot = robot
        self.intrinsics = intrinsics
        self.link = robot.link_index(link) if isinstance(link, str) else link
        self.offset = np.asarray(offset, dtype=float)
        self.R_link_optical = np.asarray(R_link_optical, dtype=float)
        self.segmentation = segmentation
        self.depth_noise_per_m = depth_noise_per_m
        self._projection = intrinsics.projection_matrix()
        K = intrinsics.K
        u, v = np.meshgrid(np.arange(intrinsics.width), np.arange(intrinsics.height))
        # x, y of each pixel's optical ray with z = 1, so depth == ray parameter
        self._ray_x = ((u - K[0, 2]) / K[0, 0]).astype(np.float32)
        self._ray_y = ((v - K[1, 2]) / K[1, 1]).astype(np.float32)

    @property
    def K(self) -> np.ndarray:
        """3×3 intrinsics of this camera (pixels)."""
        return self.intrinsics.K

    def optical_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and ``R_world_optical`` of the optical frame now."""
        p_link, q_link = self.robot.link_pose(self.link)
        R_world_link = np.array(pybullet.getMatrixFromQuaternion(q_link)).reshape(3, 3)
        return p_link + R_world_link @ self.offset, R_world_link @ self.R_link_optical

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
        rgba = np.asarray(rgba, dtype=np.uint8).reshape(intr.height, intr.width, 4)
        rgb = np.ascontiguousarray(rgba[..., :3])
        zbuf = np.asarray(zbuf, dtype=np.float32).reshape(intr.height, intr.width)
        near, far = intr.near, intr.far
        depth = (far * near / (far - (far - near) * zbuf)).astype(np.float32)
        segmentation = (
            np.asarray(seg, dtype=np.int32).reshape(intr.height, intr.width) if self.segmentation else None
        )
        self._fill_floor(rgb, depth, segmentation, position, R, zbuf >= 1.0 - 1e-7)
        self._add_noise(rgb, depth)
        return CameraFrame(rgb, depth, segmentation, intr.K, position, R)

    def _fill_floor(
        self,
        rgb: np.ndarray,
        depth: np.ndarray,
        segmentation: np.ndarray | None,
        position: np.ndarray,
        R: np.ndarray,
        empty: np.ndarray,
    ) -> None:
        floor = self.world.scene.floor
        if floor is None or not floor.analytic or not empty.any():
            return
        r = R[2].astype(np.float32)
        rays_z = r[0] * self._ray_x + r[1] * self._ray_y + r[2]  # world z per unit depth
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.float32(floor.height - position[2]) / rays_z
        hit = (t > self.intrinsics.near) & (t < self.intrinsics.far) & empty
        np.copyto(depth, t, where=hit)
        np.copyto(rgb, np.array(floor.rgb, dtype=np.uint8), where=hit[..., None])
        if segmentation is not None:
            np.copyto(segmentation, floor.body_id, where=hit)

    def _add_noise(self, rgb: np.ndarray, depth: np.ndarray) -> None:
        std = self.config.noise_std
        if std > 0:
            noisy = rgb + self.rng.normal(0.0, std, rgb.shape)
            np.clip(noisy, 0, 255, out=noisy)
            rgb[...] = noisy.astype(np.uint8)
        if self.depth_noise_per_m > 0:
            depth += (self.rng.normal(0.0, 1.0, depth.shape) * self.depth_noise_per_m * depth).astype(np.float32)
