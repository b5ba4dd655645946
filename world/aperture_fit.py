"""A tight aperture for the MAV: one opening of the aperture wall scaled so the Tello fits with a set clearance.

Arora & Papachristos insert the micro-scout through apertures "constricted"
for it (§IV-E/F); the insertion benchmark (``benchmarks/aperture.py``) asks
how often that works when the fit is tight. A mission's
``world.disturbances.aperture_fit`` entry names a shape class (an opening
``aperture_<shape>`` of the scene, or a list to draw one from) and a
clearance ``c`` (m, or a ``[low, high]`` range to draw it from); the world
then

- scales that opening's exact outline (:func:`~.apertures.aperture_outline`)
  about the centre of its bounding box by the factor ``k`` at which the
  clearance of the MAV in it is ``c`` (:func:`scale_to_clearance`);
- closes the other openings of the wall: the ranking would otherwise go to
  whichever aperture ranks first, usually a roomier one, and the trial would
  not test the tight fit (the ranking has its own benchmark);
- rebuilds the wall (every object tagged :data:`~.rim_contacts.RIM_TAG`) as
  boxes around a window about the opening (:func:`~.decoys.wall_pieces`) and,
  inside the window, convex prisms whose union is the window minus the
  opening, exactly (a constrained Delaunay triangulation merged into convex
  pieces, :func:`convex_parts`, each a pybullet convex mesh whose
  collision margin is 0.1 mm, :meth:`~.scene.Scene.add_prism`);
- moves the zone ``aperture_<shape>`` to the new opening's bounding box,
  scales ``aperture_<shape>_clear`` with it (the largest clear rectangle
  scales with the outline) and removes the closed openings' zones.

Clearance, precisely: for an opening P (a polygon in the wall plane) and the
MAV's fronto-parallel outline S as the profile analysis takes it (C_m in
metres, :func:`~marsupial.api.silhouette.mav_silhouette`: the
Tello in the apparatus's cradle seen along its body x, nose first, §IV-B),
the clearance is the largest distance by which S, turned by any angle θ
about its centre of mass and moved to any centre t, can stay inside P:

    c(P) = max over θ, t with S_θ + t ⊆ P of dist(S_θ + t, complement of P).

Since ``dist(S_θ + t, B) = dist(t, B ⊕ −S_θ)``, for one θ the best margin is
the radius of the largest circle inscribed in ``P ∖ (∂P ⊕ −S_θ)`` (the
centres at which S_θ touches no edge of P); the Minkowski sum of each edge
with each convex part of −S_θ is the convex hull of their end points' sums
(shapely, exact). θ is searched on a grid of :data:`ANGLE_STEP_DEG` and
refined around the best angles down to :data:`ANGLE_TOLERANCE_DEG`; ``k``
by bisection down to a relative :data:`SCALE_TOLERANCE`.

Everything is seeded: the shape and the clearance are drawn with
``world.rng_for("disturbance/aperture_fit")``. Truth for scoring only: no
skill reads the zones or the outline. Frames and units: the wall plane
``(x, z)`` in world metres, seen from the approach side (−y); angles in
radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, TypeAlias

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import MultiPolygon, Polygon, box

from marsupial.api.errors import UnknownNameError, WorldError

from .apertures import aperture_outline
from .decoys import wall_pieces
from .rim_contacts import RIM_TAG
from .scene import Zone

if TYPE_CHECKING:
    from marsupial.api.config import ApertureFitEntry

    from .scene import Scene
    from .world import World

Opening: TypeAlias = "Polygon | MultiPolygon"
"""An opening in the wall plane: one polygon, or several parts (shapely; x, z in world m)."""

ANGLE_STEP_DEG = 5.0
"""Grid of MAV angles θ (degrees) on which the clearance is searched first."""
ANGLE_TOLERANCE_DEG = 0.05
"""The best angles are refined down to this step (degrees)."""
REFINED_ANGLES = 2
"""How many of the grid's best angles are refined."""
SCALE_TOLERANCE = 1e-3
"""Bisection of the scale factor k stops at this relative width (about 0.1 mm on a 0.1 m opening)."""
INSCRIBED_TOLERANCE_M = 1e-5
"""Tolerance (m) of the largest inscribed circle (shapely's ``maximum_inscribed_circle``)."""
FRAME_M = 0.03
"""Width (m) of the window of convex prisms about the opening's bounding box; boxes cover the rest of the wall."""
WALL_MARGIN_M = 0.05
"""The window must stay this far (m) inside the wall's extent."""
PIECE_AREA_M2 = 1e-12
"""Pieces of a triangulation smaller than this (m²) are numerical dust, dropped."""


