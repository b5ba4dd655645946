"""Render every shipped scene to ``docs/img/scene_<name>.png`` (oblique bird's-eye view).

Usage: ``python docs/render_scenes.py [scene ...]`` (default: all scenes).

Each scene is built in a headless world and drawn with pybullet's
TinyRenderer. Headless worlds give the floor no visual shape (cameras fill
it in analytically), so for the picture a visual-only floor slab in the
floor's colour is added (no shadows: TinyRenderer's shadow map
streaks large flat faces). The scene's zones are outlined (on the floor, or
in their wall plane for thin vertical zones such as apertures) and its
paths drawn as dashed lines, each labelled. A scene with small features
(apertures) gets a strip of face-on close-ups of those zones below the overview.
"""

from __future__ import annotations

import itertools
import sys
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pybullet

from marsupial.world import World
from marsupial.world.scene import Scene, Zone, known_scenes

OUT_DIR = Path(__file__).resolve().parent / "img"
FOV_V_DEG = 40.0
CLOSE_UP_DISTANCE = 0.7  # m
CLOSE_UP_SIZE = (234, 170)  # px


@dataclass(frozen=True)
class View:
    """A camera orbiting ``target`` (m, world) at ``distance`` (m).

    ``yaw``/``pitch`` in degrees (pybullet's GUI convention).
    """

    target: tuple[float, float, float]
    distance: float
    yaw: float
    pitch: float
    width: int = 960
    height: int = 640


@dataclass(frozen=True)
class Picture:
    """How to draw one scene: the overview, the zone tags to outline, close-ups shown in a strip below."""

    overview: View
    zone_tags: tuple[str, ...] = ()
    close_ups: tuple[str, ...] = ()  # zones seen face-on from -y in a strip below the overview
    close_up_zone_tags: tuple[str, ...] = ()
    object_tags: tuple[str, ...] = ()  # label the objects carrying these tags


PICTURES: dict[str, Picture] = {
    "usar_building": Picture(
        View((0.0, -0.5, 0.0), 44.0, 20.0, -58.0),
        ("hall", "corridor", "door_frame", "target_area"),
        object_tags=("target",),
    ),
    "open_field": Picture(View((0.0, 0.0, 0.0), 230.0, 30.0, -50.0), ("field",)),
    "marsupial_yard": Picture(View((0.0, 0.0, 0.0), 23.0, 30.0, -55.0), ("arena", "mother_home")),
    "collapsed_mockup": Picture(
        View((0.0, 1.2, 0.0), 21.0, 20.0, -64.0),
        ("corridor", "hallway", "door_frame", "approach"),
        ("aperture_orthogonal", "aperture_collapsed", "aperture_amoeba", "aperture_u"),
        ("aperture", "aperture_clear"),
        ("object_of_interest",),
    ),
}
ZONE_BGR = {  # outline colour (OpenCV BGR) of the first matching tag
    "corridor": (0, 200, 255),
    "door_frame": (255, 80, 200),
    "target_area": (0, 230, 255),
    "aperture": (255, 255, 0),
    "aperture_clear": (255, 255, 255),
}
DEFAULT_BGR = (235, 235, 235)
PATH_BGR = (255, 120, 30)


def _matrices(view: View) -> tuple[np.ndarray, np.ndarray]:
    """4×4 view and projection matrices (row-major numpy) of ``view``."""
    V = pybullet.computeViewMatrixFromYawPitchRoll(list(view.target), view.distance, view.yaw, view.pitch, 0.0, 2)
    P = pybullet.computeProjectionMatrixFOV(FOV_V_DEG, view.width / view.height, 0.05, 6.0 * view.distance)
    return np.asarray(V).reshape(4, 4).T, np.asarray(P).reshape(4, 4).T


def _shoot(world: World, view: View) -> tuple[np.ndarray, np.ndarray]:
    """BGR image of ``view`` and its world->clip matrix."""
    V, P = _matrices(view)
    _, _, rgba, _, _ = pybullet.getCameraImage(
        view.width,
        view.height,
        V.T.flatten().tolist(),
        P.T.flatten().tolist(),
        renderer=pybullet.ER_TINY_RENDERER,
        lightDirection=[-0.5, -0.8, 1.5],
        lightAmbientCoeff=0.7,
        lightDiffuseCoeff=0.45,
        lightSpecularCoeff=0.05,
        flags=pybullet.ER_NO_SEGMENTATION_MASK,
        physicsClientId=world.client_id,
    )
    rgb = np.asarray(rgba, dtype=np.uint8).reshape(view.height, view.width, 4)[..., :3]
    return cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), P @ V


def _project(points: np.ndarray, clip_from_world: np.ndarray, image: np.ndarray) -> np.ndarray:
    """Pixel coordinates ``(N, 2)`` in ``image`` of world points ``(N, 3)``."""
    clip = (clip_from_world @ np.c_[points, np.ones(len(points))].T).T
    ndc = clip[:, :2] / clip[:, 3:4]
    h, w = image.shape[:2]
    return np.c_[(ndc[:, 0] + 1) / 2 * w, (1 - ndc[:, 1]) / 2 * h]


def _add_floor_visual(world: World) -> None:
    """A visual-only slab in the floor's colour under the whole view (for the picture only)."""
    floor = world.scene.floor
    half = 3.0 * max(world.scene.size)
    rgba = [c / 255.0 for c in floor.rgb] + [1.0]
    visual = pybullet.createVisualShape(
        pybullet.GEOM_BOX, halfExtents=[half, half, 0.01], rgbaColor=rgba, physicsClientId=world.client_id
    )
    pybullet.createMultiBody(0.0, -1, visual, [0, 0, floor.height - 0.01], physicsClientId=world.client_id)


