"""Scene knowledge an operator could give the robots: the building plan (structure, zones, guide paths).

The sensing boundary lets skills know the scene only as a prior the mission
declares. A mission declares its scene (``world: {scene: ...}``); what that
scene file writes down as *plan* knowledge reaches the nodes as a
:class:`BuildingPlan` (``self.context.prior("building_plan")``), copied from
the file's declared data, never from the world's bodies, and without what a
benchmark scores (the shapes of apertures, decoys, fitted rims):

- ``structure``: the objects tagged :data:`STRUCTURE_TAGS` (walls, door
  frames) — what a building plan shows. Debris, furniture and the target are
  not on a plan: robots must sense them;
- ``zones``: the declared zones (rooms, corridors, door frames, start);
- ``paths``: the declared ground paths (the operator's guide path).

World frame (m, rad), which is where every robot's navigation frame starts.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from marsupial.geometry import rotation_matrix

from .errors import UnknownNameError

STRUCTURE_TAGS = frozenset({"wall", "door_frame"})


@dataclass(frozen=True)
class PlanElement:
    """One element of the plan (a wall, a door frame) as its box: centre (m), quaternion, size along its axes (m)."""

    label: str
    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]
    size: tuple[float, float, float]
    tags: tuple[str, ...] = ()

    def corners(self) -> np.ndarray:
        """The 8 corners (m, world) of the element's box."""
        half = 0.5 * np.asarray(self.size, dtype=float)
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
        return np.asarray(self.position) + (signs * half) @ rotation_matrix(self.orientation).T

    def distance(self, point: Sequence[float]) -> float:
        """Distance (m) from ``point`` to the box; 0 inside.

        ``point`` is ``[x, y]`` (plan view, at the element's mid-height) or ``[x, y, z]``.
        """
        p = np.asarray(point, dtype=float)
        if len(p) == 2:
            p = np.append(p, self.position[2])
        local = rotation_matrix(self.orientation).T @ (p - np.asarray(self.position))
        return float(np.linalg.norm(np.maximum(np.abs(local) - 0.5 * np.asarray(self.size), 0.0)))


@dataclass(frozen=True)
class PlanZone:
    """A declared zone: axis-aligned box ``lo``..``hi`` (m, world) with tags."""

    label: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    tags: tuple[str, ...] = ()

    def distance(self, point: Sequence[float]) -> float:
        """Distance (m) from ``point`` (``[x, y]`` plan view, or ``[x, y, z]``) to the box; 0 inside."""
        p = np.asarray(point, dtype=float)
        n = len(p)
        lo, hi = np.asarray(self.lo[:n]), np.asarray(self.hi[:n])
        return float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - p, p - hi))))


@dataclass(frozen=True)
class BuildingPlan:
    """The plan of the scene a mission declares: extent (m), structure, zones, guide paths (world frame)."""

    name: str
    size: tuple[float, float]
    structure: tuple[PlanElement, ...] = ()
    zones: tuple[PlanZone, ...] = ()
    paths: dict[str, np.ndarray] = field(default_factory=dict)


    def path(self, name: str) -> np.ndarray:
        """Way-points ``(n, 2)`` (m) of the declared path ``name``; the error lists the plan's paths."""
        try:
            return self.paths[name].copy()
        except KeyError:
            raise UnknownNameError(f"{self.name} path", name, self.paths) from None

    def tagged(self, tag: str) -> list[PlanElement]:
        """Structure elements carrying ``tag``."""
        return [e for e in self.structure if tag in e.tags]

    def zones_at(self, point: Sequence[float], margin: float = 0.0, tag: str | None = None) -> list[PlanZone]:
        """Zones (carrying ``tag`` if given) within ``margin`` m of ``point`` (``[x, y]`` or ``[x, y, z]``)."""
        return [z for z in self.zones if (tag is None or tag in z.tags) and z.distance(point) <= margin]


PRIORS = ("building_plan",)
