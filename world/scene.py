"""Scenes: static geometry loaded by name from ``world/scenes/<name>.yaml``.

A scene file lists a flat floor and labelled primitive objects (boxes,
cylinders, spheres) with colours, in the world frame (metres, yaw in
radians)::

    name: open_field
    description: flat, featureless field
    size: [80, 80]                  # extent x, y (m) for maps and plots
    floor: {rgb: [96, 118, 74], height: 0.0}
    objects:
      - {label: wall_n, shape: box, size: [30, 0.2, 2.5], position: [0, 10, 1.25],
         yaw: 0.0, rgb: [190, 190, 190], tags: [wall]}
      - {label: barrel, shape: cylinder, radius: 0.3, length: 0.9, position: [2, 3, 0.45]}

Every object is a static pybullet body with collision and visual shapes;
``label`` names it for contact queries and ``tags`` group it (walls,
door frames, debris, targets …). The floor is collision-only in headless
worlds — cameras draw it analytically (see ``sensors/camera.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pybullet
import yaml

from .errors import UnknownNameError, WorldError

if TYPE_CHECKING:
    from .world import World

SCENE_DIR = Path(__file__).resolve().parent / "scenes"
FLOOR_HALF_EXTENT = 200.0  # m: the floor is a 400 m square slab
FLOOR_THICKNESS = 0.1  # m


@dataclass(frozen=True)
class Floor:
    """The scene's flat floor: top surface height (m), colour and pybullet body."""

    height: float
    rgb: tuple[int, int, int]
    body_id: int
    analytic: bool  # True when cameras fill it in (no visual shape)


@dataclass(frozen=True)
class SceneObject:
    """One labelled static object of a scene."""

    label: str
    body_id: int
    shape: str
    position: tuple[float, float, float]
    tags: tuple[str, ...] = ()


@dataclass
class Scene:
    """A loaded scene: its floor, objects by label, extent (m) and description."""

    name: str
    description: str = ""
    size: tuple[float, float] = (80.0, 80.0)
    floor: Floor | None = None
    objects: dict[str, SceneObject] = field(default_factory=dict)

    def tagged(self, tag: str) -> list[SceneObject]:
        """Objects carrying ``tag`` (e.g. ``"wall"``, ``"door_frame"``)."""
        return [o for o in self.objects.values() if tag in o.tags]

    def object(self, label: str) -> SceneObject:
        """The object labelled ``label``; the error lists the labels of the scene."""
        try:
            return self.objects[label]
        except KeyError:
            raise UnknownNameError(f"object of scene {self.name}", label, self.objects) from None

    def label_of(self, body_id: int) -> str | None:
        """Label of the scene object with pybullet id ``body_id`` (``None`` if not a scene object)."""
        for obj in self.objects.values():
            if obj.body_id == body_id:
                return obj.label
        if self.floor is not None and body_id == self.floor.body_id:
            return "floor"
        return None


def known_scenes() -> list[str]:
    """Names of the scenes shipped under ``world/scenes/``."""
    return sorted(p.stem for p in SCENE_DIR.glob("*.yaml"))


def scene_file(name: str) -> Path:
    """Path of scene ``name``; :class:`UnknownNameError` lists the known scenes."""
    path = SCENE_DIR / f"{name}.yaml"
    if not path.is_file():
        raise UnknownNameError("scene", name, known_scenes())
    return path


def load_scene(world: World, name: str | None) -> Scene:
    """Build scene ``name`` in ``world`` (``None``: a grey floor only) and return it."""
    if name is None:
        spec: dict[str, Any] = {"name": "empty", "floor": {"rgb": [128, 128, 128]}}
        path = None
    else:
        path = scene_file(name)
        spec = yaml.safe_load(path.read_text()) or {}
    where = str(path) if path else "<empty scene>"
    scene = Scene(
        name=str(spec.get("name", name)),
        description=str(spec.get("description", "")),
        size=tuple(spec.get("size", (80.0, 80.0))),
    )
    gui = pybullet.getConnectionInfo(world.client_id)["connectionMethod"] == pybullet.GUI
    if "floor" in spec:
        scene.floor = _make_floor(world, spec["floor"], draw=gui)
    for i, obj in enumerate(spec.get("objects", []) or []):
        try:
            made = _make_object(world, obj)
        except (KeyError, TypeError, ValueError) as err:
            raise WorldError(f"{where}: objects[{i}] ({obj.get('label', '?') if isinstance(obj, dict) else obj}): {err}") from None
        if made.label in scene.objects:
            raise WorldError(f"{where}: objects[{i}]: duplicate label '{made.label}'")
        scene.objects[made.label] = made
    return scene


