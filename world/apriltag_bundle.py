"""AprilTag bundles printed on robots: layout, 3-D corners for pose estimation, and their assets.

A bundle is described by a YAML layout under ``world/assets/`` (e.g.
``bebop2_tag_bundle.yaml``): a flat plate facing down (-z) under the robot's
base, and tags of the ``tag36h11`` family on it, positioned in the robot's
base frame (metres). From one layout this module derives

- :class:`TagBundle`: each tag's id, size and 3-D corners in the base frame,
  in the order ``cv2.aruco`` reports image corners (top-left, top-right,
  bottom-right, bottom-left of the printed tag), ready for ``cv2.solvePnP``;
- the texture (PNG, real tag images from ``cv2.aruco.generateImageMarker``,
  white quiet zones) and a textured quad mesh (OBJ + MTL with UVs) that the
  robot's URDF shows on its ``link``.

Printed orientation: seen from below, with the image's up along base +x,
the image's right is base +y and every tag reads as printed (not mirrored).
Regenerate the assets after editing a layout::

    python -m marsupial.world.apriltag_bundle bebop2_tag_bundle.yaml
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from .assets import ASSET_DIR, asset_path
from .errors import UnknownNameError, WorldError

ARUCO_DICTIONARIES = {"tag36h11": cv2.aruco.DICT_APRILTAG_36h11}
TAG_CELLS = 8  # tag36h11: 6×6 data cells inside a one-cell black border


@dataclass(frozen=True)
class Tag:
    """One tag of a bundle.

    Attributes:
        id: tag id in the family.
        size: side of the black square (m).
        center: centre on the plate, base frame (m), shape (3,).
        corners: (4, 3) corners in the base frame, in cv2.aruco's order
            (top-left, top-right, bottom-right, bottom-left of the printed tag).
    """

    id: int
    size: float
    center: np.ndarray
    corners: np.ndarray


@dataclass(frozen=True)
class TagBundle:
    """A bundle layout: family, URDF link, asset names, plate extent and tags (base frame, m)."""

    family: str
    link: str
    texture: str
    mesh: str
    resolution: float  # m per texture pixel
    plate_x: tuple[float, float]
    plate_y: tuple[float, float]
    plate_z: float
    tags: tuple[Tag, ...]

    @property
    def ids(self) -> list[int]:
        """Ids of the bundle's tags."""
        return [t.id for t in self.tags]

    def tag(self, tag_id: int) -> Tag:
        """The tag with id ``tag_id``; the error lists the bundle's ids."""
        for t in self.tags:
            if t.id == tag_id:
                return t
        raise UnknownNameError("tag id", str(tag_id), [str(i) for i in self.ids])

    def object_points(self, ids: list[int] | np.ndarray) -> np.ndarray:
        """Stacked (4·n, 3) base-frame corners of the detected ``ids`` (in that order), for ``cv2.solvePnP``.

        Ids that are not part of the bundle (other robots' tags) are an error;
        filter detections with :attr:`ids` first.
        """
        return np.concatenate([self.tag(int(i)).corners for i in np.ravel(ids)], axis=0)

    def aruco_dictionary(self) -> cv2.aruco.Dictionary:
        """The ``cv2.aruco`` dictionary of the bundle's family (for ``cv2.aruco.ArucoDetector``)."""
        return cv2.aruco.getPredefinedDictionary(ARUCO_DICTIONARIES[self.family])


