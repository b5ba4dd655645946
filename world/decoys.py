"""Decoy openings cut into a wall of the scene: shallow recesses and holes too small for the MAV, seeded.

Arora & Papachristos (§IV-B, §IV-C) keep an aperture only if it is hollow
(deeper than the model plane by more than d_C, Definition 1) and wider than
the MAV contour C_m, and rank the candidates by the log-odds belief; the
benchmark ``benchmarks/aperture.py`` scores how often the real ingress
aperture ranks first among openings that look like one. The decoys a
mission's ``world.disturbances.decoys`` entries ask for:

- a *recess*: an opening in the wall's face closed behind at ``depth`` (less
  than the detection's d_C = 0.05 m by default): a pocket, not see-through;
- a *hole*: a see-through opening whose sides are both below 0.0945 m, the
  side of the smallest square the Tello's 0.0926 × 0.041 m nose-first
  outline fits in (turned by 45°), so the MAV passes at no angle, though its
  area may exceed the outline's (the detection's area test).

Each entry names a box of the scene (``wall``) lying along the world x axis
(no rotation) with its face toward -y (the approach side of
``collapsed_mockup``), the ``x`` and ``z`` ranges (world m) the decoys lie
in, and how many of each; positions and sizes are drawn uniformly from the
entry's ranges with ``world.rng_for("disturbance/decoys/<entry>")``, each
decoy at least ``gap`` from the others and from the range's ends, so one seed
gives one layout. The wall box is replaced by the boxes around the openings
(``<wall>_piece_<i>``, the wall's colour and tags) and each recess gets its
back (``decoy_recess_<n>_back``). Truth for scoring: zones ``decoy_recess_<n>``
(tags ``decoy``, ``recess``: the pocket, from the face to its back) and
``decoy_hole_<n>`` (tags ``decoy``, ``hole``: the opening through the wall);
the scene's ``aperture`` zones are untouched.

Frames and units: world frame, metres; the wall plane is ``(x, z)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from marsupial.api.errors import WorldError

from .scene import Zone

if TYPE_CHECKING:
    from marsupial.api.config import DecoyEntry

    from .scene import SceneObject
    from .world import World

MAV_SQUARE_M = 0.0945
"""Side (m) of the smallest square the Tello's nose-first outline (0.0926 × 0.041 m) fits in, turned by 45°; the
default hole sides (:data:`marsupial.api.config.HOLE_SIDE_M`) stay below it."""
MAX_DRAWS = 500  # rejection-sampling attempts per decoy before the layout is declared impossible


@dataclass(frozen=True)
class Decoy:
    """One decoy opening in the wall plane.

    Attributes:
        label: its zone's label (``decoy_recess_<n>`` or ``decoy_hole_<n>``).
        kind: ``"recess"`` or ``"hole"``.
        x, z: centre of the opening (world m).
        width, height: its extent along x and z (m).
        depth: how far behind the face it reaches (m): a recess's back; a hole's is the wall thickness.
    """

    label: str
    kind: str
    x: float
    z: float
    width: float
    height: float
    depth: float

    @property
    def box(self) -> tuple[float, float, float, float]:
        """``(x_lo, x_hi, z_lo, z_hi)`` of the opening (m)."""
        return (self.x - self.width / 2, self.x + self.width / 2, self.z - self.height / 2, self.z + self.height / 2)


def draw_layout(spec: DecoyEntry, rng: np.random.Generator, numbers: dict[str, int], thickness: float) -> list[Decoy]:
    """The decoys of ``spec``: recesses first, then holes, each placed at random clear of the others.

    ``numbers`` counts the decoys of each kind made so far (labels go on from it; updated); ``thickness``
    is the wall's (m), a hole's depth. :class:`WorldError` when a decoy finds no room in ``MAX_DRAWS`` draws.
    """
    wanted = [("recess", spec.recess_width, spec.recess_height)] * spec.recesses
    wanted += [("hole", spec.hole_size, spec.hole_size)] * spec.holes
    placed: list[Decoy] = []
    for kind, widths, heights in wanted:
        for _ in range(MAX_DRAWS):
            w, h = rng.uniform(widths[0], widths[1]), rng.uniform(heights[0], heights[1])
            depth = rng.uniform(spec.recess_depth[0], spec.recess_depth[1]) if kind == "recess" else thickness
            lo_x, hi_x = spec.x[0] + spec.gap + w / 2, spec.x[1] - spec.gap - w / 2
            lo_z, hi_z = spec.z[0] + spec.gap + h / 2, spec.z[1] - spec.gap - h / 2
            if lo_x > hi_x or lo_z > hi_z:
                continue
            x, z = rng.uniform(lo_x, hi_x), rng.uniform(lo_z, hi_z)
            clear = all(abs(x - d.x) >= (w + d.width) / 2 + spec.gap or abs(z - d.z) >= (h + d.height) / 2 + spec.gap
                        for d in placed)
            if clear:
                numbers[kind] = numbers.get(kind, 0) + 1
                placed.append(Decoy(f"decoy_{kind}_{numbers[kind]}", kind, float(x), float(z), float(w), float(h),
                                    float(depth)))
                break
        else:
            raise WorldError(f"decoys in {spec.wall}: no room for another {kind} in x {spec.x}, z {spec.z} "
                             f"after {MAX_DRAWS} draws ({len(placed)} placed)")
    return placed


def wall_pieces(extent: tuple[float, float, float, float], openings: Sequence[tuple[float, float, float, float]]
                ) -> list[tuple[float, float, float, float]]:
    """Rectangles ``(x_lo, x_hi, z_lo, z_hi)`` covering ``extent`` minus the ``openings`` (disjoint, inside it).

    The wall is cut into vertical slabs at the openings' x edges; each slab keeps the z intervals no opening
    covers; neighbouring slabs with the same intervals are merged.
    """
    x0, x1, z0, z1 = extent
    edges = sorted({x0, x1, *(o[0] for o in openings), *(o[1] for o in openings)})
    slabs: list[tuple[float, float, list[tuple[float, float]]]] = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        mid = (a + b) / 2
        cuts = sorted((o[2], o[3]) for o in openings if o[0] < mid < o[1])
        solid, bottom = [], z0
        for lo, hi in cuts:
            if lo > bottom:
                solid.append((bottom, lo))
            bottom = max(bottom, hi)
        if bottom < z1:
            solid.append((bottom, z1))
        if slabs and slabs[-1][2] == solid:
            slabs[-1] = (slabs[-1][0], b, solid)
        else:
            slabs.append((a, b, solid))
    return [(a, b, lo, hi) for a, b, solid in slabs for lo, hi in solid if hi - lo > 1e-9 and b - a > 1e-9]


def cut_decoys(world: World, spec: DecoyEntry, rng: np.random.Generator, numbers: dict[str, int]) -> list[Decoy]:
    """Cut the decoys of ``spec`` into its wall in ``world``'s scene: the wall rebuilt around them, zones added.

    :class:`WorldError` for a wall that is not an unrotated box or ranges outside it.
    """
    scene = world.scene
    wall = scene.object(spec.wall)
    x0, x1, y0, y1, z0, z1 = _box_extent(wall)
    if not (x0 <= spec.x[0] < spec.x[1] <= x1 and z0 <= spec.z[0] < spec.z[1] <= z1):
        raise WorldError(f"decoys in {spec.wall}: x {spec.x} and z {spec.z} must be increasing ranges inside the "
                         f"wall (x {x0:.3f} … {x1:.3f}, z {z0:.3f} … {z1:.3f})")
    decoys = draw_layout(spec, rng, numbers, y1 - y0)
    scene.remove(spec.wall)
    for i, (a, b, lo, hi) in enumerate(wall_pieces((x0, x1, z0, z1), [d.box for d in decoys]), start=1):
        scene.add_box(f"{spec.wall}_piece_{i}", (b - a, y1 - y0, hi - lo), ((a + b) / 2, (y0 + y1) / 2, (lo + hi) / 2),
                      wall.rgb, wall.tags)
    for d in decoys:
        a, b, lo, hi = d.box
        back = y0 + d.depth  # the face is at y0 (toward -y)
        if d.kind == "recess":
            scene.add_box(f"{d.label}_back", (d.width, y1 - back, d.height), (d.x, (back + y1) / 2, d.z), wall.rgb,
                          (*wall.tags, "decoy", "recess"))
        scene.add_zone(Zone(d.label, (a, y0, lo), (b, back, hi), ("decoy", d.kind)))
    return decoys


def _box_extent(wall: SceneObject) -> tuple[float, float, float, float, float, float]:
    """``(x0, x1, y0, y1, z0, z1)`` of an unrotated box (m); :class:`WorldError` otherwise."""
    if wall.shape != "box" or not math.isclose(abs(wall.orientation[3]), 1.0, abs_tol=1e-9):
        raise WorldError(f"decoys in {wall.label}: the wall must be a box along the world axes (no yaw or rpy)")
    (x, y, z), (sx, sy, sz) = wall.position, wall.size
    return x - sx / 2, x + sx / 2, y - sy / 2, y + sy / 2, z - sz / 2, z + sz / 2
