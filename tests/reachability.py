"""What a mission node can reach: a walk of the object graph from a node, failing on simulator objects.

Reachable means through instance attributes (``__dict__`` and ``__slots__``),
containers (dicts, lists, tuples, sets, deques), closure cells, function
defaults and bound methods' ``__self__``. Module globals and classes are not
followed (a node may import a module; it may not hold the world). An object
is forbidden when its class is defined in the simulator (``marsupial.world``),
in the world side of the runtime (``marsupial.trees.bridge``: the referee's
score board, the world bridge) or in pybullet.
"""

from __future__ import annotations

import types
from collections import deque
from collections.abc import Iterator
from typing import Any

FORBIDDEN_MODULES = ("marsupial.world", "marsupial.trees.bridge", "pybullet")
#: leaf types: nothing to follow inside them
ATOMS = (str, bytes, bytearray, int, float, complex, bool, type(None), range, slice, memoryview)


def forbidden(obj: Any) -> bool:
    """Whether ``obj`` is an instance of a class of the simulator or of the runtime's world side."""
    module = getattr(type(obj), "__module__", "") or ""
    return any(module == m or module.startswith(m + ".") for m in FORBIDDEN_MODULES)


def _container_items(obj: Any) -> Iterator[tuple[str, Any]]:
    if isinstance(obj, dict):
        for key, value in obj.items():
            yield f"[{key!r}]", value
            yield f".keys({key!r})", key
    elif isinstance(obj, (set, frozenset)):
        yield from (("{…}", value) for value in obj)
    else:
        yield from ((f"[{i}]", value) for i, value in enumerate(obj))


def _function_refs(obj: types.FunctionType) -> Iterator[tuple[str, Any]]:
    for cell, name in zip(obj.__closure__ or (), obj.__code__.co_freevars, strict=True):
        try:
            yield f".<closure {name}>", cell.cell_contents
        except ValueError:  # an empty cell
            continue
    yield from ((f".__defaults__[{i}]", value) for i, value in enumerate(obj.__defaults__ or ()))
    yield from ((f".__kwdefaults__[{key!r}]", value) for key, value in (obj.__kwdefaults__ or {}).items())


def _attributes(obj: Any) -> Iterator[tuple[str, Any]]:
    attributes = getattr(obj, "__dict__", None)
    if isinstance(attributes, dict):
        yield from ((f".{k}", v) for k, v in attributes.items())
    for cls in type(obj).__mro__:
        for slot in cls.__dict__.get("__slots__", ()):
            if slot in ("__dict__", "__weakref__"):
                continue
            name = f"_{cls.__name__.lstrip('_')}{slot}" if slot.startswith("__") and not slot.endswith("__") else slot
            try:
                yield f".{name}", object.__getattribute__(obj, name)
            except AttributeError:
                continue


def _children(obj: Any) -> Iterator[tuple[str, Any]]:
    """``(step, child)`` for everything ``obj`` refers to, as the module docstring defines reachable."""
    if isinstance(obj, (dict, list, tuple, deque, set, frozenset)):
        yield from _container_items(obj)
    elif isinstance(obj, types.MethodType):
        yield ".__self__", obj.__self__
        yield ".__func__", obj.__func__
    elif isinstance(obj, types.FunctionType):
        yield from _function_refs(obj)
    elif not isinstance(obj, (types.ModuleType, type)):
        yield from _attributes(obj)


def first_forbidden(root: Any, name: str = "node") -> str | None:
    """The path from ``root`` to the first forbidden object (breadth first), or ``None`` when there is none."""
    seen = {id(root)}
    queue: deque[tuple[Any, str]] = deque([(root, name)])
    while queue:
        obj, path = queue.popleft()
        if forbidden(obj):
            return f"{path} is a {type(obj).__module__}.{type(obj).__qualname__}"
        if isinstance(obj, ATOMS):
            continue
        for step, child in _children(obj):
            if id(child) not in seen and not isinstance(child, ATOMS):
                seen.add(id(child))
                queue.append((child, path + step))
    return None
