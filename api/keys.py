"""Typed blackboard keys: a key's name and the type of what it holds (BehaviorTree.CPP's ``InputPort<T>``).

A node declares the keys it reads and writes (``reads``/``writes``) as
strings or as :class:`Key` objects; with a ``Key[T]``, ``node.read(key)`` is
typed ``T | None`` and ``node.write(key, value)`` requires a ``T``, so mypy
refuses a reading stored under a key of another type, and the runtime
refuses it too (a :class:`TypeError` naming the key).
"""

from __future__ import annotations

from typing import Any, Generic, TypeVar

T = TypeVar("T")


class Key(Generic[T]):
    """A blackboard key: its name (a format string over the node's ``robot`` and parameters) and its value type.

    ``UAV_POSE: Key[UavObservation] = Key("{carrier}/uav_pose_M", UavObservation)``;
    :meth:`at` fills the name in (``UAV_POSE.at(carrier="carrier")``).
    """

    __slots__ = ("name", "type")

    def __init__(self, name: str, type_: type[T]) -> None:
        self.name = name
        self.type = type_

    def at(self, **values: Any) -> Key[T]:
        """The same key with its name formatted with ``values``."""
        return Key(self.name.format(**values), self.type)

    def check(self, value: object) -> None:
        """Raise :class:`TypeError` unless ``value`` is a ``T`` (``None`` clears a key and is accepted)."""
        if value is not None and not isinstance(value, self.type):
            raise TypeError(
                f"blackboard key '{self.name}' holds {self.type.__name__}, not {type(value).__name__}"
            )

    def __str__(self) -> str:
        return self.name

    def __repr__(self) -> str:
        return f"Key({self.name!r}, {self.type.__name__})"
