"""pydantic validation errors turned into located :class:`~marsupial.trees.errors.MissionError` errors.

Each error names the YAML key path (union tags dropped), its file:line:column,
what was expected and, for unknown keys, the closest known key.
"""

from __future__ import annotations

import functools
import types
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Annotated, Any, Literal, Union, get_args, get_origin

from pydantic import (
    BaseModel,
    Discriminator,
    Tag,
    TypeAdapter,
    ValidationError,
)

from ..errors import KeyPathLike, MissionError, combine_errors, one_of, suggest
from ..yaml_source import SourceDoc
from .nodes import NODE_CLASSES, NODE_KINDS, structural_keys

MAX_REPORTED_ERRORS = 5


# ------------------------------------------------------- validation errors -> MissionError

_EXPECTATIONS = {
    "int_type": "an integer", "int_parsing": "an integer", "int_from_float": "an integer",
    "float_type": "a number", "float_parsing": "a number", "string_type": "a string",
    "bool_type": "true or false", "bool_parsing": "true or false", "list_type": "a list",
    "dict_type": "a mapping", "model_type": "a mapping", "model_attributes_type": "a mapping",
    "literal_error": "{expected}", "greater_than": "a value > {gt}", "greater_than_equal": "a value >= {ge}",
    "less_than": "a value < {lt}", "less_than_equal": "a value <= {le}",
    "too_short": "at least {min_length} item(s)", "too_long": "at most {max_length} item(s)",
    "string_too_short": "a non-empty string", "none_required": "null",
    "finite_number": "a finite number", "string_pattern_mismatch": "printable text (no control characters)",
    "string_too_long": "at most {max_length} characters", "tuple_type": "a list", "float_from_bool": "a number",
}


def unwrap(tp: Any) -> Any:
    """``X | None`` -> ``X``; ``Annotated[X, …]`` -> ``X``."""
    while True:
        if get_origin(tp) is Annotated:
            tp = get_args(tp)[0]
        elif get_origin(tp) in (Union, types.UnionType):
            members = [m for m in get_args(tp) if m is not type(None)]
            if len(members) != 1 or tag_map(tp):
                return tp
            tp = members[0]
        else:
            return tp


def tag_map(tp: Any) -> dict[str, Any]:
    """Tag -> member type of a tagged (discriminated) union, ``{}`` for any other type."""
    if get_origin(tp) is Annotated:
        tp = get_args(tp)[0]
    tags = {}
    if get_origin(tp) in (Union, types.UnionType):
        for member in get_args(tp):
            if get_origin(member) is Annotated:
                tags.update({m.tag: get_args(member)[0] for m in get_args(member)[1:] if isinstance(m, Tag)})
    return tags


def discriminator(tp: Any) -> str | Callable[[Any], Any] | None:
    """The discriminator of a tagged union (a field name or a function of the value), ``None`` for other types."""
    if get_origin(tp) is Annotated:
        for meta in get_args(tp)[1:]:
            if isinstance(meta, Discriminator):
                return meta.discriminator
    return None


def union_member(tp: Any, data: Any) -> Any:
    """The member of the tagged union ``tp`` that ``data`` is (told by its discriminator); else ``tp``."""
    tags, tell = tag_map(tp), discriminator(tp)
    if isinstance(tell, str):
        tag = data.get(tell) if isinstance(data, Mapping) else None
    else:
        tag = tell(data) if tell is not None else None
    return tags.get(tag, tp) if isinstance(tag, str) else tp


def _is_node_union(tp: Any) -> bool:
    return set(tag_map(tp)) == set(NODE_KINDS)


def _describe(tp: Any) -> str:
    """What a value of type ``tp`` looks like, in words ("an integer", "a node …")."""
    if _is_node_union(tp):
        return f"a node ({one_of(tag_map(tp))})"
    if isinstance(discriminator(tp), str):
        return f"a mapping with {discriminator(tp)} ({one_of(tag_map(tp))})"
    if tag_map(tp):
        return " or ".join(_describe(member) for member in tag_map(tp).values())
    tp = unwrap(tp)
    origin = get_origin(tp)
    if origin is Literal:
        return one_of(repr(a) for a in get_args(tp))
    if origin is list:
        return "a list"
    if origin is dict:
        return "a mapping"
    if origin is tuple:
        return _describe_tuple(get_args(tp))
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        required = [n for n, f in tp.model_fields.items() if f.is_required()]
        return f"a mapping with {', '.join(required)}" if required else "a mapping"
    return {int: "an integer", float: "a number", str: "a string", bool: "true or false"}.get(tp, "a value")