@cache
def load_tag_bundle(name: str = "bebop2_tag_bundle.yaml") -> TagBundle:
    """Read and check the bundle layout ``world/assets/<name>``.

    Raises :class:`WorldError` naming the file for an unknown family, a tag
    off the plate or without a one-cell quiet zone, or tag cells that do not
    fall on whole texture pixels.
    """
    path = asset_path(name)
    try:
        spec: dict[str, Any] = yaml.safe_load(path.read_text()) or {}
        family = str(spec["family"])
        if family not in ARUCO_DICTIONARIES:
            raise UnknownNameError("tag family", family, ARUCO_DICTIONARIES)
        plate = spec["plate"]
        x0, x1 = (float(v) for v in plate["x"])
        y0, y1 = (float(v) for v in plate["y"])
        z = float(plate["z"])
        res = float(spec["resolution"])
        tags = []
        for t in spec["tags"]:
            size = float(t["size"])
            cx, cy = (float(v) for v in t["center"])
            h, cell = size / 2, size / TAG_CELLS
            margin = h + cell - 1e-9
            if cx - margin < x0 or cx + margin > x1 or cy - margin < y0 or cy + margin > y1:
                raise ValueError(f"tag {t['id']} needs a one-cell ({cell:.4f} m) white margin inside the plate")
            if abs(cell / res - round(cell / res)) > 1e-6:
                raise ValueError(f"tag {t['id']}: cell {cell} m is not a whole number of {res} m pixels")
            corners = np.array(
                [[cx + h, cy - h, z], [cx + h, cy + h, z], [cx - h, cy + h, z], [cx - h, cy - h, z]]
            )  # TL, TR, BR, BL seen from below, image up = +x, image right = +y
            tags.append(Tag(int(t["id"]), size, np.array([cx, cy, z]), corners))
        if len({t.id for t in tags}) != len(tags):
            raise ValueError("tag ids must be unique")
        return TagBundle(
            family, str(spec["link"]), str(spec["texture"]), str(spec["mesh"]), res, (x0, x1), (y0, y1), z, tuple(tags)
        )
    except (KeyError, TypeError, ValueError, yaml.YAMLError) as err:
        raise WorldError(
            f"{path}: bad tag bundle layout ({err}); expected family, link, texture, mesh, resolution, "
            "plate {x, y, z} and tags [{id, size, center}]"
        ) from None


def render_texture(bundle: TagBundle) -> np.ndarray:
    """The plate's texture as a grayscale image: white plate, real tag images; row 0 at +x, column 0 at -y."""
    res = bundle.resolution
    rows = round((bundle.plate_x[1] - bundle.plate_x[0]) / res)
    cols = round((bundle.plate_y[1] - bundle.plate_y[0]) / res)
    image = np.full((rows, cols), 255, dtype=np.uint8)
    dictionary = bundle.aruco_dictionary()
    for t in bundle.tags:
        px = round(t.size / res)
        r0 = round((bundle.plate_x[1] - (t.center[0] + t.size / 2)) / res)
        c0 = round((t.center[1] - t.size / 2 - bundle.plate_y[0]) / res)
        image[r0 : r0 + px, c0 : c0 + px] = cv2.aruco.generateImageMarker(dictionary, t.id, px)
    return image


def quad_mesh(bundle: TagBundle, material_file: str) -> str:
    """OBJ text of the plate's quad facing -z, with UVs mapping the texture unmirrored as seen from below."""
    (x0, x1), (y0, y1), z = bundle.plate_x, bundle.plate_y, bundle.plate_z
    # texture up (v = 1) along +x, texture right (u = 1) along +y
    vertices = "".join(f"v {x:.4f} {y:.4f} {z:.4f}\n" for x, y in ((x0, y0), (x0, y1), (x1, y1), (x1, y0)))
    return (
        f"# AprilTag bundle plate of {bundle.texture}; generated by marsupial.world.apriltag_bundle\n"
        f"mtllib {material_file}\n"
        f"{vertices}"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
        "vn 0 0 -1\n"
        "usemtl tag_bundle\n"
        "f 1/1/1 2/2/1 3/3/1\n"
        "f 1/1/1 3/3/1 4/4/1\n"
    )


def write_assets(name: str, directory: Path = ASSET_DIR) -> list[Path]:
    """Write the texture PNG, quad OBJ and its MTL of layout ``name`` into ``directory``; returns the paths.

    Deterministic: the same layout always gives the same bytes.
    """
    bundle = load_tag_bundle(name)
    texture = directory / bundle.texture
    mesh = directory / bundle.mesh
    material = mesh.with_suffix(".mtl")
    if not cv2.imwrite(str(texture), render_texture(bundle), [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise WorldError(f"could not write {texture}")
    material.write_text(f"newmtl tag_bundle\nKa 1 1 1\nKd 1 1 1\nmap_Kd {bundle.texture}\n")
    mesh.write_text(quad_mesh(bundle, material.name))
    return [texture, mesh, material]


if __name__ == "__main__":
    for layout in sys.argv[1:] or ["bebop2_tag_bundle.yaml"]:
        for written in write_assets(layout):
            print(written)
