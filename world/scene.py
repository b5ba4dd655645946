"""Scenes: static geometry loaded by name from ``world/scenes/<name>.yaml``.

A scene file lists a flat floor, labelled primitive objects (boxes,
cylinders, spheres), labelled zones and named ground paths, all in the
world frame (metres, radians)::

    name: open_field                # must match the file name
    description: flat, featureless field
    size: [120, 120]                # extent x, y (m) for maps and plots
    floor: {rgb: [96, 118, 74], height: 0.0}
    objects:
      - {label: wall_n, shape: box, size: [30, 0.2, 2.5], position: [0, 10, 1.25],
         yaw: 0.0, rgb: [190, 190, 190], tags: [wall]}
      - {label: barrel, shape: cylinder, radius: 0.3, length: 0.9, position: [2, 3, 0.45]}
      - {label: slab, size: [2, 1, 0.1], position: [4, 0, 0.4], rpy: [0.0, 0.3, 1.2]}
    zones:
      - {label: corridor, position: [0, 0, 1.4], size: [13, 2.4, 2.8], tags: [corridor]}
    paths:
      operator_path: [[-13, -7], [-5.5, 0], [7.5, 0]]

Objects: ``shape`` is ``box`` (``size: [x, y, z]``), ``cylinder``
(``radius``, ``length`` along its z axis) or ``sphere`` (``radius``);
``position`` is the centre; the orientation is ``yaw`` about world z, or
``rpy: [roll, pitch, yaw]`` (pybullet's convention, R = Rz(yaw)·Ry(pitch)·Rx(roll));
``rgb`` is 0-255; ``tags`` group objects (wall, door_frame, debris,
target …). Every object is a static pybullet body with collision and
visual shapes; ``label`` names it for contact queries.

Zones are labelled axis-aligned boxes (``position`` = centre, ``size``)
with no body at all: regions that conditions and tests ask about
(``scene.zones_at(p)`` — is the carrier in a corridor, near a door frame?)
and the recorded geometry of features (an aperture's centre and size).

Paths are named polylines of ``[x, y]`` ground points (m), e.g. the
operator's guide path through a building.

The floor is collision-only in headless worlds — cameras draw it
analytically (see ``sensors/camera.py``); the GUI draws it.

A malformed file raises :class:`WorldError` naming the file, the entry
(``objects[3] 'door_2'``), the key and what was expected.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet
import shapely
import yaml

from marsupial.api.errors import UnknownNameError, WorldError

if TYPE_CHECKING:
    from .world import World

SCENE_DIR = Path(__file__).resolve().parent / "scenes"
FLOOR_HALF_EXTENT = 200.0  # m: the floor is a 400 m square slab
FLOOR_THICKNESS = 0.1  # m
PRISM_MARGIN_M = 1e-4
"""Collision margin (m) of a prism's convex hull (:meth:`Scene.add_prism`): measured, pybullet's rays miss at 0."""

SHAPES = ("box", "cylinder", "sphere")
SCENE_KEYS = ("name", "description", "size", "floor", "objects", "zones", "paths")
FLOOR_KEYS = ("rgb", "height")
OBJECT_KEYS = ("label", "shape", "size", "radius", "length", "position", "yaw", "rpy", "rgb", "tags")
ZONE_KEYS = ("label", "position", "size", "tags")
_YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml parses ~5x faster


@dataclass(frozen=True)
class Floor:
    """The scene's flat floor: top surface height (m), colour and pybullet body."""

    height: float
    rgb: tuple[int, int, int]
    body_id: int
    analytic: bool  # True when cameras fill it in (no visual shape)


@dataclass(frozen=True)
class SceneObject:
    """One labelled static object of a scene.

    ``position`` is its centre (m, world frame), ``orientation`` its
    ``[x, y, z, w]`` quaternion, ``size`` its extent along its own axes (m:
    a box's size, ``(2r, 2r, length)`` for a cylinder, ``(2r, 2r, 2r)`` for
    a sphere), ``rgb`` its colour (0-255).
    """

    label: str
    body_id: int
    shape: str
    position: tuple[float, float, float]
    tags: tuple[str, ...] = ()
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rgb: tuple[int, int, int] = (160, 160, 160)