_PLURALS = {int: "integers", float: "numbers", str: "strings", bool: "booleans"}


def _describe_tuple(args: tuple[Any, ...]) -> str:
    """A tuple type in words: ``"a list of 3 numbers"``, ``"a list of numbers"`` (``tuple[float, ...]``)."""
    if len(args) == 2 and args[1] is Ellipsis:
        return f"a list of {_PLURALS.get(unwrap(args[0]), 'values')}"
    kinds = {unwrap(a) for a in args}
    if len(kinds) == 1:
        return f"a list of {len(args)} {_PLURALS.get(kinds.pop(), 'values')}"
    return f"a list of {len(args)} values ({', '.join(_describe(a) for a in args)})"


@dataclass
class _LocWalk:
    """A pydantic error location mapped back onto the YAML document."""

    path: tuple[Any, ...]  # key path as written in the YAML (union tags dropped)
    model: type[BaseModel] | None  # the model that holds the last key
    annotation: Any  # declared type at the path
    value: Any  # the YAML value at the path (None if absent)


_ABSENT = object()


def _field_type(model: type[BaseModel], name: Any) -> Any:
    """The declared type of field ``name`` of ``model`` with its metadata (a union's discriminator); ``Any`` if none."""
    field = model.model_fields.get(name)
    if field is None:
        return Any
    if not field.metadata:
        return field.annotation
    annotated = (field.annotation, *field.metadata)
    return Annotated[annotated]


def walk_location(loc: tuple[Any, ...], root: Any, data: Any) -> _LocWalk:
    """A pydantic error location (or a key path) followed through the type ``root`` and the YAML value ``data``:
    union tags dropped, a single item written without its list found at index 0."""
    path: list[Any] = []
    tp, value, model = root, data, None
    for item in loc:
        tags = tag_map(tp)
        if item in tags:  # a tagged-union member: not a YAML key
            tp = tags[item]
            continue
        tp = unwrap(tp)
        origin = get_origin(tp)
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            model = tp
            tp = _field_type(tp, item)
        elif origin is list:
            tp = get_args(tp)[0]
            if item == 0 and not isinstance(value, list):  # a single item written without a list
                continue
        elif origin is dict:
            tp = get_args(tp)[1]
        elif origin is tuple and isinstance(item, int):
            args = get_args(tp)
            tp = args[0] if len(args) == 2 and args[1] is Ellipsis else args[item] if item < len(args) else Any
        else:
            tp = Any
        path.append(item)
        try:
            value = value[item]
        except (KeyError, IndexError, TypeError):
            value = _ABSENT
    return _LocWalk(tuple(path), model, tp, None if value is _ABSENT else value)


def _node_error(walk: _LocWalk) -> tuple[tuple[Any, ...], str, str, str | None]:
    """(key path, message, expected, suggestion) for a mapping whose node type cannot be told."""
    value, kinds = walk.value, one_of(NODE_KINDS)
    if not isinstance(value, Mapping):
        expected = f"a mapping with one of {', '.join(NODE_KINDS)} (e.g. {{skill: wait}})"
        return walk.path, f"expected a node, got {_show(value)}", expected, None
    present = structural_keys(value)
    if len(present) > 1:
        found = ", ".join(f"'{k}'" for k in present)
        return walk.path, f"a node has exactly one node type key, found {found}", kinds, None
    known_fields = {f for cls in NODE_CLASSES.values() for f in cls.model_fields}
    unknown = [k for k in value if k not in known_fields]
    for key in unknown:
        if suggest(key, NODE_KINDS):
            return walk.path + (key,), f"unknown node type '{key}'", kinds, suggest(key, NODE_KINDS)
    if unknown:
        return walk.path + (unknown[0],), f"unknown node type '{unknown[0]}'", kinds, None
    return walk.path, "node has no node type key", kinds, None


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _union_error(walk: _LocWalk, kind: str, err: Mapping[str, Any]) -> tuple[tuple[Any, ...], str, str, str | None]:
    """(key path, message, expected, suggestion) for a value that no member of a tagged union takes."""
    tags, tell = tag_map(walk.annotation), discriminator(walk.annotation)
    if _is_node_union(walk.annotation):
        return _node_error(walk)
    if isinstance(tell, str):  # a key of the mapping tells the member (robot: bebop2)
        if kind == "union_tag_not_found":
            return walk.path + (tell,), f"missing required key '{tell}'", one_of(tags), None
        tag = err["input"][tell]
        return walk.path + (tell,), f"unknown {tell} {_show(tag)}", one_of(tags), suggest(tag, tags)
    return walk.path, f"invalid value {_show(err['input'])}", _describe(walk.annotation), None


