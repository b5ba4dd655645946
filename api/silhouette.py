"""The MAV's fronto-parallel contour C_m (Arora & Papachristos, §IV-B, §IV-E): its outline as the aperture sees it.

"We compute the 2-D projection MAV^2D of the 'fronto-parallel' view of the
MAV mesh, and project it onto the I image plane using the pinhole scale
factor for the model plane depth" (§IV-B). The mesh here is the MAV's
collision geometry in its URDF (the robot's static model, what its designers
wrote down): each box, cylinder or sphere is projected along the direction in
which the MAV passes through the aperture and the projections are merged
(shapely union) into one outline.

The MAV goes through nose first (along its body x): the launching apparatus
holds it with its heading along the boom (``launching_apparatus.urdf``), and
Phase III of §IV-F only rolls it level afterwards. Seen along body x the
Tello is 0.0926 m wide (propeller guards) and 0.041 m high.

What passes through the aperture is the MAV *in its cradle*: the cradle's
tray (0.054 m wide) reaches 7 mm below the Tello and its boom follows it
through the plane (Phase II slips the MAV at least 0.16 m deep, the boom
starts 0.034 m behind the MAV). By default the outline is therefore the union
of the Tello's and the cradle link's collision shapes seen along body x (a
departure: the paper speaks of the MAV mesh alone, and with the Tello alone
the profile analysis placed the tray onto the rim).

Frames: the MAV's base frame (x forward, y left, z up, origin at the centre
of mass) in metres; the outline in image axes (u right, v down, as the
fronto-parallel view looks along the MAV's x with its z up), metres or pixels.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from functools import cache

import numpy as np
import shapely
from shapely.geometry import MultiPoint, Polygon

from marsupial.api.assets import asset_path

MAV_URDF = "tello.urdf"  # the micro-scout of §III-B
APPARATUS_URDF = "launching_apparatus.urdf"  # the cradle that holds it through the aperture
SEAT_IN_CRADLE = np.array([0.0, 0.0, -0.009])  # mav_seat in the cradle frame (launching_apparatus.urdf)
TELLO_LANDED_HEIGHT = 0.0215  # the tello's base above the seat when it rests on the tray (m, TELLO spec)
MAV_IN_CRADLE = SEAT_IN_CRADLE + np.array([0.0, 0.0, TELLO_LANDED_HEIGHT])
"""The MAV's base frame's origin in the cradle frame while it sits in the cradle (m, same axes)."""
CIRCLE_SEGMENTS = 32  # vertices of a projected circle


def _rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF ``rpy`` as a rotation matrix (fixed axes x, y, z: R = Rz(yaw) Ry(pitch) Rx(roll))."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def _numbers(element: ET.Element | None, key: str) -> list[float]:
    """The three numbers of attribute ``key`` of an URDF ``origin`` element (zeros when absent)."""
    text = element.attrib.get(key, "0 0 0") if element is not None else "0 0 0"
    return [float(x) for x in text.split()]


def _shape_points(geometry: ET.Element) -> np.ndarray:
    """Points (m, shape frame) whose convex hull is the primitive in ``geometry`` (box, cylinder or sphere)."""
    box, cylinder, sphere = geometry.find("box"), geometry.find("cylinder"), geometry.find("sphere")
    if box is not None:
        half = np.array([float(x) for x in box.attrib["size"].split()]) / 2.0
        corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
        return corners * half
    a = np.linspace(0.0, 2.0 * math.pi, CIRCLE_SEGMENTS, endpoint=False)
    if cylinder is not None:
        r, h = float(cylinder.attrib["radius"]), float(cylinder.attrib["length"]) / 2.0
        ring = np.stack((r * np.cos(a), r * np.sin(a)), axis=1)
        return np.concatenate([np.c_[ring, np.full(len(a), z)] for z in (-h, h)])
    if sphere is not None:  # its outline from any side: the great circles about each axis
        r = float(sphere.attrib["radius"])
        ring = np.stack((r * np.cos(a), r * np.sin(a), np.zeros_like(a)), axis=1)
        return np.concatenate([np.roll(ring, k, axis=1) for k in range(3)])
    raise ValueError(f"unsupported collision geometry: {[child.tag for child in geometry]}")


@cache
def _collision_points(urdf: str, link_name: str | None = None) -> tuple[np.ndarray, ...]:
    """Each collision primitive of link ``link_name`` (default: the first, the base link) of ``urdf`` as points
    (m, link frame) spanning its hull."""
    root = ET.parse(asset_path(urdf)).getroot()
    links = [link for link in root.findall("link") if link_name is None or link.attrib.get("name") == link_name]
    if not links:
        raise ValueError(f"{urdf}: no link {link_name or ''}".rstrip())
    link = links[0]
    shapes = []
    for collision in link.findall("collision"):
        origin = collision.find("origin")
        xyz, rpy = np.array(_numbers(origin, "xyz")), _numbers(origin, "rpy")
        geometry = collision.find("geometry")
        if geometry is None:
            raise ValueError(f"{urdf}: a collision without geometry")
        shapes.append(_shape_points(geometry) @ _rpy_matrix(*rpy).T + xyz)
    if not shapes:
        raise ValueError(f"{urdf}: link {link.attrib.get('name')} has no collision geometry")
    return tuple(shapes)


def mav_silhouette(urdf: str = MAV_URDF, margin_m: float = 0.0, in_cradle: bool = True) -> np.ndarray:
    """The MAV's outline seen along its body x (nose first), ``(n, 2)`` metres in image axes about its centre of mass.

    u = -y (the MAV's right), v = -z (down). ``in_cradle``: with the launching apparatus's cradle (tray and
    boom) that holds it through the aperture; ``margin_m`` grows the outline by that much all round (e.g. a
    safety clearance). Counter-clockwise as shown (u right, v down).
    """
    parts = list(_collision_points(urdf))
    if in_cradle:
        parts += [p - MAV_IN_CRADLE for p in _collision_points(APPARATUS_URDF, "cradle")]
    polygons = [MultiPoint(np.c_[-p[:, 1], -p[:, 2]]).convex_hull for p in parts]
    outline = shapely.unary_union(polygons)
    if margin_m > 0:
        outline = outline.buffer(margin_m, quad_segs=4)
    if not isinstance(outline, Polygon):  # separate parts: the MAV cannot pass between them anyway
        outline = outline.convex_hull
    return np.asarray(outline.exterior.coords)[:-1]


def mav_contour(plane_depth: float, K: np.ndarray, urdf: str = MAV_URDF, margin_m: float = 0.0,
                in_cradle: bool = True) -> np.ndarray:
    """C_m: the MAV's outline (:func:`mav_silhouette`) in pixels of an image with intrinsics ``K`` at ``plane_depth``.

    The pinhole scale factor of §IV-B: ``u = f_x x / d``, ``v = f_y y / d`` for an outline fronto-parallel to the
    image at depth ``d`` = ``plane_depth`` (m). Returns ``(n, 2)`` px about the centre of mass (not shifted by the
    principal point).
    """
    if plane_depth <= 0:
        raise ValueError(f"plane depth must be positive, got {plane_depth} m")
    outline = mav_silhouette(urdf, margin_m, in_cradle)
    return outline * np.array([K[0, 0], K[1, 1]]) / plane_depth
