"""Message payloads shared by everything that writes marsupial's channels (JSON for the Foxglove schemas).

Simulated time becomes integer nanoseconds (:func:`ns_of`) and Foxglove
``time`` (:func:`foxglove_time`); vectors and quaternions become Foxglove's field
names; :func:`encode` writes compact JSON with NaN as ``null``;
:func:`scene_update` is the ``/scene`` message of a world.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import py_trees

from .btxml import STATUS_NAMES

if TYPE_CHECKING:
    from marsupial.world.world import World

WORLD_FRAME = "world"


def ns_of(t: float) -> int:
    """Simulated seconds -> integer nanoseconds."""
    return int(round(t * 1e9))


def foxglove_time(ns: int) -> dict[str, int]:
    """Foxglove ``time`` of integer nanoseconds."""
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def xyz(v: Sequence[float]) -> dict[str, float]:
    """Foxglove ``Vector3``/``Point3`` of a 3-vector (m)."""
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def xyzw(q: Sequence[float]) -> dict[str, float]:
    """Foxglove ``Quaternion`` of ``[x, y, z, w]``."""
    return {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])}


def json_default(value: Any) -> Any:
    """JSON form of the values messages carry besides plain JSON: numpy, sets, paths, pydantic models, statuses."""
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        return value.tolist()
    if isinstance(value, (set, frozenset)):
        return sorted(value, key=str)
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "model_dump"):  # pydantic models
        return value.model_dump()
    if isinstance(value, py_trees.common.Status):
        return STATUS_NAMES[value]
    raise TypeError(f"a value of type {type(value).__name__} cannot be logged as JSON")


def finite(value: Any) -> Any:
    """``value`` with every non-finite float replaced by ``None`` (JSON has no NaN)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    return value


_to_json = json.JSONEncoder(separators=(",", ":"), default=json_default, allow_nan=False).encode


def encode(payload: dict[str, Any]) -> bytes:
    """Compact JSON bytes of a message; NaN and infinities become ``null``."""
    try:
        text = _to_json(payload)
    except ValueError:  # NaN / inf somewhere
        text = _to_json(finite(json.loads(json.dumps(payload, default=json_default))))
    return text.encode()


def scene_update(world: World, stamp: dict[str, int]) -> dict[str, Any]:
        """A ``foxglove.SceneUpdate`` of the world's static scene: the floor and every scene object.

        Object geometry (box size, cylinder radius/length, sphere radius),
        colour and pose are read back from pybullet, so they are what the
        physics simulates. Entity ids are the scene labels (``floor`` for the floor).
        """
        import pybullet

        cid = world.client_id
        scene = world.scene
        entities = []
        if scene.floor is not None:
            thickness = 0.02  # m: a thin slab whose top is the floor surface
            entities.append(
                _entity(
                    stamp,
                    "floor",
                    ["floor"],
                    cubes=[
                        {
                            "pose": {
                                "position": xyz((0.0, 0.0, scene.floor.height - thickness / 2)),
                                "orientation": xyzw((0.0, 0.0, 0.0, 1.0)),
                            },
                            "size": xyz((scene.size[0], scene.size[1], thickness)),
                            "color": dict(zip("rgba", [c / 255.0 for c in scene.floor.rgb] + [1.0], strict=True)),
                        }
                    ],
                )
            )
        for label, obj in scene.objects.items():
            position, orientation = pybullet.getBasePositionAndOrientation(obj.body_id, physicsClientId=cid)
            primitives: dict[str, list[dict[str, Any]]] = {"cubes": [], "spheres": [], "cylinders": []}
            for shape in pybullet.getVisualShapeData(obj.body_id, physicsClientId=cid):
                geometry, dims, local_p, local_q, rgba = shape[2], shape[3], shape[5], shape[6], shape[7]
                p, q = pybullet.multiplyTransforms(position, orientation, local_p, local_q, physicsClientId=cid)
                if geometry == pybullet.GEOM_BOX:
                    kind, size = "cubes", dims[:3]
                elif geometry == pybullet.GEOM_SPHERE:
                    kind, size = "spheres", (2 * dims[0],) * 3
                elif geometry == pybullet.GEOM_CYLINDER:
                    kind, size = "cylinders", (2 * dims[1], 2 * dims[1], dims[0])
                else:
                    continue  # meshes/planes are not part of YAML scenes
                primitive = {"pose": {"position": xyz(p), "orientation": xyzw(q)}, "size": xyz(size)}
                if kind == "cylinders":
                    primitive.update(bottom_scale=1.0, top_scale=1.0)
                primitive["color"] = dict(zip("rgba", map(float, rgba), strict=True))
                primitives[kind].append(primitive)
            entities.append(_entity(stamp, label, list(obj.tags), **primitives))
        return {"deletions": [], "entities": entities}

def _entity(stamp: dict[str, int], label: str, tags: list[str], **primitives: Any) -> dict[str, Any]:
        return {
            "timestamp": stamp,
            "frame_id": WORLD_FRAME,
            "id": label,
            "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": False,
            "metadata": [{"key": "tags", "value": ",".join(tags)}],
            "cubes": [],
            "spheres": [],
            "cylinders": [],
            **primitives,
        }