@dataclass(frozen=True)
class Zone:
    """A labelled axis-aligned box of the world frame with no body (m).

    ``lo``/``hi`` are its min/max corners; 2-D queries use x and y only.
    """

    label: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    tags: tuple[str, ...] = ()

    @property
    def center(self) -> np.ndarray:
        """Centre of the box (m, world frame)."""
        return (np.asarray(self.lo) + np.asarray(self.hi)) / 2.0

    @property
    def size(self) -> np.ndarray:
        """Extent along x, y, z (m)."""
        return np.asarray(self.hi) - np.asarray(self.lo)

    def distance(self, point: Sequence[float]) -> float:
        """Euclidean distance (m) from ``point`` (``[x, y]`` or ``[x, y, z]``) to the box; 0 inside."""
        p = np.asarray(point, dtype=float)
        n = len(p)
        lo, hi = np.asarray(self.lo[:n]), np.asarray(self.hi[:n])
        return float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - p, p - hi))))

    def contains(self, point: Sequence[float], margin: float = 0.0) -> bool:
        """True if ``point`` is inside the box grown by ``margin`` metres (a distance, not per axis)."""
        return self.distance(point) <= margin


@dataclass
class Scene:
    """A loaded scene: floor, objects and zones by label, paths by name, extent (m)."""

    name: str
    description: str = ""
    size: tuple[float, float] = (80.0, 80.0)
    floor: Floor | None = None
    objects: dict[str, SceneObject] = field(default_factory=dict)
    zones: dict[str, Zone] = field(default_factory=dict)
    paths: dict[str, np.ndarray] = field(default_factory=dict)
    client_id: int = -1

    # ------------------------------------------------------------ objects
    def tagged(self, tag: str) -> list[SceneObject]:
        """Objects carrying ``tag`` (e.g. ``"wall"``, ``"door_frame"``), in file order."""
        return [o for o in self.objects.values() if tag in o.tags]

    def object(self, label: str) -> SceneObject:
        """The object labelled ``label``; the error lists the labels of the scene."""
        try:
            return self.objects[label]
        except KeyError:
            raise UnknownNameError(f"{self.name} object", label, self.objects) from None

    def labels(self, tag: str | None = None) -> list[str]:
        """Labels of the objects (those carrying ``tag`` if given), in file order."""
        return [o.label for o in self.objects.values() if tag is None or tag in o.tags]

    def tags(self) -> set[str]:
        """Every tag used by an object or a zone of the scene."""
        return {t for o in self.objects.values() for t in o.tags} | {t for z in self.zones.values() for t in z.tags}

    def label_of(self, body_id: int) -> str | None:
        """Label of the scene object with pybullet id ``body_id`` (``"floor"``; ``None`` if not in the scene)."""
        for obj in self.objects.values():
            if obj.body_id == body_id:
                return obj.label
        if self.floor is not None and body_id == self.floor.body_id:
            return "floor"
        return None

    def aabb(self, tag: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """World-frame bounding box ``(lo, hi)`` (m) of the objects (carrying ``tag`` if given).

        Raises :class:`WorldError` when no object matches.
        """
        boxes = [
            pybullet.getAABB(o.body_id, physicsClientId=self.client_id)
            for o in self.objects.values()
            if tag is None or tag in o.tags
        ]
        if not boxes:
            raise WorldError(f"scene {self.name} has no object{f' tagged {tag!r}' if tag else ''}")
        lo = np.min([b[0] for b in boxes], axis=0)
        hi = np.max([b[1] for b in boxes], axis=0)
        return lo, hi

    # -------------------------------------------------------------- zones
    def zone(self, label: str) -> Zone:
        """The zone labelled ``label``; the error lists the zones of the scene."""
        try:
            return self.zones[label]
        except KeyError:
            raise UnknownNameError(f"{self.name} zone", label, self.zones) from None

    def zones_tagged(self, tag: str) -> list[Zone]:
        """Zones carrying ``tag`` (e.g. ``"corridor"``, ``"aperture"``), in file order."""
        return [z for z in self.zones.values() if tag in z.tags]

    def zones_at(self, point: Sequence[float], margin: float = 0.0, tag: str | None = None) -> list[Zone]:
        """Zones containing ``point`` (``[x, y]``: plan view, or ``[x, y, z]``), grown by ``margin`` m.

        ``tag`` keeps only the zones carrying it, e.g.
        ``scene.zones_at(p_carrier[:2], margin=1.5, tag="door_frame")``.
        """
        return [
            z for z in self.zones.values() if (tag is None or tag in z.tags) and z.contains(point, margin)
        ]

    # ------------------------------------------------------------- editing
    def add_box(
        self, label: str, size: Sequence[float], position: Sequence[float], rgb: Sequence[int] = (160, 160, 160),
        tags: Sequence[str] = (),
    ) -> SceneObject:
        """Add a static axis-aligned box (``size`` and centre ``position`` in m, world frame) labelled ``label``.

        For scene changes made after loading (e.g. :mod:`.decoys`); :class:`WorldError` for a label in use.
        """
        if label in self.objects:
            raise WorldError(f"scene {self.name} already has an object labelled '{label}'")
        size3 = tuple(float(v) for v in size)
        geometry = {"shapeType": pybullet.GEOM_BOX, "halfExtents": [v / 2 for v in size3]}
        rgb_ = tuple(int(v) for v in rgb)
        orientation = (0.0, 0.0, 0.0, 1.0)
        centre = tuple(float(v) for v in position)
        body = _static_body(self.client_id, geometry, geometry, rgb_, centre, orientation)
        made = SceneObject(label, body, "box", centre, tuple(tags), orientation, size3, rgb_[:3])  # type: ignore[arg-type]
        self.objects[label] = made
        return made

    def add_prism(
        self, label: str, outline: Sequence[Sequence[float]] | np.ndarray, y_range: tuple[float, float],
        rgb: Sequence[int] = (160, 160, 160), tags: Sequence[str] = (),
    ) -> SceneObject:
        """Add a static prism labelled ``label``: the convex polygon ``outline`` (``(n, 2)`` world ``(x, z)``, m)
        extruded along y over ``y_range`` (m), e.g. a piece of a wall around an opening (:mod:`.aperture_fit`).

        Its collision shape is the convex hull (pybullet convex mesh) with a collision margin of
        :data:`PRISM_MARGIN_M` instead of pybullet's 1 mm: contacts and rays meet it that much before its faces
        (at 0 pybullet's ray tests miss a convex hull altogether); ``size`` and ``position`` are its bounding box.
        :class:`WorldError` for a label in use or an outline that is not a convex polygon of positive area.
        """
        if label in self.objects:
            raise WorldError(f"scene {self.name} already has an object labelled '{label}'")
        ring = np.asarray(outline, dtype=float).reshape(-1, 2)
        hull = shapely.Polygon(ring).convex_hull
        if not isinstance(hull, shapely.Polygon) or hull.area <= 0 or len(ring) != len(hull.exterior.coords) - 1:
            raise WorldError(f"prism '{label}': the outline must be a convex polygon of positive area, got {ring}")
        y0, y1 = (float(v) for v in y_range)
        lo, hi = np.r_[ring.min(axis=0), y0], np.r_[ring.max(axis=0), y1]  # (x, z, y)
        centre = (float(lo[0] + hi[0]) / 2, (y0 + y1) / 2, float(lo[1] + hi[1]) / 2)
        vertices = np.array([(x - centre[0], y - centre[1], z - centre[2]) for y in (y0, y1) for x, z in ring])
        n = len(ring)
        faces = [(0, i, i + 1) for i in range(1, n - 1)] + [(n, n + i + 1, n + i) for i in range(1, n - 1)]
        faces += [q for i in range(n) for q in ((i, (i + 1) % n, n + i), ((i + 1) % n, n + (i + 1) % n, n + i))]
        inside = vertices.mean(axis=0)  # inside the convex prism (its bounding box's centre may lie on a face)
        corners = vertices[[v for face in faces for v in _outward(vertices, face, inside)]]  # 3 per face, flat shaded
        a, b, c = corners[0::3], corners[1::3], corners[2::3]
        normals = np.cross(b - a, c - a)
        normals = np.repeat(normals / np.linalg.norm(normals, axis=1, keepdims=True), 3, axis=0)
        visual = {"shapeType": pybullet.GEOM_MESH, "vertices": corners.tolist(), "indices": list(range(len(corners))),
                  "normals": normals.tolist()}
        rgb_ = tuple(int(v) for v in rgb)
        body = _static_body(self.client_id, {"shapeType": pybullet.GEOM_MESH, "vertices": vertices.tolist()}, visual,
                            rgb_, centre, (0.0, 0.0, 0.0, 1.0))
        pybullet.changeDynamics(body, -1, collisionMargin=PRISM_MARGIN_M, physicsClientId=self.client_id)
        size = (float(hi[0] - lo[0]), y1 - y0, float(hi[1] - lo[1]))
        made = SceneObject(label, body, "prism", centre, tuple(tags), (0.0, 0.0, 0.0, 1.0), size, rgb_[:3])  # type: ignore[arg-type]
        self.objects[label] = made
        return made

    def remove(self, label: str) -> SceneObject:
        """Remove object ``label`` from the scene and its body from the world; returns it."""
        obj = self.object(label)
        pybullet.removeBody(obj.body_id, physicsClientId=self.client_id)
        del self.objects[label]
        return obj

    def add_zone(self, zone: Zone) -> None:
        """Add ``zone``; :class:`WorldError` for a label in use."""
        if zone.label in self.zones:
            raise WorldError(f"scene {self.name} already has a zone labelled '{zone.label}'")
        self.zones[zone.label] = zone

    def remove_zone(self, label: str) -> Zone:
        """Remove zone ``label`` (the error lists the zones); returns it."""
        zone = self.zone(label)
        del self.zones[label]
        return zone

    # -------------------------------------------------------------- paths
    def path(self, name: str) -> np.ndarray:
        """Waypoints ``(N, 2)`` (m, world x/y) of the path ``name``; the error lists the paths."""
        try:
            return self.paths[name].copy()
        except KeyError:
            raise UnknownNameError(f"{self.name} path", name, self.paths) from None


def known_scenes() -> list[str]:
    """Names of the scenes shipped under ``world/scenes/``."""
    return sorted(p.stem for p in SCENE_DIR.glob("*.yaml"))


def scene_file(name: str) -> Path:
    """Path of scene ``name``; :class:`UnknownNameError` lists the known scenes."""
    path = SCENE_DIR / f"{name}.yaml"
    if not path.is_file():
        raise UnknownNameError("scene", name, known_scenes())
    return path


def read_scene_spec(path: Path) -> dict[str, Any]:
    """Parse a scene file into a mapping; :class:`WorldError` names the file if it is not one."""
    try:
        spec = yaml.load(path.read_text(), Loader=_YAML_LOADER)
    except yaml.YAMLError as err:
        raise WorldError(f"{path}: not valid YAML: {err}") from None
    if spec is None:
        spec = {}
    if not isinstance(spec, dict):
        raise WorldError(
            f"{path}: a scene file is a mapping with keys {', '.join(SCENE_KEYS)}; got {type(spec).__name__}"
        )
    return spec


def load_scene(world: World, name: str | None) -> Scene:
    """Build scene ``name`` in ``world`` (``None``: a grey floor only) and return it.

    Raises :class:`UnknownNameError` for an unknown name and
    :class:`WorldError` naming the file, the entry and the key for a malformed file.
    """
    if name is None:
        spec: dict[str, Any] = {"name": "empty", "floor": {"rgb": [128, 128, 128]}}
        where = "<empty scene>"
    else:
        path = scene_file(name)
        spec = read_scene_spec(path)
        where = str(path)
    try:
        return _build(world, spec, name or "empty")
    except _SpecError as err:
        raise WorldError(f"{where}: {err}") from None


# --------------------------------------------------------------------------- building


class _SpecError(Exception):
    """A malformed entry; :func:`load_scene` prefixes the file name."""


_REQUIRED = object()


class _Fields:
    """Typed reads of one YAML mapping; errors name the entry, the key and what was expected."""

    def __init__(self, spec: Any, entry: str, allowed: Sequence[str]):
        if not isinstance(spec, dict):
            raise _SpecError(f"{entry}: expected a mapping with keys {', '.join(allowed)}; got {spec!r}")
        unknown = sorted(set(map(str, spec)) - set(allowed))
        if unknown:
            raise _SpecError(f"{entry}: unknown key(s) {', '.join(unknown)}; allowed keys: {', '.join(allowed)}")
        self.spec = spec
        self.entry = entry

    def _get(self, key: str, default: Any, expected: str) -> Any:
        if key in self.spec:
            return self.spec[key]
        if default is _REQUIRED:
            raise _SpecError(f"{self.entry}: missing key '{key}' ({expected})")
        return default

    def _fail(self, key: str, expected: str) -> _SpecError:
        return _SpecError(f"{self.entry}: '{key}' must be {expected}; got {self.spec[key]!r}")

    def text(self, key: str, default: Any = _REQUIRED) -> str:
        value = self._get(key, default, "a string")
        if not isinstance(value, (str, int)) or isinstance(value, bool):
            raise self._fail(key, "a string")
        return str(value)

    def number(self, key: str, default: Any = _REQUIRED, expected: str = "a number", positive: bool = False) -> float:
        value = self._get(key, default, expected)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (positive and value <= 0):
            raise self._fail(key, expected)
        return float(value)

    def vector(
        self, key: str, n: int, default: Any = _REQUIRED, expected: str = "", positive: bool = False
    ) -> tuple[float, ...]:
        expected = expected or f"a list of {n} numbers"
        value = self._get(key, default, expected)
        ok = isinstance(value, (list, tuple)) and len(value) == n and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and (not positive or v > 0) for v in value
        )
        if not ok:
            raise self._fail(key, expected)
        return tuple(float(v) for v in value)

    def rgb(self, default: Any) -> tuple[int, ...]:
        value = self._get("rgb", default, "")
        ok = isinstance(value, (list, tuple)) and len(value) in (3, 4) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v <= 255 for v in value
        )
        if not ok:
            raise self._fail("rgb", "3 or 4 values in 0..255")
        return tuple(int(v) for v in value)

    def tags(self) -> tuple[str, ...]:
        value = self._get("tags", [], "")
        if not isinstance(value, (list, tuple)) or not all(isinstance(t, str) for t in value):
            raise self._fail("tags", "a list of strings")
        return tuple(value)


