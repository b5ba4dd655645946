"""Volumetric exploration of the bounded volume V until it is "stuck" (Arora & Papachristos, §III Problem 1, §IV-A).

The paper's MMS "already performs autonomous exploration based on a pre-established receding horizon
next-best-view approach" ([29], Bircher et al. 2016) and the aperture search begins "at the point where no
feasible exploration routes offer any further exploration gain [29], i.e. the robot is 'stuck'" (§IV-A,
Fig. 3); Problem 1: "motion plans which maximize the cumulative expected observation of unknown environment
subsets M_unknown using the S depth sensor model", "within a subset bounded volume V".

Here, one receding-horizon step plans the next view of the MMS:

- **Cells.** M (:mod:`.volumetric`) over V is coarsened into cells of ``cell_voxels``³ voxels: a cell is
  occupied when any voxel is, free when any is free and none occupied, unknown when no ray reached any.
- **Viewpoints.** Base poses on a ``spacing`` grid over V's ground × ``headings`` yaws whose base stands
  ``clearance`` from every occupied column of the base's height band (the camera 0.8 m ahead keeps the wall
  beyond its near clip and in its depth range) and whose straight drive there is collision-free in M
  (:class:`~.placement.FootprintGrid`: no occupied voxel in the base's band, no column all unknown; the disc
  the base turns in where it stands is its own space).
- **Gain** ([29]'s: unknown volume in the sensor's view): the volume of unknown cells within ``view_range``
  of the camera, inside its field of view (the look-around's horizontal span, the camera's vertical one),
  whose line of sight crosses no occupied cell (unknown cells are see-through: [29]'s optimistic count).
- **Choice** ([29]'s receding-horizon score): the viewpoint maximising gain · exp(−λ c), the cost c the
  drive's length plus ``w_turn`` per radian turned; none with gain ≥ ``stuck_gain``: stuck.

Frames and units: the navigation frame of the base estimate (``odom``), metres, radians; volumes m³.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import distance_transform_edt

from ..navigation import Footprint
from .placement import FootprintGrid, footprint_points, voxel_states
from .volumetric import FREE, OCCUPIED, UNKNOWN, SensorCloud, VolumetricMap


@dataclass(frozen=True)
class ExplorationParams:
    """Settings of one exploration step (nav frame, m, rad, m³).

    Attributes:
        bounds: V, corners ``((x, y, z) low, (x, y, z) high)`` of the volume explored (m).
        cell_voxels: a gain cell is this many voxels of M along each axis.
        spacing: distance (m) between viewpoint positions on the ground grid.
        headings: yaws per viewpoint position, evenly spaced.
        clearance: least distance (m) of a viewpoint's base centre from an occupied column.
        view_range: cells farther than this (m) from the camera add no gain (the depth camera's useful range).
        half_fov: half-angles (rad) of the view, horizontal (the look-around's pan plus the camera's half
            field of view) and vertical (the camera's).
        lam: λ (1/m) of the score gain · exp(−λ c) ([29]).
        w_turn: cost (m/rad) of turning the base, beside metres of drive.
        stuck_gain: a view must see at least this much unknown volume (m³); none does: stuck.
        footprint: front, rear, half-width (m) of the base rectangle (mms.urdf's 0.99 × 0.67 m box).
        margin: the rectangle is inflated by this (m) on the drive.
        z_band: heights (m above the ground) of the base's collision box: voxels there block it.
        path_step: distance (m) between the base poses checked along a drive.
        horizon: views farther than this (m) from the base are not planned (``None``: all of V).
    """

    bounds: tuple[tuple[float, float, float], tuple[float, float, float]]
    cell_voxels: int = 3
    spacing: float = 0.3
    headings: int = 8
    clearance: float = 1.2
    view_range: float = 3.0
    half_fov: tuple[float, float] = (1.1, 0.39)
    lam: float = 0.5
    w_turn: float = 0.2
    stuck_gain: float = 1.5
    footprint: tuple[float, float, float] = (0.495, 0.495, 0.335)
    margin: float = 0.05
    z_band: tuple[float, float] = (0.06, 0.39)
    path_step: float = 0.1
    horizon: float | None = None


@dataclass(frozen=True)
class Viewpoint:
    """One candidate view: base ``pose`` ``(x, y, yaw)`` (nav, m, rad), its ``gain`` (m³), drive ``cost`` (m)
    and ``score`` (gain · exp(−λ cost))."""

    pose: np.ndarray
    gain: float
    cost: float
    score: float

    def summary(self) -> dict[str, object]:
        """The view as the log records it (rounded)."""
        return {"pose": [round(float(x), 3) for x in self.pose], "gain_m3": round(self.gain, 3),
                "cost_m": round(self.cost, 3)}


class GainGrid:
    """M over V in coarse cells (:data:`~.volumetric.UNKNOWN`, ``FREE``, ``OCCUPIED``), ``cell`` (m) wide."""

    def __init__(self, occupancy: VolumetricMap, bounds: tuple[tuple[float, float, float], tuple[float, float, float]],
                 cell_voxels: int = 3):
        """Coarsen M's voxels in ``bounds`` (nav, m) by ``cell_voxels`` along each axis."""
        k = int(cell_voxels)
        key_lo, voxels = voxel_states(occupancy, np.asarray(bounds[0], dtype=float), np.asarray(bounds[1], dtype=float))
        n = [s // k for s in voxels.shape]
        blocks = voxels[: n[0] * k, : n[1] * k, : n[2] * k].reshape(n[0], k, n[1], k, n[2], k)
        occupied = (blocks == OCCUPIED).any(axis=(1, 3, 5))
        free = (blocks == FREE).any(axis=(1, 3, 5))
        self.states = np.where(occupied, OCCUPIED, np.where(free, FREE, UNKNOWN)).astype(np.int8)
        self.cell = k * occupancy.resolution
        self.lo = key_lo * occupancy.resolution
        ijk = np.indices(self.states.shape).reshape(3, -1).T
        self._centres = self.lo + (ijk + 0.5) * self.cell

    def centres(self, state: int) -> np.ndarray:
        """Centres ``(n, 3)`` (m) of the cells in ``state``."""
        return self._centres[self.states.reshape(-1) == state]

    @property
    def unknown_volume(self) -> float:
        """Unknown volume (m³) left in V."""
        return float(np.count_nonzero(self.states == UNKNOWN)) * self.cell**3

    def occupied_at(self, points: np.ndarray) -> np.ndarray:
        """``(...)`` True where ``points`` ``(..., 3)`` (m) fall in an occupied cell (outside V: False)."""
        ijk = np.floor((points - self.lo) / self.cell).astype(np.int64)
        inside = np.all((ijk >= 0) & (ijk < self.states.shape), axis=-1)
        ijk = np.where(inside[..., None], ijk, 0)
        return inside & (self.states[ijk[..., 0], ijk[..., 1], ijk[..., 2]] == OCCUPIED)


def visible_unknown(grid: GainGrid, camera: np.ndarray, view_range: float, half_v: float) -> np.ndarray:
    """Unknown cells' centres ``(n, 3)`` (m) within ``view_range`` of ``camera`` (nav, m) and ``half_v`` (rad) of
    its horizon, their sight line from it crossing no occupied cell (sampled every half cell, the end excluded)."""
    cells = grid.centres(UNKNOWN)
    offset = cells - camera
    distance = np.linalg.norm(offset, axis=1)
    horizontal = np.hypot(offset[:, 0], offset[:, 1])
    near = (distance <= view_range) & (np.abs(np.arctan2(offset[:, 2], horizontal)) <= half_v)
    cells, offset, distance = cells[near], offset[near], distance[near]
    if not len(cells):
        return cells
    steps = max(2, int(math.ceil(view_range / (0.5 * grid.cell))))
    t = np.linspace(0.0, 1.0, steps, endpoint=False)[1:]
    keep_out = np.clip(1.0 - 0.5 * grid.cell / np.maximum(distance, 1e-9), 0.0, 1.0)  # stop short of the cell
    samples = camera + (t[None, :, None] * keep_out[:, None, None]) * offset[:, None, :]
    clear = ~grid.occupied_at(samples).any(axis=1)
    return cells[clear]


def sector_gain(cells: np.ndarray, camera: np.ndarray, yaw: float, half_h: float, cell: float) -> float:
    """Volume (m³) of ``cells`` ``(n, 3)`` within ``half_h`` (rad) of heading ``yaw`` seen from ``camera``."""
    if not len(cells):
        return 0.0
    bearing = np.arctan2(cells[:, 1] - camera[1], cells[:, 0] - camera[0])
    off = np.abs(np.remainder(bearing - yaw + math.pi, math.tau) - math.pi)
    return float(np.count_nonzero(off <= half_h)) * cell**3


def camera_at(pose: np.ndarray, camera_offset: np.ndarray, ground_z: float = 0.0) -> np.ndarray:
    """The camera's position (nav, m) with the base at ``pose`` ``(x, y, yaw)``, ``ground_z`` (m) high;
    ``camera_offset``: its position in ``base_footprint``'s frame (m) at the look-around's central pose."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + c * camera_offset[0] - s * camera_offset[1],
                     pose[1] + s * camera_offset[0] + c * camera_offset[1], ground_z + camera_offset[2]])


def drive_poses(start: np.ndarray, goal: np.ndarray, step: float, turn_step: float = 0.2) -> np.ndarray:
    """Base poses ``(n, 3)`` of the drive from ``start`` to ``goal`` ``(x, y, yaw)``: along the straight line facing
    it, every ``step`` (m), then turning in place to the goal's yaw every ``turn_step`` (rad)."""
    offset = goal[:2] - start[:2]
    length = float(np.hypot(*offset))
    heading = math.atan2(offset[1], offset[0]) if length > 1e-6 else float(start[2])
    n = max(1, int(math.ceil(length / step)))
    line = start[:2] + np.linspace(0.0, 1.0, n + 1)[:, None] * offset
    turn = math.remainder(float(goal[2]) - heading, math.tau)
    yaws = heading + np.linspace(0.0, turn, max(1, int(math.ceil(abs(turn) / turn_step))) + 1)
    return np.vstack((np.column_stack((line, np.full(len(line), heading))),
                      np.column_stack((np.repeat(goal[None, :2], len(yaws), axis=0), yaws))))


def outside_body(cloud: SensorCloud, pose: np.ndarray, ground_z: float, footprint: Footprint,
                 height: float) -> SensorCloud:
    """``cloud`` without the rays that end on the robot itself (a self-filter): inside the rectangle ``footprint``
    about the base pose ``pose`` ``(x, y, yaw)`` (nav, m, rad), lower than ``height`` (m) above ``ground_z``.

    The ground-looking views see the front of the deck and the apparatuses on it; kept, they would stand in M
    as obstacles where the robot was.
    """
    c, s = math.cos(pose[2]), math.sin(pose[2])
    d = cloud.points[:, :2] - pose[:2]
    x, y = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
    body = ((-footprint.rear <= x) & (x <= footprint.front) & (np.abs(y) <= footprint.half_width)
            & (cloud.points[:, 2] < ground_z + height))
    return SensorCloud(np.ascontiguousarray(cloud.points[~body]), cloud.origin, cloud.max_range)


def turning_disc(pose: np.ndarray, footprint: Footprint, spacing: float) -> np.ndarray:
    """Ground points ``(n, 2)`` (nav, m), ``spacing`` apart, covering the disc the rectangle ``footprint`` sweeps
    turning in place at ``pose``."""
    radius = math.hypot(max(footprint.front, footprint.rear), footprint.half_width) + spacing  # whole cells
    g = np.arange(-radius, radius + spacing, spacing)
    x, y = np.meshgrid(g, g, indexing="ij")
    inside = np.hypot(x, y) <= radius
    return np.column_stack((x[inside] + pose[0], y[inside] + pose[1]))


def drive_grid(occupancy: VolumetricMap, start: np.ndarray, params: ExplorationParams,
               ground_z: float = 0.0) -> FootprintGrid:
    """M collapsed onto the ground over V and the reach of a base standing in it (:class:`~.placement.FootprintGrid`),
    the disc the base turns in at ``start`` ``(x, y, yaw)`` (nav, m, rad) counted as its own space."""
    lo, hi = (np.asarray(b, dtype=float) for b in params.bounds)
    footprint = Footprint(*(d + params.margin for d in params.footprint))
    own = turning_disc(np.asarray(start, dtype=float), footprint, 0.5 * occupancy.resolution)
    reach = math.hypot(max(footprint.front, footprint.rear), footprint.half_width) + occupancy.resolution
    return FootprintGrid(occupancy, lo[:2] - reach, hi[:2] + reach,
                         (ground_z + params.z_band[0], ground_z + params.z_band[1]), own)


def drive_clear(occupancy: VolumetricMap, start: np.ndarray, goal: np.ndarray, params: ExplorationParams,
                ground_z: float = 0.0, grid: FootprintGrid | None = None) -> bool:
    """Whether the straight drive from ``start`` to ``goal`` ``(x, y, yaw)`` (nav, m, rad), turning at both ends
    (:func:`drive_poses`), keeps the inflated base rectangle off M's occupied and unseen columns."""
    ground = grid if grid is not None else drive_grid(occupancy, start, params, ground_z)
    footprint = Footprint(*(d + params.margin for d in params.footprint))
    poses = drive_poses(np.asarray(start, dtype=float), np.asarray(goal, dtype=float), params.path_step)
    return not bool(ground.collides(footprint_points(poses, footprint, occupancy.resolution)).any())


def plan_viewpoints(occupancy: VolumetricMap, start: np.ndarray, camera_offset: np.ndarray,
                    params: ExplorationParams, visited: list[np.ndarray] | None = None,
                    ground_z: float = 0.0, grid: GainGrid | None = None) -> list[Viewpoint]:
    """The reachable viewpoints of V, best score first (§III Problem 1, [29]); those with gain below
    ``stuck_gain`` left out, so an empty list means stuck.

    ``start``: the base estimate ``(x, y, yaw)`` (nav, m, rad); ``camera_offset``: the camera's position in the
    base frame at the look-around's central pose (m, :func:`camera_at`); ``visited``: poses already viewed from,
    not proposed again (the same position within half a grid step and yaw within half a heading step);
    ``ground_z``: the height (m) of the ground the base stands on; ``grid``: M's gain cells over V, if already built
    from this M.
    """
    start = np.asarray(start, dtype=float)
    lo, hi = (np.asarray(b, dtype=float) for b in params.bounds)
    grid = grid if grid is not None else GainGrid(occupancy, params.bounds, params.cell_voxels)
    ground = drive_grid(occupancy, start, params, ground_z)
    clearance = distance_transform_edt(~(ground.occupied & ground.blocked)) * ground.resolution  # not its own space
    xs = np.arange(lo[0] + 0.5 * params.spacing, hi[0], params.spacing)
    ys = np.arange(lo[1] + 0.5 * params.spacing, hi[1], params.spacing)
    positions = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    positions = np.vstack((start[None, :2], positions))  # viewing again from where it stands costs no drive
    ij = np.floor(positions / ground.resolution).astype(np.int64) - ground.key_lo
    inside = np.all((ij >= 0) & (ij < ground.shape), axis=1)
    ij = np.where(inside[:, None], ij, 0)
    keep = inside & (clearance[ij[:, 0], ij[:, 1]] >= params.clearance)
    if params.horizon is not None:
        keep &= np.hypot(*(positions - start[:2]).T) <= params.horizon
    positions = positions[keep]
    yaws = np.arange(params.headings) * math.tau / params.headings - math.pi
    visited = visited or []
    views: list[Viewpoint] = []
    for xy in positions:
        for yaw in yaws:
            pose = np.array([xy[0], xy[1], yaw])
            if any(np.hypot(*(pose[:2] - v[:2])) < 0.5 * params.spacing
                   and abs(math.remainder(yaw - v[2], math.tau)) < math.pi / params.headings for v in visited):
                continue
            if not drive_clear(occupancy, start, pose, params, ground_z, ground):
                continue
            camera = camera_at(pose, camera_offset, ground_z)
            cells = visible_unknown(grid, camera, params.view_range, params.half_fov[1])
            gain = sector_gain(cells, camera, yaw, params.half_fov[0], grid.cell)
            if gain < params.stuck_gain:
                continue
            heading = math.atan2(*(pose[:2] - start[:2])[::-1]) if np.hypot(*(pose[:2] - start[:2])) > 1e-6 \
                else start[2]
            turned = abs(math.remainder(heading - start[2], math.tau)) + abs(math.remainder(yaw - heading, math.tau))
            cost = float(np.hypot(*(pose[:2] - start[:2]))) + params.w_turn * turned
            views.append(Viewpoint(pose, gain, cost, gain * math.exp(-params.lam * cost)))
    return sorted(views, key=lambda v: -v.score)
