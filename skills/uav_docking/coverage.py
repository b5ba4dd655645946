"""Coverage of the rooms around the team by the exploring UAV: flight map, what has been seen, where to go next.

Plain numpy/OpenCV on a plan-view grid of the mission's building plan
(navigation frame x, y — the world frame at the start; ``cell`` m):

- :class:`FlightMap` — the plan's walls and door frames at the flight
  height (every element whose vertical extent meets the flight band), grown
  by the UAV's clearance; the cells of the area to survey (declared zones
  with the given tags — rooms, hall, corridor — or every cell when the plan
  has none). The building map is known in outline, as the paper allows ("in
  some cases, a building map is available", §V-A): it is the prior the
  mission declares (``context.prior("building_plan")``); debris is not on it.
- :func:`view_bearings` and :func:`plan_ranges` — the front camera's
  horizontal field of view (its level image row, through the camera pose
  the UAV estimates) and the free range along each bearing up to the first
  wall of the plan. The Bebop 2's front camera measures no depth, so the
  plan, not the image, bounds what a frame surveys;
- :func:`visible_cells` — the cells inside that visibility fan, so walls
  hide what is behind them.
- :func:`geodesic` — Dijkstra distances and parents over free cells inside
  an allowed mask (the D_team disc around the carrier).
- :func:`shortcut` — straight-line pruning of a grid path over free cells.
- :func:`next_goal` — frontier-like choice: the reachable cell maximising
  the unsurveyed target cells around it, discounted by its path length.
- :func:`detect_colour` — the largest blob of a declared colour in an RGB
  frame (HSV thresholds, OpenCV connected components), and
  :func:`floor_point` — where the ray through its lowest pixel meets the
  floor (a monocular range for an object lying on the floor).
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

_NEIGHBOURS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


@dataclass
class FlightMap:
    """Plan-view grid at the flight height; cell ``[i, j]`` is centred at ``lo + ((i, j) + ½) cell`` (world x, y).

    Attributes:
        lo: world x, y (m) of the grid's corner; cell: cell side (m).
        blocked: obstacles grown by the UAV's clearance (bool ``(nx, ny)``).
        area: cells of the area to survey (bool ``(nx, ny)``).
        walls: the plan's elements at the flight height, not grown (bool ``(nx, ny)``): what hides the view.
    """

    lo: np.ndarray
    cell: float
    blocked: np.ndarray
    area: np.ndarray
    walls: np.ndarray

    @classmethod
    def from_plan(
        cls,
        plan,
        height: float,
        band: float,
        clearance: float,
        area_tags: Iterable[str],
        cell: float = 0.25,
        extent: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> FlightMap:
        """The map of a building ``plan`` for flight at ``height`` ± ``band`` (m), obstacles grown by ``clearance`` (m).

        The grid spans the plan's size (centred on the origin), its elements
        and zones, and ``extent`` (``(lo, hi)`` x, y) if given.
        """
        lows = [-0.5 * np.asarray(plan.size, dtype=float)]
        highs = [0.5 * np.asarray(plan.size, dtype=float)]
        if extent is not None:
            lows.append(np.asarray(extent[0], dtype=float))
            highs.append(np.asarray(extent[1], dtype=float))
        footprints = []
        for element in plan.structure:
            corners = element.corners()
            lows.append(corners[:, :2].min(axis=0))
            highs.append(corners[:, :2].max(axis=0))
            if corners[:, 2].min() <= height + band and corners[:, 2].max() >= height - band:
                footprints.append(cv2.convexHull(corners[:, :2].astype(np.float32)).reshape(-1, 2))
        for zone in plan.zones:
            lows.append(np.asarray(zone.lo[:2]))
            highs.append(np.asarray(zone.hi[:2]))
        lo = np.min(lows, axis=0) - clearance - cell
        hi = np.max(highs, axis=0) + clearance + cell
        shape = tuple(np.ceil((hi - lo) / cell).astype(int))
        occupied = np.zeros(shape, dtype=np.uint8)
        for polygon in footprints:  # OpenCV draws (x = column, y = row): rows are our i (world x)
            points = np.round((polygon - lo) / cell - 0.5).astype(np.int32)[:, ::-1]
            cv2.fillConvexPoly(occupied, points, 1)
        radius = int(math.ceil(clearance / cell))
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
        blocked = cv2.dilate(occupied, kernel).astype(bool)
        grid = cls(lo, cell, blocked, np.zeros(shape, dtype=bool), occupied.astype(bool))
        tags = set(area_tags)
        zones = [z for z in plan.zones if tags & set(z.tags)]
        if zones:
            x, y = grid.centers()
            for zone in zones:
                grid.area |= (x >= zone.lo[0]) & (x <= zone.hi[0]) & (y >= zone.lo[1]) & (y <= zone.hi[1])
        else:
            grid.area[:] = True
        grid.area &= ~blocked
        return grid

    @property
    def shape(self) -> tuple[int, int]:
        """Cells along x and y."""
        return self.blocked.shape

    def centers(self) -> tuple[np.ndarray, np.ndarray]:
        """World x and y (m) of every cell centre, each ``(nx, ny)``."""
        i, j = np.indices(self.shape)
        return self.lo[0] + (i + 0.5) * self.cell, self.lo[1] + (j + 0.5) * self.cell

    def index(self, xy: np.ndarray) -> tuple[int, int]:
        """Cell ``(i, j)`` of a world point (clipped to the grid)."""
        ij = np.floor((np.asarray(xy[:2]) - self.lo) / self.cell).astype(int)
        return int(np.clip(ij[0], 0, self.shape[0] - 1)), int(np.clip(ij[1], 0, self.shape[1] - 1))

    def point(self, ij: tuple[int, int]) -> np.ndarray:
        """World x, y (m) of a cell centre."""
        return self.lo + (np.asarray(ij, dtype=float) + 0.5) * self.cell

    def disc(self, center_xy: np.ndarray, radius: float) -> np.ndarray:
        """Cells whose centre is within ``radius`` m of ``center_xy`` (bool grid)."""
        x, y = self.centers()
        return (x - center_xy[0]) ** 2 + (y - center_xy[1]) ** 2 <= radius**2

    def nearest_free(self, xy: np.ndarray, allowed: np.ndarray) -> tuple[int, int] | None:
        """The free allowed cell nearest to ``xy`` (``None`` if there is none)."""
        candidates = np.argwhere(allowed & ~self.blocked)
        if len(candidates) == 0:
            return None
        here = np.asarray(self.index(xy))
        k = int(np.argmin(np.sum((candidates - here) ** 2, axis=1)))
        return int(candidates[k, 0]), int(candidates[k, 1])

    def line_free(self, a: tuple[int, int], b: tuple[int, int]) -> bool:
        """True when the straight segment between two cell centres crosses no blocked cell."""
        n = max(abs(b[0] - a[0]), abs(b[1] - a[1])) * 2 + 1
        i = np.round(np.linspace(a[0], b[0], n)).astype(int)
        j = np.round(np.linspace(a[1], b[1], n)).astype(int)
        return not self.blocked[i, j].any()


def geodesic(grid: FlightMap, start: tuple[int, int], allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Dijkstra path lengths (m; ``inf`` unreachable) from ``start`` over free ``allowed`` cells, 8-connected.

    Returns the distances and, per cell, the flat index of its parent (−1: none).
    """
    passable = allowed & ~grid.blocked
    nx, ny = grid.shape
    distance = np.full(grid.shape, np.inf)
    parent = np.full(grid.shape, -1, dtype=np.int64)
    distance[start] = 0.0
    queue = [(0.0, start[0], start[1])]
    steps = [(di, dj, grid.cell * math.hypot(di, dj)) for di, dj in _NEIGHBOURS]
    while queue:
        d, i, j = heapq.heappop(queue)
        if d > distance[i, j]:
            continue
        for di, dj, length in steps:
            a, b = i + di, j + dj
            if 0 <= a < nx and 0 <= b < ny and passable[a, b] and d + length < distance[a, b]:
                if di and dj and not (passable[i, b] and passable[a, j]):
                    continue  # no corner cutting between two blocked cells
                distance[a, b] = d + length
                parent[a, b] = i * ny + j
                heapq.heappush(queue, (d + length, a, b))
    return distance, parent


