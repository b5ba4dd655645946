"""AprilTag bundles printed on robots: the layout a robot's designers wrote down, and its 3-D corners.

A bundle is described by a YAML layout shipped with the robot models (e.g.
``bebop2_tag_bundle.yaml``): a flat plate facing down (-z) under the robot's
base, and tags of the ``tag36h11`` family on it, positioned in the robot's
base frame (metres). :class:`TagBundle` gives each tag's id, size and 3-D
corners in the base frame, in the order ``cv2.aruco`` reports image corners
(top-left, top-right, bottom-right, bottom-left of the printed tag), ready
for ``cv2.solvePnP``. The world renders the plate's texture and mesh from the
same layout (:mod:`marsupial.world.apriltag_bundle`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
import yaml

from .assets import asset_path
from .errors import UnknownNameError, WorldError

#: the tag families a bundle may use, by the name of their ``cv2.aruco`` dictionary constant
ARUCO_DICTIONARIES = {"tag36h11": "DICT_APRILTAG_36h11"}


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

    @property
    def aruco_dictionary(self) -> str:
        """Name of the ``cv2.aruco`` dictionary constant of the bundle's family (``"DICT_APRILTAG_36h11"``).

        ``cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, bundle.aruco_dictionary))`` builds it.
        """
        return ARUCO_DICTIONARIES[self.family]


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