# ------------------------------------------------------------ geometry
def convex_parts(region: Polygon) -> list[Polygon]:
    """Convex polygons whose union is ``region`` (it may have holes) and which overlap only on their edges.

    The constrained Delaunay triangulation of ``region`` (shapely), with neighbouring pieces merged while their
    union stays convex (greedily, as Hertel and Mehlhorn do with diagonals).
    """
    pieces = [t for t in shapely.get_parts(shapely.constrained_delaunay_triangles(region)) if t.area > PIECE_AREA_M2]
    merged = True
    while merged:
        merged = False
        tree = shapely.STRtree(pieces)
        for i, piece in enumerate(pieces):
            for j in tree.query(piece, predicate="touches"):
                if j <= i:
                    continue
                union = piece.union(pieces[j])
                hull = union.convex_hull
                if isinstance(union, Polygon) and hull.area - union.area <= 1e-9 * hull.area:
                    pieces[i] = hull
                    del pieces[j]
                    merged = True
                    break
            if merged:
                break
    return pieces


@cache
def _mav_parts() -> tuple[np.ndarray, ...]:
    """The convex parts of the MAV's fronto-parallel outline (m, about its centre of mass), each ``(n, 2)``."""
    from marsupial.api.silhouette import mav_silhouette  # the skills' C_m, in metres

    outline = mav_silhouette()  # image axes u right, v down: the wall plane's x, −z as the camera sees it
    parts = convex_parts(Polygon(np.c_[outline[:, 0], -outline[:, 1]]))
    return tuple(np.asarray(p.exterior.coords)[:-1] for p in parts)


@dataclass(frozen=True)
class MavFit:
    """The MAV's best pose in an opening (wall plane, world m, rad).

    Attributes:
        clearance: the margin (m) it keeps from the opening's rim there (negative: it fits nowhere).
        angle: θ, the turn of its outline about its centre of mass (rad, counter-clockwise as seen from −y).
        centre: ``(x, z)`` of its centre of mass (m).
    """

    clearance: float
    angle: float
    centre: tuple[float, float]


def _fit_at(opening: Opening, parts: Sequence[np.ndarray], angle: float) -> MavFit:
    """The best centre of the MAV turned by ``angle`` in ``opening`` and its margin (see the module docstring)."""
    c, s = math.cos(angle), math.sin(angle)
    turned = [p @ np.array([[c, s], [-s, c]]) for p in parts]  # S_θ's convex parts (row vectors)
    rings = [np.asarray(r.coords) for g in shapely.get_parts(opening) for r in (g.exterior, *g.interiors)]
    ends = []
    for ring in rings:
        a, b = ring[:-1, None, :], ring[1:, None, :]
        ends += [np.concatenate((a - part[None], b - part[None]), axis=1) for part in turned]
    touching = shapely.union_all(shapely.convex_hull(shapely.multipoints(np.concatenate(ends))))
    free = opening.difference(touching)
    best = MavFit(-1.0, angle, (math.nan, math.nan))
    for region in shapely.get_parts(free):
        if region.area <= PIECE_AREA_M2:
            continue
        radius = shapely.maximum_inscribed_circle(region, tolerance=INSCRIBED_TOLERANCE_M)
        if radius.length > best.clearance:
            x, z = radius.coords[0]
            best = MavFit(float(radius.length), angle, (float(x), float(z)))
    return best