def _build(world: World, spec: dict[str, Any], default_name: str) -> Scene:
    top = _Fields(spec, "scene", SCENE_KEYS)
    name = top.text("name", default_name)
    if name != default_name:
        raise _SpecError(f"'name' is {name!r} but the file is {default_name}.yaml; they must match")
    size = top.vector("size", 2, (80.0, 80.0), "[x, y] extent in metres (> 0)", positive=True)
    scene = Scene(name=name, description=top.text("description", ""), size=size, client_id=world.client_id)  # type: ignore[arg-type]
    if "floor" in spec:
        gui = pybullet.getConnectionInfo(world.client_id)["connectionMethod"] == pybullet.GUI
        scene.floor = _make_floor(world, _Fields(spec["floor"], "floor", FLOOR_KEYS), draw=gui)
    for i, entry in enumerate(_entries(spec, "objects")):
        made = _make_object(world, _Fields(entry, _entry_name("objects", i, entry), OBJECT_KEYS))
        if made.label in scene.objects:
            raise _SpecError(f"{_entry_name('objects', i, entry)}: duplicate label '{made.label}'")
        scene.objects[made.label] = made
    for i, entry in enumerate(_entries(spec, "zones")):
        zone = _make_zone(_Fields(entry, _entry_name("zones", i, entry), ZONE_KEYS))
        if zone.label in scene.zones:
            raise _SpecError(f"{_entry_name('zones', i, entry)}: duplicate label '{zone.label}'")
        scene.zones[zone.label] = zone
    scene.paths = _read_paths(spec.get("paths") or {})
    return scene


