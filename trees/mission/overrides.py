"""``--set key.path=value`` overrides applied to a mission's data before validation.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, get_origin

from pydantic import (
    BaseModel,
)

from ..errors import MissionError, one_of, suggest
from ..yaml_source import parse_scalar
from .spec import MissionSpec
from .validation import union_member, unwrap, walk_location

# ------------------------------------------------------------------------ overrides

_SECTIONS = {name: f.annotation for name, f in MissionSpec.model_fields.items()}


def _override_keys(data: Any, tp: Any) -> list[Any]:
    """Keys an override may set in ``data`` (declared type ``tp``): a list's indices, model fields, else existing
    keys."""
    if isinstance(data, list):
        return list(range(len(data)))
    tp = unwrap(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return list(tp.model_fields)
    if isinstance(data, dict):
        return list(data)
    return []


def _is_mapping_type(tp: Any) -> bool:
    tp = unwrap(tp)
    return get_origin(tp) is dict or (isinstance(tp, type) and issubclass(tp, BaseModel))


def apply_overrides(
    data: dict[str, Any], overrides: Mapping[str, str], file: str | None = None
) -> dict[tuple[Any, ...], str]:
    """Set ``--set key=value`` overrides in mission ``data`` (in place); values are parsed as YAML.

    A key is a dotted path (``params.cruise_height``, ``world.seed``,
    ``run.until``, ``team.uav.pose.2``), a bare mission parameter name
    (``cruise_height``) or a dotted path into a mission parameter that is a
    mapping (``tracker.mode`` for ``params.tracker.mode``). Returns key path -> ``"--set key=value"`` of each
    override (to annotate later validation errors). An unknown key raises a
    :class:`MissionError` listing the close names.
    """
    applied: dict[tuple[Any, ...], str] = {}
    given = data.get("params")
    params: dict[str, Any] = given if isinstance(given, dict) else {}
    for key, text in overrides.items():
        shown = f"--set {key}={text}"
        parts: list[Any] = key.split(".") if "." in key else ["params", key]
        if parts[0] not in _SECTIONS and parts[0] in params:
            parts = ["params", *parts]  # a key of a settings group: tracker.mode = params.tracker.mode
        elif parts[0] not in _SECTIONS:
            raise MissionError(
                f"{shown}: '{parts[0]}' is neither a mission section nor a mission parameter",
                file,
                expected=f"a section ({one_of(_SECTIONS)}) or a mission parameter ({one_of(params)})",
                suggestion=suggest(parts[0], list(_SECTIONS) + list(params)),
            )
        if "." not in key and key not in params:
            names = [f"params.{p}" for p in params] + [f"{s}." for s in _SECTIONS]
            raise MissionError(
                f"{shown}: '{key}' is not a mission parameter",
                file,
                expected=f"a mission parameter ({one_of(params)}) or a dotted key such as world.seed",
                suggestion=suggest(key, list(params) + names),
            )
        target: Any = data
        tp: Any = MissionSpec
        for depth, part in enumerate(parts):
            if isinstance(target, list) and part.lstrip("-").isdigit():
                part = parts[depth] = int(part)
            tp = union_member(tp, target)
            allowed = _override_keys(target, tp) if isinstance(target, (dict, list)) else []
            if part not in allowed:
                prefix = ".".join(str(p) for p in parts[:depth])
                full = [f"{prefix}.{a}" if prefix else str(a) for a in allowed]
                key_text = ".".join(str(p) for p in parts[: depth + 1])
                raise MissionError(
                    f"{shown}: unknown key '{key_text}'",
                    file,
                    expected=one_of(full) if full else f"'{prefix}' to hold a mapping or a list",
                    suggestion=suggest(key_text, full),
                )
            tp = walk_location((part,), tp, None).annotation
            if depth == len(parts) - 1:
                target[part] = parse_scalar(text)
            else:
                if isinstance(target, dict) and target.get(part) is None and _is_mapping_type(tp):
                    target[part] = {}  # a section left out of the file (run:, world: …)
                target = target.get(part) if isinstance(target, dict) else target[part]
        applied[tuple(parts)] = shown
    return applied