def grid_path(grid: FlightMap, parent: np.ndarray, goal: tuple[int, int]) -> list[tuple[int, int]]:
    """Cells from the Dijkstra start to ``goal`` following ``parent`` (start first)."""
    ny = grid.shape[1]
    path = [goal]
    while parent[path[-1]] >= 0:
        k = int(parent[path[-1]])
        path.append((k // ny, k % ny))
    return path[::-1]


def shortcut(grid: FlightMap, path: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The path's cells kept only where a straight free segment cannot skip them (greedy string pulling)."""
    if len(path) <= 2:
        return list(path)
    kept = [path[0]]
    k = 0
    while k < len(path) - 1:
        far = len(path) - 1
        while far > k + 1 and not grid.line_free(path[k], path[far]):
            far -= 1
        kept.append(path[far])
        k = far
    return kept


def truncate(points: np.ndarray, length: float) -> np.ndarray:
    """The polyline ``(n, 2)`` cut at arc length ``length`` (m) (the whole polyline if shorter)."""
    out = [points[0]]
    left = length
    for a, b in itertools.pairwise(points):
        segment = float(np.linalg.norm(b - a))
        if segment >= left:
            out.append(a + (b - a) * (left / segment if segment > 0 else 0.0))
            return np.asarray(out)
        out.append(b)
        left -= segment
    return np.asarray(out)


def visible_cells(
    grid: FlightMap, origin_xy: np.ndarray, bearings: np.ndarray, ranges: np.ndarray, view_range: float
) -> np.ndarray:
    """Cells inside the visibility fan of one frame (bool grid).

    ``bearings`` (rad, world, increasing) and ``ranges`` (m, horizontal free
    range along each) sample the camera's level view; a cell is seen when its
    bearing lies within the fan and it is no farther than the range of the
    nearest sampled bearing (and ``view_range``).
    """
    x, y = grid.centers()
    dx, dy = x - origin_xy[0], y - origin_xy[1]
    distance = np.hypot(dx, dy)
    centre = 0.5 * (bearings[0] + bearings[-1])
    relative = np.remainder(np.arctan2(dy, dx) - centre + math.pi, math.tau) - math.pi
    half = 0.5 * (bearings[-1] - bearings[0])
    inside = (np.abs(relative) <= half) & (distance <= view_range)
    k = np.clip(np.searchsorted(bearings - centre, relative), 0, len(bearings) - 1)
    return inside & (distance <= np.minimum(ranges[k], view_range) + 0.5 * grid.cell)


def view_bearings(K: np.ndarray, width: int, R_nav_optical: np.ndarray) -> np.ndarray:
    """Bearings (rad, navigation frame, increasing) of a camera's image columns along its level row.

    The row whose ray at the principal point is horizontal (clamped to the
    image, as for a pitched camera) is taken; each column's ray through it
    is rotated into the navigation frame with the estimated camera rotation.
    """
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    height = int(round(2.0 * cy))
    r_z = R_nav_optical[2]  # nav-frame z of the optical axes
    row = cy if abs(r_z[1]) < 1e-9 else cy - fy * r_z[2] / r_z[1]
    row = float(np.clip(round(row), 0, height - 1))
    u = np.arange(width)
    rays = R_nav_optical @ np.stack(((u - cx) / fx, np.full(width, (row - cy) / fy), np.ones(width)))
    return np.sort(np.unwrap(np.arctan2(rays[1], rays[0])))


def plan_ranges(grid: FlightMap, origin_xy: np.ndarray, bearings: np.ndarray, max_range: float) -> np.ndarray:
    """Free range (m, ≤ ``max_range``) along each bearing from ``origin_xy`` to the first wall cell of the plan.

    Rays are marched in steps of half a cell, the range being the midpoint
    between the last free and the first wall sample (within about a cell of
    the wall's face, as the plan is rasterised); leaving the grid ends a ray
    at the grid's edge.
    """
    steps = np.arange(1, int(math.ceil(max_range / (0.5 * grid.cell))) + 1) * 0.5 * grid.cell
    x = origin_xy[0] + np.cos(bearings)[:, None] * steps
    y = origin_xy[1] + np.sin(bearings)[:, None] * steps
    i = np.floor((x - grid.lo[0]) / grid.cell).astype(int)
    j = np.floor((y - grid.lo[1]) / grid.cell).astype(int)
    inside = (i >= 0) & (i < grid.shape[0]) & (j >= 0) & (j < grid.shape[1])
    stop = ~inside
    stop[inside] = grid.walls[i[inside], j[inside]]
    first = np.where(stop.any(axis=1), stop.argmax(axis=1), len(steps))
    return np.where(first < len(steps), steps[np.minimum(first, len(steps) - 1)] - 0.25 * grid.cell, max_range)


def next_goal(
    grid: FlightMap,
    distance: np.ndarray,
    unseen_target: np.ndarray,
    look_radius: float,
    decay_length: float,
    excluded: np.ndarray,
) -> tuple[int, int] | None:
    """The reachable cell with most unsurveyed target cells within ``look_radius`` m, discounted by its distance.

    Utility = count · exp(−path length / ``decay_length``); cells in
    ``excluded`` (near earlier stops) and unreachable ones are skipped.
    ``None`` when no reachable cell has anything left to survey around it.
    """
    r = max(1, int(round(look_radius / grid.cell)))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)).astype(np.float32)
    gain = cv2.filter2D(unseen_target.astype(np.float32), -1, kernel, borderType=cv2.BORDER_CONSTANT)
    utility = np.where(np.isfinite(distance) & ~excluded, gain * np.exp(-distance / decay_length), 0.0)
    if utility.max() <= 0.5:
        return None
    k = int(np.argmax(utility))
    return k // grid.shape[1], k % grid.shape[1]


@dataclass(frozen=True)
class Blob:
    """A detected colour blob: pixel count, centroid and lowest pixel ``(u, v)`` (px)."""

    area: int
    centroid: tuple[float, float]
    bottom: tuple[float, float]


def detect_colour(
    rgb: np.ndarray, colour: tuple[int, int, int], min_pixels: int = 40, hue_tolerance: int = 6
) -> Blob | None:
    """The largest blob of pixels of ``colour`` in an ``(h, w, 3)`` uint8 frame, or ``None``.

    ``colour`` is 0-255 RGB, a saturated one.

    A pixel matches when its OpenCV hue (0..180) is within ``hue_tolerance``
    of the colour's, its saturation at least 0.85 of the colour's (shading
    scales the channels and keeps the ratio; dull browns of the same hue —
    door frames, debris — stay below even under a camera's white-balance
    error) and its value above 60; blobs of fewer than ``min_pixels`` are
    noise.
    """
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
    h0, s0, _ = (int(v) for v in cv2.cvtColor(np.array([[colour]], dtype=np.uint8), cv2.COLOR_RGB2HSV)[0, 0])
    hue_off = np.abs(((hsv[..., 0].astype(np.int16) - h0 + 90) % 180) - 90)
    mask = ((hue_off <= hue_tolerance) & (hsv[..., 1] >= 0.85 * s0) & (hsv[..., 2] > 60)).astype(np.uint8)
    count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if count <= 1:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    area = int(stats[k, cv2.CC_STAT_AREA])
    if area < min_pixels:
        return None
    v_bottom = int(stats[k, cv2.CC_STAT_TOP] + stats[k, cv2.CC_STAT_HEIGHT] - 1)
    u_bottom = float(np.mean(np.flatnonzero(labels[v_bottom] == k)))
    return Blob(area, (float(centroids[k, 0]), float(centroids[k, 1])), (u_bottom, float(v_bottom)))


def floor_point(
    K: np.ndarray, position: np.ndarray, R_nav_optical: np.ndarray, pixel: tuple[float, float], floor_z: float = 0.0
) -> np.ndarray | None:
    """Where the ray through ``pixel`` (px) of a camera at ``position`` (m) meets the floor.

    The floor is the plane ``z = floor_z`` (m, nav frame).

    ``None`` when the ray does not point down to the floor.
    """
    ray = R_nav_optical @ np.array([(pixel[0] - K[0, 2]) / K[0, 0], (pixel[1] - K[1, 2]) / K[1, 1], 1.0])
    if ray[2] >= -1e-6:
        return None
    t = (floor_z - position[2]) / ray[2]
    return position + t * ray