def _entries(spec: dict[str, Any], key: str) -> list[Any]:
    entries = spec.get(key) or []
    if not isinstance(entries, list):
        raise _SpecError(f"'{key}' must be a list of mappings; got {type(entries).__name__}")
    return entries


def _entry_name(section: str, index: int, entry: Any) -> str:
    label = entry.get("label") if isinstance(entry, dict) else None
    return f"{section}[{index}]" + (f" '{label}'" if label is not None else "")


def _rgba(rgb: Sequence[int]) -> list[float]:
    return [c / 255.0 for c in rgb[:3]] + [rgb[3] / 255.0 if len(rgb) == 4 else 1.0]


def _make_floor(world: World, spec: _Fields, draw: bool) -> Floor:
    height = spec.number("height", 0.0, "the floor's top height in metres")
    rgb = spec.rgb((128, 128, 128))[:3]
    half = [FLOOR_HALF_EXTENT, FLOOR_HALF_EXTENT, FLOOR_THICKNESS / 2]
    cid = world.client_id
    collision = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, physicsClientId=cid)
    if draw:
        visual = pybullet.createVisualShape(
            pybullet.GEOM_BOX, halfExtents=half, rgbaColor=_rgba(rgb), physicsClientId=cid
        )
    else:  # a body without a visual shape gets its collision shape drawn: give it a speck instead
        visual = pybullet.createVisualShape(
            pybullet.GEOM_SPHERE, radius=1e-4, visualFramePosition=[0, 0, -1], physicsClientId=cid
        )
    body = pybullet.createMultiBody(
        0.0, collision, visual, [0.0, 0.0, height - FLOOR_THICKNESS / 2], physicsClientId=cid
    )
    pybullet.changeDynamics(body, -1, lateralFriction=1.0, physicsClientId=cid)
    return Floor(height=height, rgb=rgb, body_id=body, analytic=not draw)  # type: ignore[arg-type]