def mav_clearance(
    opening: Opening, parts: Sequence[np.ndarray] | None = None, enough: float = math.inf, hint: float | None = None
) -> MavFit:
    """The clearance of the MAV (convex ``parts`` of its outline, default the Tello's) in ``opening``: its best pose.

    θ on a grid of :data:`ANGLE_STEP_DEG` over a full turn (the outline is not symmetric), then the
    :data:`REFINED_ANGLES` best refined by grids five times finer about them down to :data:`ANGLE_TOLERANCE_DEG`.
    With ``enough`` (m), the first pose found with at least that clearance is returned (the angle ``hint`` is
    tried first): enough to tell whether the MAV fits with it.
    """
    parts = _mav_parts() if parts is None else parts
    step = math.radians(ANGLE_STEP_DEG)
    fits: list[MavFit] = []
    for angle in ([] if hint is None else [hint]) + list(np.arange(0.0, 2.0 * math.pi, step)):
        fits.append(_fit_at(opening, parts, float(angle)))
        if fits[-1].clearance >= enough:
            return fits[-1]
    best = max(fits, key=lambda f: f.clearance)
    for around in sorted(fits, key=lambda f: -f.clearance)[:REFINED_ANGLES]:
        width = step
        while width > math.radians(ANGLE_TOLERANCE_DEG):
            width /= 5.0
            candidates = [_fit_at(opening, parts, around.angle + i * width) for i in (-4, -3, -2, -1, 1, 2, 3, 4)]
            around = max([around, *candidates], key=lambda f: f.clearance)
            if around.clearance >= enough:
                return around
        best = max(best, around, key=lambda f: f.clearance)
    return best


def scale_to_clearance(
    outline: Opening, centre: tuple[float, float], clearance: float, parts: Sequence[np.ndarray] | None = None
) -> tuple[float, Opening]:
    """The factor k and the opening ``outline`` scaled by k about ``centre`` in which the MAV's clearance is
    ``clearance`` (m), by bisection (the clearance grows with k) to a relative :data:`SCALE_TOLERANCE`."""
    hint: float | None = None

    def fits(k: float) -> bool:
        nonlocal hint
        found = mav_clearance(affinity.scale(outline, k, k, origin=centre), parts, clearance, hint)
        if found.clearance >= clearance:
            hint = found.angle
        return found.clearance >= clearance

    low, high = 0.0, 1.0
    while not fits(high):
        low, high = high, 2.0 * high
    while high - low > SCALE_TOLERANCE * high:
        middle = (low + high) / 2.0
        low, high = (low, middle) if fits(middle) else (middle, high)
    return high, affinity.scale(outline, high, high, origin=centre)


# ------------------------------------------------------------ the entry
def draw_fit(entry: ApertureFitEntry, rng: np.random.Generator) -> tuple[str, float]:
    """The shape class and the clearance (m) of one world, drawn uniformly from ``entry``'s with ``rng``, in that
    order (a clearance range with ``low == high`` gives that clearance)."""
    shape = entry.shapes[int(rng.integers(len(entry.shapes)))]
    low, high = entry.clearance_range
    return shape, float(rng.uniform(low, high)) if high > low else low


@dataclass(frozen=True)
class ApertureFit:
    """The tight aperture a world was given.

    Attributes:
        shape: its shape class (zone ``aperture_<shape>``).
        clearance: the clearance asked for (m).
        scale: k, the factor by which the scene's opening was scaled about its bounding box's centre.
        opening: the new opening in the wall plane (world x, z in m).
        fit: the MAV's best pose in it, measured again (its clearance equals ``clearance`` within the tolerances).
    """

    shape: str
    clearance: float
    scale: float
    opening: Opening
    fit: MavFit


def fit_aperture(world: World, entry: ApertureFitEntry, rng: np.random.Generator) -> ApertureFit:
    """Give ``world``'s scene the tight aperture ``entry`` draws from ``rng`` (module docstring); returns it.

    :class:`WorldError` when the scene has no such aperture or wall, or the scaled opening leaves the wall.
    """
    scene = world.scene
    shape, clearance = draw_fit(entry, rng)
    zone = scene.zone(f"aperture_{shape}")
    centre = (float(zone.center[0]), float(zone.center[2]))
    k, opening = scale_to_clearance(aperture_outline(shape, scene.name), centre, clearance)
    y_range = rebuild_wall(scene, opening)
    _move_zones(scene, zone, k, opening, y_range)
    return ApertureFit(shape, clearance, k, opening, mav_clearance(opening))


