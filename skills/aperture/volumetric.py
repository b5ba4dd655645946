"""The volumetric map M (Arora & Papachristos, §III-A, Definition 1): occupied, free and unknown voxels.

M is "incrementally constructed [26] by using the sensor S": here an OctoMap
octree [26] fed with the MMS's eye-in-hand depth frames, each placed with
the pose its camera had as the robot's computer knows it (the base estimate
composed with the arm's forward kinematics at the encoder angles,
:func:`~.detection.eye_in_hand_frame`), never the simulator's. Each frame's
returns are inserted as rays from the optical centre: the voxels a ray
crosses take a miss, the voxel it ends in a hit, in OctoMap's log-odds
occupancy model (p_hit 0.7, p_miss 0.4, clamped to [0.12, 0.97]: [26]'s
defaults; the paper gives none). A voxel is *occupied* when its occupancy
probability exceeds 0.5, *free* when below, *unknown* when no ray reached it.

Frames and units: the navigation frame of the base estimate (``odom``),
metres; voxel edge ``resolution`` (m).

Library: ``pyoctomap`` 1.2.2 (the OctoMap 1.10 C++ library with Cython
bindings) installs from a manylinux cp311 wheel (8.0 MB download, 34 MB
installed, no compiler, numpy its only requirement) and answers ``None`` for
unknown space, which M needs. ``octomap-python`` (1.10.0.0, a 0.4 MB cp311
wheel) raises on unknown-space queries instead. Measured on the shared
2-core machine (loaded), inserting one 320×240 frame of ``collapsed_mockup``
(the aperture wall 1.3 m ahead, the corridor up to 5.9 m behind it), rays
truncated at 4 m: 0.05 m voxels 124-176 ms for every pixel, 53-60 ms for
every second pixel; 0.03 m voxels 300-390 ms and 170-180 ms; 0.02 m voxels
770-890 ms and 570-660 ms. The defaults (0.03 m, every second pixel) keep a
voxel at a fifth to an eighth of the apertures' 0.16-0.26 m for ≈0.2 s a
frame. A vectorised numpy voxel hash would need its own ray traversal in
Python-level loops or a dense 3-D DDA; the octree does both in C++.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyoctomap

from .detection import DepthFrame

UNKNOWN, FREE, OCCUPIED = 0, 1, 2
"""Voxel states of M (:meth:`VolumetricMap.state`)."""

@dataclass(frozen=True)
class SensorCloud:
    """One depth frame's returns as rays in the navigation frame.

    Attributes:
        points: ``(n, 3)`` ends of the rays (m): the measured points, or a point on the ray at the camera's far
            clip where nothing returned (that ray then only frees space up to ``max_range``).
        origin: the optical centre (m).
        max_range: rays are truncated here (m): voxels beyond stay as they were.
    """

    points: np.ndarray
    origin: np.ndarray
    max_range: float


def sensor_cloud(frame: DepthFrame, stride_px: int = 2, max_range: float = 4.0) -> SensorCloud:
    """The rays of ``frame`` (every ``stride_px``-th pixel each way), in the navigation frame (m).

    Pixels without a depth (NaN, ≤ 0) are dropped; those at or beyond the far clip measured nothing and
    are kept as rays to the far clip (free space up to ``max_range`` < far).
    """
    depth = frame.depth[::stride_px, ::stride_px].astype(float)
    v, u = np.mgrid[0 : frame.depth.shape[0] : stride_px, 0 : frame.depth.shape[1] : stride_px]
    ok = np.isfinite(depth) & (depth > 0.0)
    z = np.minimum(depth[ok], frame.far)
    K = frame.K
    optical = np.stack(((u[ok] - K[0, 2]) * z / K[0, 0], (v[ok] - K[1, 2]) * z / K[1, 1], z), axis=1)
    points = optical @ frame.rotation.T + frame.position
    return SensorCloud(np.ascontiguousarray(points), np.asarray(frame.position, dtype=float), float(max_range))


def voxel_centres(points: np.ndarray, resolution: float) -> np.ndarray:
    """The centres (m) of the distinct voxels of edge ``resolution`` holding ``points`` ``(n, 3)``, as OctoMap
    keys them (floor of coordinate / resolution)."""
    keys = np.unique(np.floor(np.asarray(points, dtype=float) / resolution).astype(np.int64), axis=0)
    return (keys + 0.5) * resolution


def tree_log_odds(tree: pyoctomap.OcTree, points: np.ndarray) -> np.ndarray:
    """The log-odds ``tree`` holds at ``points`` ``(n, 3)`` (m); NaN where no update ever reached the voxel."""
    out = np.full(len(points), np.nan)
    for i, p in enumerate(np.asarray(points, dtype=float)):
        node = tree.search(p)
        if node is not None:
            out[i] = node.getLogOdds()
    return out


class VolumetricMap:
    """M: an OctoMap occupancy octree in the navigation frame (m), fed with posed depth frames."""

    def __init__(self, resolution: float = 0.03, surface_resolution: float = 0.01):
        """An empty map (every voxel unknown) of voxels ``resolution`` (m) wide, keeping the measured surface
        points one per ``surface_resolution`` (m) cell."""
        self.resolution = float(resolution)
        self.surface_resolution = float(surface_resolution)
        self.tree = pyoctomap.OcTree(self.resolution)
        self._surface = np.zeros((0, 3))
        self.revision = 0
        """Frames inserted so far (a cache of anything computed from M is valid while it is unchanged)."""

    def insert(self, cloud: SensorCloud) -> None:
        """Integrate one frame's rays: misses along each ray, a hit at its end (OctoMap, each voxel once a frame);
        the returns within ``max_range`` join :attr:`surface`."""
        self.tree.insertPointCloud(cloud.points, cloud.origin, max_range=cloud.max_range)
        self.revision += 1
        returns = cloud.points[np.linalg.norm(cloud.points - cloud.origin, axis=1) < cloud.max_range]
        merged = np.vstack((self._surface, returns))  # the first point of each cell kept: the map's own record
        _, first = np.unique(np.floor(merged / self.surface_resolution).astype(np.int64), axis=0, return_index=True)
        self._surface = merged[np.sort(first)]

    @property
    def surface(self) -> np.ndarray:
        """``(n, 3)`` measured points (m) of every frame inserted, one per ``surface_resolution`` cell: the surface
        the frames saw, finer than the voxels (what a new frame is registered against, :mod:`.registration`)."""
        return self._surface

    def log_odds(self, points: np.ndarray) -> np.ndarray:
        """Occupancy log-odds at ``points`` ``(n, 3)`` (m); NaN where unknown."""
        return tree_log_odds(self.tree, points)

    def occupied_boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """Centres ``(n, 3)`` (m) and edge lengths ``(n,)`` (m) of the occupied leaves (pruned leaves are larger)."""
        centres, sizes = [], []
        for leaf in self.tree.begin_leafs():
            if self.tree.isNodeOccupied(leaf):
                centres.append(leaf.getCoordinate())
                sizes.append(leaf.getSize())
        return np.array(centres, dtype=float).reshape(-1, 3), np.array(sizes, dtype=float)

    def state(self, points: np.ndarray) -> np.ndarray:
        """:data:`UNKNOWN`, :data:`FREE` or :data:`OCCUPIED` for each of ``points`` ``(n, 3)`` (m)."""
        lo = self.log_odds(points)
        threshold = self.tree.getOccupancyThresLog()
        return np.where(np.isnan(lo), UNKNOWN, np.where(lo > threshold, OCCUPIED, FREE)).astype(np.int8)