def _make_object(world: World, spec: _Fields) -> SceneObject:
    cid = world.client_id
    label = spec.text("label")
    shape = spec.text("shape", "box")
    if shape == "box":
        size = spec.vector("size", 3, expected="[x, y, z] in metres (> 0) for a box", positive=True)
        geometry: dict[str, Any] = {"shapeType": pybullet.GEOM_BOX, "halfExtents": [s / 2 for s in size]}
        visual_geometry = dict(geometry)
    elif shape == "cylinder":
        radius = spec.number("radius", expected="a radius in metres (> 0) for a cylinder", positive=True)
        length = spec.number("length", expected="a length in metres (> 0) for a cylinder", positive=True)
        size = (2 * radius, 2 * radius, length)
        geometry = {"shapeType": pybullet.GEOM_CYLINDER, "radius": radius, "height": length}
        visual_geometry = {"shapeType": pybullet.GEOM_CYLINDER, "radius": radius, "length": length}
    elif shape == "sphere":
        radius = spec.number("radius", expected="a radius in metres (> 0) for a sphere", positive=True)
        size = (2 * radius,) * 3
        geometry = {"shapeType": pybullet.GEOM_SPHERE, "radius": radius}
        visual_geometry = dict(geometry)
    else:
        raise _SpecError(f"{spec.entry}: 'shape' must be one of {', '.join(SHAPES)}; got {shape!r}")
    position = spec.vector("position", 3, expected="[x, y, z] of the centre in metres")
    if "rpy" in spec.spec and "yaw" in spec.spec:
        raise _SpecError(f"{spec.entry}: give either 'yaw' or 'rpy', not both")
    rpy = spec.vector(
        "rpy", 3, (0.0, 0.0, spec.number("yaw", 0.0, "an angle in radians")), "[roll, pitch, yaw] in radians"
    )
    orientation = tuple(pybullet.getQuaternionFromEuler(rpy))
    rgb = spec.rgb((160, 160, 160))
    tags = spec.tags()
    body = _static_body(cid, geometry, visual_geometry, rgb, position, orientation)
    return SceneObject(label, body, shape, position, tags, orientation, size, rgb[:3])  # type: ignore[arg-type]


