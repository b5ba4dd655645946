"""Milestones: what a run achieved, as its skills report it ("uav: docked", "scout_1: found fire_extinguisher").

A skill that reaches a result a person would ask about records it with
:func:`milestone`: a ``milestone`` event naming the robot it is about (the
stored UAV, not the carrier that stored it), a short past-tense phrase and,
if useful, a detail. The end-of-run summary and the run report read them
back from the log (:func:`story`) and tell each robot's story in order::

    uav: deployed at 4.8 s, docked at 110.9 s (tracking → lock 5.5 s), stored at 111.7 s (charging)

These are the skills' own claims, from what the robots sensed; the
referee's truth-based scores are metrics beside them
(:mod:`marsupial.world.scoring`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .skill import MissionNode

__all__ = ["MAX_TOLD", "Milestone", "milestone", "story", "tell"]

MAX_TOLD = 12  # milestones told per robot in a summary line before "… N more"


@dataclass(frozen=True)
class Milestone:
    """One milestone: simulated time ``t`` (s), what happened, an optional detail."""

    t: float
    what: str
    detail: str = ""

    def __str__(self) -> str:
        return f"{self.what} at {self.t:.1f} s" + (f" ({self.detail})" if self.detail else "")


def milestone(node: MissionNode[Any], what: str, robot: str | None = None, detail: str = "", **fields: Any) -> None:
    """Record that ``robot`` (default: the node's) reached ``what`` (``"docked"``), with an optional ``detail``.

    A ``milestone`` event at the current simulated time, with the node's
    name and skill and any extra ``fields``.
    """
    node.context.event(
        "milestone",
        robot=robot if robot is not None else node.robot_name,
        what=what,
        detail=detail,
        node=node.name,
        skill=node.kind,
        **fields,
    )


def story(events: Iterable[Mapping[str, Any]]) -> dict[str, list[Milestone]]:
    """The ``milestone`` events of a run (``{"t", "kind", ...}`` as read from a log) by robot, in time order."""
    told: dict[str, list[Milestone]] = {}
    for event in events:
        if event.get("kind") == "milestone":
            told.setdefault(str(event["robot"]), []).append(
                Milestone(float(event["t"]), str(event["what"]), str(event.get("detail") or ""))
            )
    return told


def tell(milestones: list[Milestone], limit: int = MAX_TOLD) -> str:
    """One robot's milestones as a line: ``"docked at 110.9 s (…), stored at 111.7 s"`` (at most ``limit``)."""
    text = ", ".join(str(m) for m in milestones[:limit])
    more = len(milestones) - limit
    return text + (f", … {more} more (marsupial replay lists them)" if more > 0 else "")