def _convert(err: Mapping[str, Any], root: Any, data: Any) -> tuple[tuple[Any, ...], str, str | None, str | None]:
    """(key path, message, expected, suggestion) of one pydantic error."""
    kind, ctx = err["type"], err.get("ctx") or {}
    walk = walk_location(tuple(err["loc"]) + tuple(ctx.get("at", ())), root, data)
    if kind in ("union_tag_not_found", "union_tag_invalid"):
        return _union_error(walk, kind, err)
    if kind == "extra_forbidden":
        key = walk.path[-1]
        known = list(walk.model.model_fields) if walk.model else []
        return walk.path, f"unknown key '{key}'", one_of(known), suggest(key, known)
    if kind == "missing" and walk.path and isinstance(walk.path[-1], int):  # a list too short for its tuple
        owner = walk_location(tuple(err["loc"])[:-1], root, data)
        given = len(owner.value) if isinstance(owner.value, (list, tuple)) else 0
        return owner.path, f"{given} item{'s' if given != 1 else ''} given", _describe(owner.annotation), None
    if kind == "missing":
        return walk.path, f"missing required key '{walk.path[-1]}'", _describe(walk.annotation), None
    if "expected" in ctx and kind not in _EXPECTATIONS:  # our own checks (PydanticCustomError)
        return walk.path, err["msg"], ctx["expected"], ctx.get("suggestion")
    if kind in _EXPECTATIONS:
        limits = {k: f"{v:g}" if isinstance(v, float) else v for k, v in ctx.items()}
        return walk.path, f"invalid value {_show(err['input'])}", _EXPECTATIONS[kind].format(**limits), None
    return walk.path, err["msg"], None, None


def validation_errors(
    exc: ValidationError,
    source: SourceDoc,
    base_path: KeyPathLike = (),
    root: Any = None,
    data: Any = None,
    notes: Mapping[tuple[Any, ...], str] | None = None,
    note: str | None = None,
) -> list[MissionError]:
    """A :class:`MissionError` for each error of a pydantic ``ValidationError``.

    ``exc`` came from validating ``data`` (found at ``base_path`` of ``source``)
    against ``root`` (a model class or type; ``None``: locations are taken as
    they are). Each error names the YAML key path (union tags dropped), its
    file:line:column, what was expected and, for unknown keys, the closest
    known key. ``notes`` adds lines to errors at or under given key paths
    (values set by overrides or ``${name}`` references); ``note`` to all
    (inside a subtree).
    """
    errors = []
    for err in exc.errors():
        rel, message, expected, suggestion = _convert(err, root if root is not None else Any, data)
        path = tuple(base_path) + rel
        lines = [n for p, n in (notes or {}).items() if path[: len(p)] == p] + ([note] if note else [])
        errors.append(source.error(path, message, expected, suggestion, "; ".join(lines) or None))
    return errors


def errors_from_validation(
    exc: ValidationError,
    source: SourceDoc,
    base_path: KeyPathLike = (),
    root: Any = None,
    data: Any = None,
    notes: Mapping[tuple[Any, ...], str] | None = None,
    note: str | None = None,
) -> MissionError:
    """:func:`validation_errors` as one :class:`MissionError` (a :class:`MissionErrors` if several)."""
    return combine_errors(validation_errors(exc, source, base_path, root, data, notes, note), MAX_REPORTED_ERRORS)


@functools.cache
def _adapter(model: Any) -> TypeAdapter[Any]:
    return TypeAdapter(model)


def validate_source(
    model: Any,
    data: Any,
    source: SourceDoc,
    base_path: KeyPathLike = (),
    pending: Sequence[MissionError] = (),
    notes: Mapping[tuple[Any, ...], str] | None = None,
    note: str | None = None,
) -> Any:
    """``data`` (found at ``base_path`` of ``source``) validated against ``model`` (a type).

    ``pending`` errors found before (unknown ``${name}`` references, whose
    strings were left as written) are raised together with the validation
    errors, in file order; validation errors under a pending error's key path
    are dropped as its consequences.
    """
    errors, value = list(pending), None
    try:
        value = _adapter(model).validate_python(data)
    except ValidationError as exc:
        found = validation_errors(exc, source, base_path, model, data, notes, note)
        errors += [e for e in found if not any(e.key_path[: len(p.key_path)] == p.key_path for p in pending)]
    if errors:
        raise combine_errors(errors, MAX_REPORTED_ERRORS)
    return value