def _rgba(rgb: Any) -> list[float]:
    values = [float(c) for c in rgb]
    if len(values) not in (3, 4) or not all(0 <= c <= 255 for c in values):
        raise ValueError(f"rgb must be 3 or 4 values in 0..255, got {rgb}")
    rgba = [c / 255.0 for c in values[:3]] + [values[3] / 255.0 if len(values) == 4 else 1.0]
    return rgba


def _make_floor(world: World, spec: dict[str, Any], draw: bool) -> Floor:
    height = float(spec.get("height", 0.0))
    rgb = tuple(int(c) for c in spec.get("rgb", (128, 128, 128)))
    half = [FLOOR_HALF_EXTENT, FLOOR_HALF_EXTENT, FLOOR_THICKNESS / 2]
    cid = world.client_id
    collision = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, physicsClientId=cid)
    if draw:
        visual = pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=_rgba(rgb), physicsClientId=cid)
    else:  # a body without a visual shape gets its collision shape drawn: give it a speck instead
        visual = pybullet.createVisualShape(
            pybullet.GEOM_SPHERE, radius=1e-4, visualFramePosition=[0, 0, -1], physicsClientId=cid
        )
    body = pybullet.createMultiBody(
        0.0, collision, visual, [0.0, 0.0, height - FLOOR_THICKNESS / 2], physicsClientId=cid
    )
    pybullet.changeDynamics(body, -1, lateralFriction=1.0, physicsClientId=cid)
    return Floor(height=height, rgb=rgb, body_id=body, analytic=not draw)  # type: ignore[arg-type]


def _make_object(world: World, spec: dict[str, Any]) -> SceneObject:
    cid = world.client_id
    label = str(spec["label"])
    shape = str(spec.get("shape", "box"))
    rgba = _rgba(spec.get("rgb", (160, 160, 160)))
    if shape == "box":
        half = [float(s) / 2 for s in spec["size"]]
        if len(half) != 3:
            raise ValueError(f"size must be [x, y, z] in metres, got {spec['size']}")
        geometry: dict[str, Any] = {"shapeType": pybullet.GEOM_BOX, "halfExtents": half}
        visual_geometry = dict(geometry)
    elif shape == "cylinder":
        radius, length = float(spec["radius"]), float(spec["length"])
        geometry = {"shapeType": pybullet.GEOM_CYLINDER, "radius": radius, "height": length}
        visual_geometry = {"shapeType": pybullet.GEOM_CYLINDER, "radius": radius, "length": length}
    elif shape == "sphere":
        geometry = {"shapeType": pybullet.GEOM_SPHERE, "radius": float(spec["radius"])}
        visual_geometry = dict(geometry)
    else:
        raise ValueError(f"shape must be box, cylinder or sphere, got '{shape}'")
    position = [float(v) for v in spec["position"]]
    if len(position) != 3:
        raise ValueError(f"position must be [x, y, z] in metres, got {spec['position']}")
    yaw = float(spec.get("yaw", 0.0))
    orientation = [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]
    collision = pybullet.createCollisionShape(physicsClientId=cid, **geometry)
    visual = pybullet.createVisualShape(rgbaColor=rgba, physicsClientId=cid, **visual_geometry)
    body = pybullet.createMultiBody(0.0, collision, visual, position, orientation, physicsClientId=cid)
    tags = tuple(str(t) for t in spec.get("tags", ()))
    return SceneObject(label, body, shape, tuple(position), tags)  # type: ignore[arg-type]

