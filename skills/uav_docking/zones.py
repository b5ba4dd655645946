"""Local 3-D map of obstacles and prohibited zones, and the cord repair (Narváez et al., §IV-A-2, Figs. 8–9).

The map lives in the manipulator frame M and holds

- obstacles from the carrier's range sensor, drawn as columns perpendicular
  to the ground and expanded radially away from the sensor: everything
  above, below and behind a detected face is forbidden, which keeps the
  camera's line of sight clear and covers the sensor's blind side (Fig. 8);
- prohibited zones at their exact place, without expansion: the carrier's
  own structure, singularity zones of the arm, and the workspace bounds.

Every zone is thickened by a_N + T_s for the cord (the largest semi-axis of
the vicinity plus a safety clearance T_s, Fig. 9). The thickening is exact:
a cord item is free when a sphere of radius a_N + T_s around it touches no
zone — the sphere swept over a zone is the zone's Minkowski sum with it.
:func:`repair_cord` shifts the cord items out of the thickened zones and
smooths the cord's curvature until every item is free; the vicinity then
keeps at least T_s from every zone (Fig. 9b).

Collision queries use python-fcl (boxes, cylinders, convex columns,
ellipsoids) behind a numpy bounding-box pre-filter that evaluates every
query point against every zone at once; only the overlapping pairs reach
fcl. The workspace bounds (a reach ball and a height slab) are analytic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import fcl
import numpy as np
import pinocchio as pin

from marsupial.api.assets import asset_path
from marsupial.api.kinematics import ArmKinematics

from ..common.ik_engine import ArmGeometry
from .cord import Cord
from .vicinity import Vicinity


def _fibonacci_sphere(n: int) -> np.ndarray:
    """``(n, 3)`` unit vectors spread evenly over the sphere (Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    azimuth = math.pi * (3.0 - math.sqrt(5.0)) * k
    r = np.sqrt(1.0 - z**2)
    return np.column_stack((r * np.cos(azimuth), r * np.sin(azimuth), z))


_COLLIDE = fcl.CollisionRequest()
_SIGNED = fcl.DistanceRequest(enable_nearest_points=True, enable_signed_distance=True)
_SEARCH_DIRECTIONS = _fibonacci_sphere(48)
"""Unit directions of the closest-free-position search, spread evenly over the sphere."""
_MARGIN = 2e-3  # m, pushed items land this far beyond the thickened surface: creases between zones resolve fast


@dataclass(frozen=True)
class ZoneParams:
    """Map and repair parameters (T_s, Fig. 9; the paper gives no number for it).

    Attributes:
        T_s: extra thickness T_s (m) added to a_N: the safety clearance left between
            the vicinity and every zone after the repair.
        column_width: angular width (rad) of one obstacle column.
        column_depth: radial extent (m) of a column behind the detected face.
        column_height: height (m) of a column, centred on M's origin ("above and below").
        column_range: hits farther than this (m) from M's origin make no column: beyond the
            arm's reach (0.85 m) plus the thickening and the repair's search radius.
        max_iterations: shift-and-smooth iterations before the repair gives up.
        smoothing: gain of the curvature smoothing of the interior items per iteration (0…1).
        search_radius, search_steps: reach (m) and radial steps of the closest-free-position
            search for an item caught between two zones.
    """

    T_s: float = 0.03
    column_width: float = math.radians(2.0)
    column_depth: float = 2.0
    column_height: float = 10.0
    column_range: float = 1.5
    max_iterations: int = 25
    smoothing: float = 0.5
    search_radius: float = 0.25
    search_steps: int = 25


@dataclass(frozen=True)
class WorkspaceBounds:
    """The allowed region of the end effector: a ball around the shoulder cut by a height slab (M, m).

    Attributes:
        center: ball centre; radius: ball radius; z_min, z_max: slab heights.
    """

    center: np.ndarray
    radius: float
    z_min: float = -math.inf
    z_max: float = math.inf

    def push(self, points: np.ndarray, clearance: float) -> np.ndarray:
        """``(n, 3)`` shifts that bring each point at least ``clearance`` inside the region (0 when it is)."""
        offset = points - self.center
        distance = np.linalg.norm(offset, axis=1)
        excess = np.maximum(distance - (self.radius - clearance), 0.0)
        shift = -offset * (excess / np.maximum(distance, 1e-12))[:, None]
        z = points[:, 2] + shift[:, 2]
        shift[:, 2] += np.maximum(self.z_min + clearance - z, 0.0) - np.maximum(z - (self.z_max - clearance), 0.0)
        return shift


@dataclass(frozen=True)
class Zone:
    """One zone of the map: its name, kind (``"obstacle"`` or ``"prohibited"``), fcl object and AABB in M."""

    name: str
    kind: str
    obj: fcl.CollisionObject
    lower: np.ndarray
    upper: np.ndarray


def _box_corners(center: np.ndarray, R: np.ndarray, half: np.ndarray) -> np.ndarray:
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    return center + (signs * half) @ R.T


_PRISM_FACES = np.array([4, 0, 3, 2, 1, 4, 4, 5, 6, 7, 4, 0, 1, 5, 4, 4, 1, 2, 6, 5, 4, 2, 3, 7, 6, 4, 3, 0, 4, 7])
"""fcl face list of a prism over a quadrilateral: vertices 0-3 at the bottom, 4-7 above them."""


class ZoneMap:
    """Obstacles and prohibited zones around the arm, in the manipulator frame M.

    Args:
        params: :class:`ZoneParams`.
        bounds: the workspace bounds (``None``: unbounded).
    """

    def __init__(self, params: ZoneParams = ZoneParams(), bounds: WorkspaceBounds | None = None):
        self.params = params
        self.bounds = bounds
        self.zones: list[Zone] = []
        self._refresh()

    # ------------------------------------------------------------ building
    def _add(
        self, name: str, kind: str, geometry: fcl.CollisionGeometry, T: np.ndarray | None, corners: np.ndarray
    ) -> None:
        """Append one zone placed at ``T`` (``None``: geometry already in M) whose AABB spans ``corners``.

        Call :meth:`_refresh` after the last one.
        """
        if kind not in ("obstacle", "prohibited"):
            raise ValueError(f"zone kind must be 'obstacle' or 'prohibited', got '{kind}'")
        placement = fcl.Transform() if T is None else fcl.Transform(T[:3, :3], T[:3, 3])
        obj = fcl.CollisionObject(geometry, placement)
        self.zones.append(Zone(name, kind, obj, corners.min(axis=0), corners.max(axis=0)))

    def _refresh(self) -> None:
        """Rebuild the stacked zone AABBs of the pre-filter (after zones were added or removed)."""
        self._lower = np.array([z.lower for z in self.zones]).reshape(-1, 3)
        self._upper = np.array([z.upper for z in self.zones]).reshape(-1, 3)

    def add_box(
        self,
        name: str,
        center: np.ndarray,
        half_extents: np.ndarray,
        R: np.ndarray | None = None,
        kind: str = "prohibited",
    ) -> None:
        """A box of ``half_extents`` (m) at ``center`` with axes ``R`` (columns, default M's)."""
        center, half = np.asarray(center, dtype=float), np.asarray(half_extents, dtype=float)
        R = np.eye(3) if R is None else np.asarray(R, dtype=float)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, center
        self._add(name, kind, fcl.Box(*(2.0 * half)), T, _box_corners(center, R, half))
        self._refresh()

    def add_cylinder(
        self,
        name: str,
        center: np.ndarray,
        radius: float,
        half_height: float,
        R: np.ndarray | None = None,
        kind: str = "prohibited",
    ) -> None:
        """A cylinder (m) centred at ``center`` whose axis is the third column of ``R`` (default M's z)."""
        center = np.asarray(center, dtype=float)
        R = np.eye(3) if R is None else np.asarray(R, dtype=float)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, center
        corners = _box_corners(center, R, np.array([radius, radius, half_height]))
        self._add(name, kind, fcl.Cylinder(radius, 2.0 * half_height), T, corners)
        self._refresh()

    def add_obstacle_columns(self, points_xy: np.ndarray, origin_xy: np.ndarray, name: str = "obstacle") -> int:
        """Columns of the obstacle points (range-sensor hits, M frame, m) seen from ``origin_xy`` (Fig. 8).

        Hits within ``column_range`` of M's origin are binned by bearing
        (``column_width``); each bin forbids the prism between its two bounding
        rays from its nearest hit to ``column_depth`` behind it, over
        ``column_height``. The prism's near side is the chord between the
        rays, slightly closer than the hit (a conservative cover). Returns the
        number of columns added.
        """
        p = self.params
        origin = np.asarray(origin_xy, dtype=float)
        rel = np.asarray(points_xy, dtype=float).reshape(-1, 2) - origin
        ranges = np.hypot(rel[:, 0], rel[:, 1])
        keep = (ranges > 1e-6) & (np.linalg.norm(rel + origin, axis=1) <= p.column_range)
        if not keep.any():
            return 0
        bins = np.floor(np.arctan2(rel[keep, 1], rel[keep, 0]) / p.column_width).astype(int)
        unique, inverse = np.unique(bins, return_inverse=True)
        nearest = np.full(unique.size, np.inf)
        np.minimum.at(nearest, inverse, ranges[keep])
        # all prisms at once: (m, 4) corners of the quadrilaterals, then (m, 8, 3) vertices
        beta = (unique[:, None] + np.array([0, 1, 1, 0])) * p.column_width
        radius = nearest[:, None] + np.array([0.0, 0.0, p.column_depth, p.column_depth])
        xy = origin + np.stack((radius * np.cos(beta), radius * np.sin(beta)), axis=-1)
        h = p.column_height / 2.0
        bottom = np.concatenate((xy, np.full((unique.size, 4, 1), -h)), axis=2)
        vertices = np.concatenate((bottom, bottom + [0.0, 0.0, 2.0 * h]), axis=1)
        for b, v in zip(unique, vertices, strict=True):
            self._add(f"{name}_{b}", "obstacle", fcl.Convex(v, 6, _PRISM_FACES), None, v)
        self._refresh()
        return int(unique.size)

    def clear(self, kind: str = "obstacle") -> None:
        """Remove every zone of ``kind`` (e.g. the obstacles before a new scan)."""
        self.zones = [z for z in self.zones if z.kind != kind]
        self._refresh()

    # ------------------------------------------------------------- queries
    def _candidates(self, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(query, zone) index pairs whose boxes overlap: every query box against every zone box at once."""
        overlap = np.all((lower[:, None] <= self._upper[None]) & (upper[:, None] >= self._lower[None]), axis=2)
        query, zone = np.nonzero(overlap)
        return query, zone

    def points_free(self, points: np.ndarray, clearance: float = 0.0) -> np.ndarray:
        """Boolean mask of the ``(n, 3)`` points (m) at least ``clearance`` from every zone and inside the bounds."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        free = np.ones(points.shape[0], dtype=bool)
        if self.bounds is not None:
            free &= ~np.any(self.bounds.push(points, clearance) != 0.0, axis=1)
        query, zone = self._candidates(points - clearance, points + clearance)
        sphere = fcl.CollisionObject(fcl.Sphere(max(clearance, 1e-9)))
        for i, j in zip(query, zone, strict=True):
            if free[i]:
                sphere.setTranslation(points[i])
                free[i] = fcl.collide(sphere, self.zones[j].obj, _COLLIDE, fcl.CollisionResult()) == 0
        return free

    def push_out(self, points: np.ndarray, clearance: float) -> np.ndarray:
        """``(n, 3)`` shifts (m) that move each point to ``clearance`` from the zones it is too close to.

        Per zone, the shift is along the signed-distance direction (from the
        deepest point of the ``clearance`` sphere to the zone's surface) by the
        penetration; the shifts of several zones and of the bounds add up.
        Zero rows are free points.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        shift = np.zeros_like(points) if self.bounds is None else self.bounds.push(points, clearance)
        query, zone = self._candidates(points - clearance, points + clearance)
        sphere = fcl.CollisionObject(fcl.Sphere(max(clearance, 1e-9)))
        for i, j in zip(query, zone, strict=True):
            sphere.setTranslation(points[i])
            result = fcl.DistanceResult()
            depth = -fcl.distance(sphere, self.zones[j].obj, _SIGNED, result)
            if depth >= 0.0:
                on_sphere, on_zone = result.nearest_points
                direction = on_zone - on_sphere
                norm = float(np.linalg.norm(direction))
                if norm < 1e-9:  # touching: leave along the line from the zone to the centre
                    direction, norm = points[i] - on_zone, float(np.linalg.norm(points[i] - on_zone))
                shift[i] += direction / max(norm, 1e-12) * (depth + _MARGIN)
        return shift

    def nearest_free(self, point: np.ndarray, clearance: float) -> np.ndarray | None:
        """The closest point to ``point`` (m) at least ``clearance`` from every zone, on a search grid.

        The grid is :data:`_SEARCH_DIRECTIONS` rays by ``search_steps`` radii up to
        ``search_radius``, checked one radius (one batch of rays) at a time from
        the inside out. ``None`` when none is free.
        """
        p = self.params
        for radius in np.linspace(p.search_radius / p.search_steps, p.search_radius, p.search_steps):
            candidates = np.asarray(point, dtype=float) + radius * _SEARCH_DIRECTIONS
            free = np.flatnonzero(self.points_free(candidates, clearance))
            if free.size:
                return candidates[free[0]].copy()
        return None

    def vicinity_free(self, vicinity: Vicinity, clearance: float = 0.0) -> bool:
        """True when no section ellipsoid comes within ``clearance`` of a zone and all stay inside the bounds."""
        half = np.sqrt(np.einsum("nij,nj->ni", vicinity.rotations**2, vicinity.semi_axes**2))  # ellipsoid AABBs
        lower, upper = vicinity.centers - half - clearance, vicinity.centers + half + clearance
        if self.bounds is not None and np.any(self.bounds.push(vicinity.centers, vicinity.max_semi_axis + clearance)):
            return False
        query, zone = self._candidates(lower, upper)
        for i, j in zip(query, zone, strict=True):
            shape = fcl.Ellipsoid(*(vicinity.semi_axes[i] + clearance))
            ellipsoid = fcl.CollisionObject(shape, fcl.Transform(vicinity.rotations[i], vicinity.centers[i]))
            if fcl.collide(ellipsoid, self.zones[j].obj, _COLLIDE, fcl.CollisionResult()):
                return False
        return True


@dataclass(frozen=True)
class Repair:
    """Outcome of :func:`repair_cord`.

    Attributes:
        cord: the cord with shifted and smoothed items (the input cord when nothing was in the way).
        ok: True when every item is at least the thickening away from every zone.
        iterations: shift-and-smooth iterations used.
    """

    cord: Cord
    ok: bool
    iterations: int


def thickening(vicinity: Vicinity, params: ZoneParams) -> float:
    """a_N + T_s: the map's thickening for the cord items (largest semi-axis of the vicinity plus T_s), m."""
    return vicinity.max_semi_axis + params.T_s


def repair_cord(cord: Cord, zones: ZoneMap, clearance: float) -> Repair:
    """Shift the cord's items out of the zones thickened by ``clearance`` and smooth it (Fig. 9).

    Each iteration moves every item that is closer than ``clearance`` to a
    zone out along the zone's signed-distance direction, then relaxes the
    interior items toward the midpoint of their neighbours (curvature
    smoothing, ``smoothing`` gain) wherever the relaxed position is free too,
    until every item is free or ``max_iterations`` is reached. An item pushed
    back the way it came is caught between two zones: it jumps to the
    closest free position found by :meth:`ZoneMap.nearest_free` instead.
    """
    items = cord.items.copy()
    gain = zones.params.smoothing
    previous = np.zeros_like(items)
    for iteration in range(zones.params.max_iterations + 1):
        shift = zones.push_out(items, clearance)
        if not shift.any():
            return Repair(replace(cord, items=items) if iteration else cord, True, iteration)
        for i in np.flatnonzero(np.einsum("ij,ij->i", shift, previous) < 0.0):  # ping-pong between two zones
            free = zones.nearest_free(items[i], clearance)
            if free is not None:
                shift[i] = free - items[i]
        previous = shift
        items += shift
        if items.shape[0] > 2:
            smoothed = items[1:-1] + gain * (0.5 * (items[:-2] + items[2:]) - items[1:-1])
            accept = zones.points_free(smoothed, clearance)
            items[1:-1][accept] = smoothed[accept]
    return Repair(replace(cord, items=items), False, zones.params.max_iterations)


def carrier_zones(
    kinematics: ArmKinematics,
    urdf: str,
    params: ZoneParams = ZoneParams(),
    singularity_radius: float = 0.03,
    reach_margin: float = 0.05,
) -> ZoneMap:
    """The prohibited zones of the carrier, from its URDF and arm model (M frame, Fig. 8).

    - the collision shapes (boxes, cylinders) of every link that does not move
      with the arm (the mobile base, the arm pedestal);
    - the shoulder singularity: a vertical cylinder of ``singularity_radius`` (m)
      around joint 1's axis, where the wrist centre loses joint 1;
    - the workspace bounds: the ball of the arm's reach minus ``reach_margin``
      around the shoulder, above the base's top.

    Args:
        kinematics: the arm model (``ArmKinematics`` with base frame M).
        urdf: the same URDF file (path or asset name) the model was built from.
    """
    path = Path(urdf) if Path(urdf).is_file() else asset_path(urdf)
    model = kinematics.model
    geometry = pin.buildGeomFromUrdf(model, str(path), pin.GeometryType.COLLISION)
    M_frame = model.frames[model.getFrameId(kinematics.base_link, pin.FrameType.BODY)]
    T_M_root = M_frame.placement.inverse().homogeneous
    arm = ArmGeometry.from_kinematics(kinematics)
    top = -math.inf
    zones = ZoneMap(params)
    for g in geometry.geometryObjects:
        if g.parentJoint != 0:
            continue  # moves with the arm
        T = T_M_root @ g.placement.homogeneous
        shape = g.geometry
        if hasattr(shape, "halfSide"):
            half = np.array(shape.halfSide)
            zones.add_box(g.name, T[:3, 3], half, T[:3, :3])
            top = max(top, float(_box_corners(T[:3, 3], T[:3, :3], half)[:, 2].max()))
        elif hasattr(shape, "halfLength"):
            zones.add_cylinder(g.name, T[:3, 3], float(shape.radius), float(shape.halfLength), T[:3, :3])
        else:
            raise ValueError(f"{urdf}: collision shape of '{g.name}' must be a box or a cylinder for the zone map")
    zones.add_cylinder("shoulder_singularity", arm.shoulder, singularity_radius, arm.reach)
    zones.bounds = WorkspaceBounds(arm.shoulder, arm.reach - reach_margin, z_min=top)
    return zones
