"""The JSON Schema of mission files (for editors), with the node union named ``Node``.
"""

from __future__ import annotations

from typing import Any

from .nodes import NODE_CLASSES, NODE_KINDS
from .spec import MissionSpec


def mission_schema() -> dict[str, Any]:
    """JSON Schema (draft 2020-12) of a mission file, with the node union as ``$defs/Node``."""
    schema = MissionSpec.model_json_schema()
    refs = [{"$ref": f"#/$defs/{cls.__name__}"} for cls in NODE_CLASSES.values()]

    def name_union(value: Any) -> None:
        if isinstance(value, dict):
            if value.get("oneOf") == refs:
                del value["oneOf"]
                value["$ref"] = "#/$defs/Node"
            for item in value.values():
                name_union(item)
        elif isinstance(value, list):
            for item in value:
                name_union(item)

    name_union(schema)
    schema["$defs"]["Node"] = {
        "title": "Node",
        "description": f"A tree node: a mapping with exactly one of {', '.join(NODE_KINDS)}.",
        "oneOf": refs,
    }
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}
