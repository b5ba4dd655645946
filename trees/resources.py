"""Compile-time checks of what nodes need of robots: capabilities, sensors, team-member parameters, resources.

The vocabulary is :mod:`marsupial.api.capabilities`: a robot kind has the
capabilities its onboard interface class provides and the resources its
commands drive. A skill claims resources (``Skill.claims``); two branches
of one ``parallel`` must not claim one resource of one robot, since both
would command it every tick (the arbiter orders commands within a tick, it
cannot share a resource between two running skills).
"""

from __future__ import annotations

import functools
import typing
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from marsupial.api.capabilities import CAPABILITIES, provides
from marsupial.api.errors import UnknownNameError

from .arbitration import ANY_RESOURCE
from .skill import MissionNode, Skill, TeamMember

if TYPE_CHECKING:
    from .mission import Mission


@functools.cache
def _view_class(kind: str) -> Any:
    from marsupial.world.robots import robot_class

    return robot_class(kind).view_class


@functools.cache
def kind_capabilities(kind: str) -> frozenset[type]:
    """The capabilities (protocols of :mod:`marsupial.api.capabilities`) robots of ``kind`` have.

    Raises :class:`UnknownNameError` for an unknown kind.
    """
    onboard = _view_class(kind)
    return frozenset(c for c in CAPABILITIES if provides(onboard, c))


def kind_resources(kind: str) -> frozenset[str]:
    """The resources robots of ``kind`` have (those their commands drive)."""
    return frozenset(_view_class(kind).resources())


def members_with(team: Mapping[str, Any], capabilities: Iterable[type] | None) -> list[str]:
    """Team members (name -> member with a ``robot`` kind) whose kind has every capability; unknown kinds have none."""
    wanted = set(capabilities or ())
    able = []
    for name, member in team.items():
        try:
            if wanted <= kind_capabilities(member.robot):
                able.append(name)
        except UnknownNameError:
            continue
    return able


def team_member_of(annotation: Any, metadata: Sequence[Any] = ()) -> TeamMember | None:
    """The :class:`~.skill.TeamMember` marker of a parameter (in its metadata, or inside an optional annotation)."""
    for item in metadata:
        if isinstance(item, TeamMember):
            return item
    for arg in typing.get_args(annotation):
        if isinstance(arg, TeamMember):
            return arg
        found = team_member_of(arg)
        if found is not None:
            return found
    return None


class ResourceChecks:
    """The resource and sensor checks of one compilation (errors at the nodes' file:line)."""

    def __init__(self, mission: Mission):
        self.mission = mission

    def missing_sensors(self, kind: str, sensors: Sequence[str]) -> list[str]:
        """The names in ``sensors`` that robots of ``kind`` lack (none when the kind does not declare its sensors)."""
        from marsupial.world.robots import robot_class

        declared = robot_class(kind).declared_sensors()
        return [] if declared is None else [s for s in sensors if s not in declared]

    def claims_of(self, node: MissionNode[Any], team: Mapping[str, Any]) -> set[tuple[str, str]]:
        """``(robot, resource)`` pairs a skill leaf commands (a claim on any resource expands to its robot's)."""
        if not isinstance(node, Skill):
            return set()
        pairs = set()
        for robot, resource in node.claimed(node.params, node.robot_name):
            if resource == ANY_RESOURCE and robot in team:
                pairs |= {(robot, r) for r in kind_resources(team[robot].robot)}
            else:
                pairs.add((robot, resource))
        return pairs

    def check_parallel(
        self, branches: Sequence[Sequence[tuple[MissionNode[Any], Any]]], team: Mapping[str, Any]
    ) -> None:
        """No two branches of a ``parallel`` (each its ``(leaf, where)`` list) claim one resource of one robot."""
        seen: dict[tuple[str, str], tuple[MissionNode[Any], Any, int]] = {}
        for index, leaves in enumerate(branches):
            for node, at in leaves:
                for claim in sorted(self.claims_of(node, team)):
                    other = seen.get(claim)
                    if other is not None and other[2] != index:
                        first, first_at, _ = other
                        robot, resource = claim
                        where = self.mission.error_at(first_at, "").location
                        raise self.mission.error_at(
                            at,
                            f"'{node.name}' and '{first.name}' ({where}) both command {robot}'s {resource} "
                            "from parallel branches",
                            expected="one skill per resource of a robot at a time (put them in a sequence, or give "
                            "each branch its own resource)",
                        )
                    seen.setdefault(claim, (node, at, index))
