"""Objects of interest in the relayed frames: the detector interface and a colour-and-shape default.

Arora & Papachristos, §IV-G and §V: the carrier "leverage[s] the relayed
imagery to conduct automated detection of objects of interest" ([41], a
learned detector and classifier), which "can be used to terminate each
sequence as we have placed a fire extinguisher and a chair on either corridor
side". An :class:`ObjectDetector` finds objects of one class in a decoded RGB
frame; the scout ends its run on the first confirmed one.

Default, :class:`HsvColourDetector`: the two objects of the mockup are
painted in saturated colours nothing else in the scene has (the extinguisher
red, the chair blue), so colour segmentation in HSV plus size and shape
checks of each blob stands in for the learned detector:

1. RGB → HSV (OpenCV: H 0–179, S and V 0–255), pixels within the class's hue
   interval(s) and above its saturation and value floors;
2. a 3×3 morphological opening (drops the JPEG's isolated chroma speckle);
3. connected components; a blob counts when its area is at least
   ``min_area_px`` (the object is near enough to be worth reporting), its box
   aspect (height / width) lies in the class's interval (the extinguisher
   stands tall, the chair's back and seat are about square) and its fill
   (area / box area) reaches the class's floor.

Pixel boxes ``(u_min, v_min, u_max, v_max)`` inclusive, u right, v down.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import cv2
import numpy as np
from pydantic import Field

from .plugins import Plugin, PluginOptions


@dataclass(frozen=True)
class Detection:
    """One object found in a frame: its class, pixel box, blob area (px) and score in [0, 1] (the box's fill)."""

    object_class: str
    box: tuple[int, int, int, int]
    area_px: int
    score: float


class ObjectDetector(Plugin):
    """Base of object detectors: :meth:`detect` objects of one class in a frame; :attr:`classes` it knows."""

    kind: ClassVar[str] = "object detector"
    classes: ClassVar[tuple[str, ...]] = ()

    def __init__(self, options: PluginOptions):
        self.options = options

    def detect(self, rgb: np.ndarray, object_class: str) -> list[Detection]:
        """Objects of ``object_class`` in ``rgb`` ``(h, w, 3)`` uint8, largest first."""
        raise NotImplementedError(f"{type(self).__name__} must implement detect()")


@dataclass(frozen=True)
class ColourClass:
    """The colour and shape of one class: OpenCV hue intervals, S and V floors, aspect interval, fill floor."""

    hues: tuple[tuple[int, int], ...]
    min_saturation: int
    min_value: int
    aspect: tuple[float, float]
    min_fill: float


#: the mockup's objects of interest (collapsed_mockup.yaml): extinguisher RGB (200, 24, 24), a 0.16 × 0.5 m
#: cylinder (aspect ≈ 3 seen from the side); chair RGB (40, 62, 120), back 0.45 × 0.45 m over a 0.45 m seat
COLOUR_CLASSES: dict[str, ColourClass] = {
    "fire_extinguisher": ColourClass(((0, 6), (174, 179)), 170, 60, (1.5, 6.0), 0.5),
    "chair": ColourClass(((100, 125),), 110, 40, (0.4, 2.5), 0.3),
}


class HsvColourDetector(ObjectDetector):
    """Colour segmentation in HSV with size and shape checks (module docstring), classes of :data:`COLOUR_CLASSES`."""

    class Options(PluginOptions):
        min_area_px: int = Field(900, ge=1)
        """Smallest blob (pixels of the frame) reported: 900 px of the Tello's 320×240 frame is the
        extinguisher at ≈2.2 m, the chair at ≈2.6 m (measured on relayed frames)."""

    classes: ClassVar[tuple[str, ...]] = tuple(COLOUR_CLASSES)
    options: HsvColourDetector.Options

    def detect(self, rgb: np.ndarray, object_class: str) -> list[Detection]:
        """Blobs of the class's colour that pass the size and shape checks, largest first."""
        spec = COLOUR_CLASSES.get(object_class)
        if spec is None:
            raise ValueError(f"the HSV colour detector knows no '{object_class}'; expected one of "
                             f"{', '.join(self.classes)}")
        hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
        mask: np.ndarray = np.zeros(rgb.shape[:2], np.uint8)
        for low, high in spec.hues:
            mask = cv2.bitwise_or(mask, cv2.inRange(hsv, (low, spec.min_saturation, spec.min_value), (high, 255, 255)))
        opened = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
        count, _, stats, _ = cv2.connectedComponentsWithStats(opened)
        found = []
        for x, y, w, h, area in stats[1:count]:
            fill = area / float(w * h)
            if area >= self.options.min_area_px and spec.aspect[0] <= h / w <= spec.aspect[1] and fill >= spec.min_fill:
                found.append(Detection(object_class, (int(x), int(y), int(x + w - 1), int(y + h - 1)), int(area),
                                       round(float(fill), 3)))
        return sorted(found, key=lambda d: -d.area_px)