def _static_body(
    cid: int, geometry: dict[str, Any], visual_geometry: dict[str, Any], rgb: Sequence[int],
    position: Sequence[float], orientation: Sequence[float],
) -> int:
    """A static pybullet body with the collision ``geometry`` and the visual one, coloured ``rgb``; its id."""
    collision = pybullet.createCollisionShape(physicsClientId=cid, **geometry)
    visual = pybullet.createVisualShape(rgbaColor=_rgba(rgb), physicsClientId=cid, **visual_geometry)
    return int(pybullet.createMultiBody(0.0, collision, visual, position, orientation, physicsClientId=cid))


def _outward(vertices: np.ndarray, face: tuple[int, int, int], inside: np.ndarray) -> tuple[int, int, int]:
    """``face`` of a convex body with ``vertices`` wound counter-clockwise seen from outside (``inside``: a point
    inside the body)."""
    a, b, c = vertices[list(face)]
    outward = float(np.dot(np.cross(b - a, c - a), (a + b + c) / 3.0 - inside)) > 0
    return face if outward else (face[0], face[2], face[1])


def _make_zone(spec: _Fields) -> Zone:
    label = spec.text("label")
    center = np.array(spec.vector("position", 3, expected="[x, y, z] of the zone's centre in metres"))
    half = np.array(spec.vector("size", 3, expected="[x, y, z] extent in metres (> 0)", positive=True)) / 2
    return Zone(label, tuple((center - half).tolist()), tuple((center + half).tolist()), spec.tags())


def _read_paths(spec: Any) -> dict[str, np.ndarray]:
    if not isinstance(spec, dict):
        raise _SpecError(f"'paths' must map a path name to a list of [x, y] points; got {spec!r}")
    paths = {}
    for name, points in spec.items():
        ok = isinstance(points, list) and len(points) >= 2 and all(
            isinstance(p, (list, tuple)) and len(p) == 2 and all(isinstance(v, (int, float)) for v in p) for p in points
        )
        if not ok:
            raise _SpecError(f"paths['{name}'] must be a list of at least 2 [x, y] points in metres; got {points!r}")
        paths[str(name)] = np.array(points, dtype=float)
    return paths

