"""Where skills and conditions come from: entry points, and the mission's ``plugins:`` pins.

Every installed distribution registers its nodes under the entry-point
groups ``marsupial.skills`` and ``marsupial.conditions`` (``name =
"pkg.module:Class"``); marsupial registers its own the same way in its
``pyproject.toml``. A mission may pin the implementation of a name
(``plugins: {hover: my_pkg.nodes:Hover}``). A plug-in that offers the name
of one of marsupial's own nodes never changes what a mission means: without
a pin the mission gets marsupial's node, and the collision is reported once
per process as a :class:`PluginCollision` warning naming both providers. A
name offered by two other distributions and no pin is an error naming both.

Lookup failures raise :class:`~marsupial.trees.errors.MissionError` without
a location; the compiler re-raises them at the node's file:line.
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from importlib.metadata import entry_points
from typing import Any

from .errors import MissionError, one_of, suggest
from .metrics import declare_node
from .skill import Condition, MissionNode, Skill

#: the distribution whose node a name means unless the mission pins another
BUILTIN = "marsupial"

#: node kind -> (entry-point group, base class)
GROUPS: dict[str, tuple[str, type[MissionNode[Any]]]] = {
    "skill": ("marsupial.skills", Skill),
    "condition": ("marsupial.conditions", Condition),
}


@dataclass(frozen=True)
class Provider:
    """One implementation of a node name: ``"pkg.mod:Class"`` and the distribution offering it."""

    name: str
    target: str
    distribution: str

    def __str__(self) -> str:
        return f"{self.distribution} ({self.target})"


class PluginCollision(UserWarning):
    """A plug-in offers the name of a marsupial node: missions keep marsupial's unless they pin the plug-in's."""


_reported: set[tuple[str, str]] = set()  # (kind, name) collisions already reported in this process


def _report_collision(kind: str, name: str, builtin: Provider, others: Sequence[Provider]) -> None:
    """Warn once per process that ``others`` also offer ``name``, and how a mission picks one of them."""
    if (kind, name) in _reported:
        return
    _reported.add((kind, name))
    listed = " and by ".join(str(p) for p in others)
    warnings.warn(
        PluginCollision(
            f"{kind} '{name}' is provided by {builtin} and by {listed}: missions use {builtin.distribution}'s "
            f"unless they pin another, e.g. 'plugins: {{{name}: {others[0].target}}}'"
        ),
        stacklevel=3,
    )


@cache
def installed(kind: str) -> dict[str, tuple[Provider, ...]]:
    """Installed providers of skills (``kind="skill"``) or conditions, by name (cached per process).

    A name's providers are in a fixed order: marsupial's first, then by distribution name.
    """
    group = GROUPS[kind][0]
    found: dict[str, list[Provider]] = {}
    for ep in entry_points(group=group):
        dist = ep.dist.name if ep.dist is not None else "?"
        provider = Provider(ep.name, ep.value, dist)
        providers = found.setdefault(ep.name, [])
        if provider not in providers:  # one distribution seen twice on sys.path
            providers.append(provider)
    return {name: tuple(sorted(p, key=_provider_order)) for name, p in sorted(found.items())}


def _provider_order(provider: Provider) -> tuple[bool, str, str]:
    """Sort key of a name's providers: marsupial's first, then by distribution and target."""
    return provider.distribution != BUILTIN, provider.distribution, provider.target


def import_target(target: str) -> type:
    """Import ``"pkg.module:Class"``; a :class:`MissionError` says what failed."""
    module_name, sep, attr = target.partition(":")
    if not sep or not module_name or not attr:
        raise MissionError(f"'{target}' is not an import target", expected="'package.module:Class'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as err:
        raise MissionError(f"cannot import module '{module_name}' of '{target}': {err}") from None
    obj = module
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            known = [n for n in dir(module) if not n.startswith("_")]
            raise MissionError(
                f"module '{module_name}' has no '{attr}'", suggestion=suggest(attr, known)
            ) from None
    return obj  # type: ignore[return-value]


class Registry:
    """Resolves node names to classes for one mission (its ``plugins:`` pins applied).

    Args:
        pins: ``{name: "pkg.mod:Class"}`` from the mission's ``plugins:``.
    """

    def __init__(self, pins: Mapping[str, str] | None = None):
        self.pins = dict(pins or {})

    def names(self, kind: str) -> list[str]:
        """Known names of ``kind`` (``"skill"`` or ``"condition"``), pinned ones included."""
        base = GROUPS[kind][1]
        pinned = [n for n, t in self.pins.items() if self._pinned_is(t, base)]
        return sorted(set(installed(kind)) | set(pinned))

    def providers(self, kind: str, name: str) -> tuple[Provider, ...]:
        """Installed providers of ``name``."""
        return installed(kind).get(name, ())

    def resolve(self, kind: str, name: str) -> type[MissionNode[Any]]:
        """The class of node ``name`` of ``kind`` (its metrics declared); MissionError if unknown or ambiguous."""
        group, base = GROUPS[kind]
        provider = None if name in self.pins else self.provider(kind, name)
        cls = import_target(self.pins[name] if provider is None else provider.target)
        if not (isinstance(cls, type) and issubclass(cls, base)):
            if provider is not None:
                raise MissionError(f"entry point '{name}' of group {group} ({provider}) is not a {base.__name__}")
            raise MissionError(
                f"plugin '{self.pins[name]}' pinned for {kind} '{name}' is not a {base.__name__}",
                expected=f"a subclass of marsupial.trees.skill.{base.__name__}",
            )
        try:
            declare_node(cls)
        except ValueError as err:  # a metric declared again with another unit, meaning or aggregation
            raise MissionError(f"{kind} '{name}': {err}", expected="one declaration per metric name") from None
        return cls

    def provider(self, kind: str, name: str) -> Provider:
        """The provider a mission without a pin gets for ``name``: the only one, or marsupial's (warned once).

        MissionError for an unknown name, or one offered by several other distributions.
        """
        providers = self.providers(kind, name)
        if not providers:
            known = self.names(kind)
            raise MissionError(
                f"unknown {kind} '{name}'", expected=one_of(known), suggestion=suggest(name, known)
            )
        if len(providers) == 1:
            return providers[0]
        builtin = next((p for p in providers if p.distribution == BUILTIN), None)
        if builtin is None:
            listed = " and ".join(str(p) for p in providers)
            raise MissionError(
                f"{kind} '{name}' is provided by {listed}",
                expected=f"one provider; pin one with 'plugins: {{{name}: <package.module:Class>}}'",
            )
        _report_collision(kind, name, builtin, [p for p in providers if p is not builtin])
        return builtin

    def skill(self, name: str) -> type[Skill[Any]]:
        """The skill class called ``name``."""
        return self.resolve("skill", name)  # type: ignore[return-value]

    def condition(self, name: str) -> type[Condition[Any]]:
        """The condition class called ``name``."""
        return self.resolve("condition", name)  # type: ignore[return-value]

    @staticmethod
    def _pinned_is(target: str, base: type) -> bool:
        try:
            cls = import_target(target)
        except MissionError:
            return False
        return isinstance(cls, type) and issubclass(cls, base)