def _zone_outline(zone: Zone, z_floor: float) -> np.ndarray:
    """Corners (4, 3) outlining a zone: its wall-plane face if it is thin and vertical, else its floor footprint."""
    lo, hi, size = np.asarray(zone.lo), np.asarray(zone.hi), zone.size
    thin = int(np.argmin(size[:2]))
    if size[thin] < 0.3 and size[2] < 2.0:  # an opening in a wall: outline it in the wall plane
        along = 1 - thin
        corners = []
        for u, w in ((lo[along], lo[2]), (hi[along], lo[2]), (hi[along], hi[2]), (lo[along], hi[2])):
            p = zone.center.copy()
            p[along], p[2] = u, w
            corners.append(p)
        return np.asarray(corners)
    return np.array(
        [(lo[0], lo[1], z_floor), (hi[0], lo[1], z_floor), (hi[0], hi[1], z_floor), (lo[0], hi[1], z_floor)]
    )


def _annotate(
    image: np.ndarray, scene: Scene, clip_from_world: np.ndarray, zone_tags: tuple[str, ...], labels: bool = True
) -> None:
    """Outline the zones carrying one of ``zone_tags`` and draw the paths (labelled unless ``labels`` is False)."""
    z_floor = (scene.floor.height if scene.floor else 0.0) + 0.03
    for zone in scene.zones.values():
        if not any(t in zone.tags for t in zone_tags):
            continue
        colour = next((c for t, c in ZONE_BGR.items() if t in zone.tags), DEFAULT_BGR)
        px = _project(_zone_outline(zone, z_floor), clip_from_world, image)
        cv2.polylines(image, [np.round(px).astype(np.int32)], True, colour, 2 if labels else 1, cv2.LINE_AA)
        if labels:
            top = px[np.argmin(px[:, 1])]
            _label(image, zone.label, top + np.array([4.0, -6.0]), colour)
    for name, points in scene.paths.items():
        dense = _densify(points, 0.25)
        px = np.round(_project(np.c_[dense, np.full(len(dense), z_floor)], clip_from_world, image)).astype(int)
        for k in range(0, len(px) - 1, 2):  # dashed
            cv2.line(image, tuple(px[k]), tuple(px[k + 1]), PATH_BGR, 3, cv2.LINE_AA)
        _label(image, name, px[0] + np.array([6.0, 16.0]), PATH_BGR)


def _densify(points: np.ndarray, step: float) -> np.ndarray:
    """Points every ``step`` metres along the polyline ``points`` (N, 2)."""
    out = [points[0]]
    for a, b in itertools.pairwise(points):
        n = max(1, int(np.linalg.norm(b - a) / step))
        out.extend(a + (b - a) * (k / n) for k in range(1, n + 1))
    return np.asarray(out)


def _label(image: np.ndarray, text: str, anchor: np.ndarray, colour: tuple, scale: float = 0.42) -> None:
    """Write ``text`` in ``colour`` on a dark box whose lower-left corner is ``anchor`` (px)."""
    (w, h), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    x, y = int(anchor[0]), int(anchor[1])
    cv2.rectangle(image, (x - 2, y - h - 3), (x + w + 2, y + base), (30, 30, 30), -1)
    cv2.putText(image, text, (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def render(name: str) -> Path:
    """Render scene ``name`` to ``docs/img/scene_<name>.png`` and return the file path."""
    picture = PICTURES.get(name, Picture(View((0.0, 0.0, 0.0), 20.0, 30.0, -50.0)))
    with World(name) as world:
        _add_floor_visual(world)
        image, clip_from_world = _shoot(world, picture.overview)
        _annotate(image, world.scene, clip_from_world, picture.zone_tags)
        for obj in (o for tag in picture.object_tags for o in world.scene.tagged(tag)):
            px = _project(np.array([obj.position]), clip_from_world, image)[0]
            cv2.circle(image, tuple(np.round(px).astype(int)), 14, (0, 255, 255), 2, cv2.LINE_AA)
            _label(image, obj.label, px + np.array([16.0, -10.0]), (0, 255, 255))
        if picture.close_ups:
            w, h = CLOSE_UP_SIZE
            strip = np.full((h + 8, image.shape[1], 3), 30, np.uint8)
            for k, label in enumerate(picture.close_ups):
                view = View(tuple(world.scene.zone(label).center), CLOSE_UP_DISTANCE, 0.0, 0.0, w, h)
                close_up, close_up_clip = _shoot(world, view)
                _annotate(close_up, world.scene, close_up_clip, picture.close_up_zone_tags, labels=False)
                _label(close_up, label, np.array([6.0, 18.0]), (255, 255, 255))
                x = 4 + k * (w + 6)
                strip[4 : 4 + h, x : x + w] = close_up
            image = np.vstack([image, strip])
        _label(image, f"{name}: {world.scene.description}", np.array([10.0, 22.0]), (255, 255, 255), 0.5)
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    path = OUT_DIR / f"scene_{name}.png"
    cv2.imwrite(str(path), image, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return path


if __name__ == "__main__":
    for scene_name in sys.argv[1:] or known_scenes():
        out = render(scene_name)
        print(f"{out} ({out.stat().st_size // 1024} kB)")
