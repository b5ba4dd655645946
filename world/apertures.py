"""The apertures of a scene as the world builds them: exact outlines in the wall plane (truth: tests, benchmarks).

A scene such as ``collapsed_mockup`` declares each opening of its aperture
wall as a zone ``aperture_<shape>`` (the opening's bounding box) and builds the
shape with wall pieces (tag ``mockup_wall``) inside or around it: sills,
heads, slabs, lobes, tongues, boxes turned about the wall normal (y). The
opening is the zone's box in the wall plane minus every piece's footprint.

Wall-plane coordinates: ``(x, z)`` world metres, seen from the approach side
(-y, looking along +y): x to the right, z up. Decision code never reads this
(scene truth); it scores what the robots detect.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from shapely import contains_xy
from shapely.geometry import Polygon, box

from .scene import read_scene_spec, scene_file

WALL_TAG = "mockup_wall"


def _footprint(entry: dict[str, Any]) -> Polygon:
    """A wall box's outline in the wall plane (it may be turned about y by its ``rpy`` pitch)."""
    x, _, z = (float(v) for v in entry["position"])
    sx, _, sz = (float(v) for v in entry["size"])
    pitch = float(entry.get("rpy", (0.0, 0.0, 0.0))[1])
    c, s = math.cos(pitch), math.sin(pitch)
    ax, az = np.array([c, -s]) * sx / 2.0, np.array([s, c]) * sz / 2.0  # the box's x and z axes in (x, z)
    centre = np.array([x, z])
    return Polygon([centre + ax + az, centre - ax + az, centre - ax - az, centre + ax - az])


def aperture_outline(shape: str, scene: str = "collapsed_mockup") -> Polygon:
    """The opening of zone ``aperture_<shape>`` of ``scene`` in wall-plane coordinates (m), exact.

    Raises ``KeyError`` when the scene has no such zone.
    """
    spec = read_scene_spec(scene_file(scene))
    zones = {z["label"]: z for z in spec.get("zones", [])}
    zone = zones[f"aperture_{shape}"]
    (x, _, z), (sx, _, sz) = zone["position"], zone["size"]
    opening: Polygon = box(x - sx / 2.0, z - sz / 2.0, x + sx / 2.0, z + sz / 2.0)
    for entry in spec.get("objects", []):
        if WALL_TAG in entry.get("tags", ()):
            opening = opening.difference(_footprint(entry))
    return opening


def rasterised(outline: Polygon, pixel_m: float, pad_px: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """``outline`` as a uint8 mask (255 inside) of pixels ``pixel_m`` wide, with ``pad_px`` empty pixels around.

    Image axes: u = x, v = -z (wall plane seen from the approach side). Returns the mask and the wall-plane
    ``(x, z)`` (m) of pixel ``(0, 0)``'s centre; pixel ``(u, v)`` is at ``(x0 + u p, z0 - v p)``.
    """
    x_lo, z_lo, x_hi, z_hi = outline.bounds
    origin = np.array([x_lo - pad_px * pixel_m, z_hi + pad_px * pixel_m])
    w = math.ceil((x_hi - x_lo) / pixel_m) + 2 * pad_px + 1
    h = math.ceil((z_hi - z_lo) / pixel_m) + 2 * pad_px + 1
    u, v = np.meshgrid(np.arange(w), np.arange(h))

    inside = contains_xy(outline, origin[0] + u * pixel_m, origin[1] - v * pixel_m)
    return np.where(inside, 255, 0).astype(np.uint8), origin