def rebuild_wall(scene: Scene, opening: Opening) -> tuple[float, float]:
    """Replace the wall (objects tagged ``RIM_TAG``) by one whose only opening is ``opening``; its y range (m).

    Boxes cover the wall but a window :data:`FRAME_M` about the opening's bounding box, convex prisms the window
    less the opening; they take the first wall object's colour and tags.
    """
    walls = scene.tagged(RIM_TAG)
    if not walls:
        raise WorldError(f"aperture_fit: scene {scene.name} has no wall (objects tagged '{RIM_TAG}')")
    lo, hi = scene.aabb(RIM_TAG)
    (x0, y0, z0), (x1, y1, z1) = lo.tolist(), hi.tolist()
    ox0, oz0, ox1, oz1 = opening.bounds
    window = (ox0 - FRAME_M, ox1 + FRAME_M, oz0 - FRAME_M, oz1 + FRAME_M)
    if not (
        x0 + WALL_MARGIN_M <= window[0]
        and window[1] <= x1 - WALL_MARGIN_M
        and z0 + WALL_MARGIN_M <= window[2]
        and window[3] <= z1 - WALL_MARGIN_M
    ):
        raise WorldError(
            f"aperture_fit: the scaled opening (x {ox0:.3f} … {ox1:.3f}, z {oz0:.3f} … {oz1:.3f} m) "
            f"leaves the wall (x {x0:.3f} … {x1:.3f}, z {z0:.3f} … {z1:.3f} m, less "
            f"{FRAME_M + WALL_MARGIN_M} m); ask for a smaller clearance"
        )
    rgb, tags = walls[0].rgb, walls[0].tags
    for wall in walls:
        scene.remove(wall.label)
    thickness, y = y1 - y0, (y0 + y1) / 2.0
    for i, (a, b, bottom, top) in enumerate(wall_pieces((x0, x1, z0, z1), [window]), start=1):
        scene.add_box(
            f"aperture_fit_wall_{i}", (b - a, thickness, top - bottom), ((a + b) / 2, y, (bottom + top) / 2), rgb, tags
        )
    frame = box(window[0], window[2], window[1], window[3]).difference(opening)
    for i, piece in enumerate(convex_parts(frame), start=1):
        scene.add_prism(f"aperture_fit_rim_{i}", np.asarray(piece.exterior.coords)[:-1], (y0, y1), rgb, tags)
    return y0, y1


def _move_zones(scene: Scene, old: Zone, k: float, opening: Opening, y_range: tuple[float, float]) -> None:
    """Zone ``old`` moved to ``opening``'s bounding box, its ``_clear`` zone scaled by ``k`` about its centre, the
    other apertures' zones (tagged ``aperture``, and their ``_clear`` zones) removed."""
    ox0, oz0, ox1, oz1 = opening.bounds
    cx, cz = float(old.center[0]), float(old.center[2])
    clear = scene.zones.get(f"{old.label}_clear")
    for zone in scene.zones_tagged("aperture"):
        scene.remove_zone(zone.label)
        if f"{zone.label}_clear" in scene.zones:
            scene.remove_zone(f"{zone.label}_clear")
    scene.add_zone(Zone(old.label, (ox0, y_range[0], oz0), (ox1, y_range[1], oz1), old.tags))
    if clear is not None:
        (ax, _, az), (bx, _, bz) = clear.lo, clear.hi
        scene.add_zone(
            Zone(
                clear.label,
                (cx + k * (ax - cx), y_range[0], cz + k * (az - cz)),
                (cx + k * (bx - cx), y_range[1], cz + k * (bz - cz)),
                clear.tags,
            )
        )


def known_shapes(scene: Scene) -> list[str]:
    """The shape classes of ``scene``'s apertures: ``<shape>`` of each zone ``aperture_<shape>`` tagged ``aperture``."""
    return [z.label.removeprefix("aperture_") for z in scene.zones_tagged("aperture")]


def check_shapes(scene: Scene, shapes: Sequence[str]) -> None:
    """:class:`UnknownNameError` (listing the known ones) for a shape class that is not an aperture of ``scene``."""
    known = known_shapes(scene)
    for shape in shapes:
        if shape not in known:
            raise UnknownNameError(f"{scene.name} aperture shape", shape, known)
