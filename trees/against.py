"""Replay a run's recorded inputs into a mission's current skills, open loop, and find where they answer differently.

A run made with ``--record-inputs`` logs every message the tree received
and the commands it answered with (:mod:`.exchange_log`). :func:`replay_against`
builds the tree of ``mission`` (the same one, or a changed one: other
parameters, an edited skill) on the run's set-up (team models, priors,
seed), feeds it those inputs in order without any world, and compares its
commands with the logged ones, tick by tick. The first difference is a
:class:`Divergence`: the tick, the simulated time, the node and both commands.
``marsupial replay LOG --against MISSION`` prints it (exit 1), or that every
command matched (exit 0); :func:`assert_replays` is the same for tests.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from marsupial.api.commands import Command
from marsupial.api.ticks import TickInput, TickOutput, TreeSetup

from . import exchange_log
from .errors import MissionError
from .host import TreeHost
from .mission import Mission, load_mission
from .replay import read_log


@dataclass(frozen=True)
class Divergence:
    """The first command that differs: tick, sim time (s), the node that sent it, logged and replayed commands.

    ``logged`` or ``replayed`` is ``None`` where one side sent fewer commands in that tick.
    """

    tick: int
    t: float
    node: str
    logged: Command | None
    replayed: Command | None

    def __str__(self) -> str:
        return (
            f"tick {self.tick} (t = {self.t:.3f} s), node '{self.node}':\n"
            f"  logged:   {self.logged!r}\n  replayed: {self.replayed!r}"
        )


@dataclass(frozen=True)
class ReplayResult:
    """How a replay went: ticks replayed, commands compared, and the first divergence (``None``: identical)."""

    ticks: int
    commands: int
    divergence: Divergence | None

    @property
    def identical(self) -> bool:
        """Whether every command matched the logged one."""
        return self.divergence is None


def _records(path: Path) -> Iterator[tuple[str, float, Any]]:
    """``(kind, t, message)`` of the log's exchange records, in order; :class:`MissionError` when it has none."""
    log = read_log(path)
    if exchange_log.TOPIC not in log.topic_names:
        raise MissionError(
            f"{path} has no recorded inputs", expected="a log of 'marsupial run … --record-inputs'"
        )
    for message in log.messages(exchange_log.TOPIC):
        try:
            yield message.data["kind"], message.t, exchange_log.decode(message.data["data"])
        except exchange_log.ExchangeLogError as err:
            raise MissionError(f"{path}: {err}", expected="a log written by 'marsupial run --record-inputs'") from None


def _first_difference(tick: int, t: float, logged: tuple[tuple[str, ...], tuple[Command, ...]],
                      replayed: TickOutput) -> Divergence | None:
    senders, commands = logged
    for i in range(max(len(commands), len(replayed.commands))):
        a = commands[i] if i < len(commands) else None
        b = replayed.commands[i] if i < len(replayed.commands) else None
        if not exchange_log.same(a, b):
            node = senders[i] if i < len(senders) else replayed.senders[i]
            return Divergence(tick, t, node, a, b)
    return None


def replay_against(log: str | Path, mission: Mission | str | Path,
                   overrides: Mapping[str, str] | None = None) -> ReplayResult:
    """Feed the inputs recorded in ``log`` to ``mission``'s tree (loaded with ``overrides``); compare its commands.

    Raises :class:`MissionError` for a log without recorded inputs, or a mission whose team differs from the run's.
    """
    if not isinstance(mission, Mission):
        mission = load_mission(mission, overrides)
    host: TreeHost | None = None
    ticks = compared = tick = 0
    answered = True  # the last input has been answered: an output now is the end-of-run stop's
    output = TickOutput()
    for kind, t, message in _records(Path(log)):
        if kind == "setup":
            host = _host(mission, message)
            continue
        if host is None:
            raise MissionError(f"{log}: the recorded inputs have no set-up record", expected="a complete log")
        if kind in ("tick", "pause"):
            assert isinstance(message, TickInput)
            output = host.tick(message) if kind == "tick" else host.pause(message)
            ticks, answered = ticks + (kind == "tick"), False
            tick = message.tick
            continue
        if answered:
            output = host.stop()
        answered = True
        divergence = _first_difference(tick, t, message, output)
        if divergence is not None:
            return ReplayResult(ticks, compared, divergence)
        compared += len(message[1])
    return ReplayResult(ticks, compared, None)


def _host(mission: Mission, setup: TreeSetup) -> TreeHost:
    """The tree of ``mission`` on the run's set-up; its team must be the run's."""
    team = set(mission.spec.team)
    if team != set(setup.team):
        raise MissionError(
            f"the mission's team {sorted(team)} is not the run's {sorted(setup.team)}",
            expected="a mission with the logged run's team",
        )
    return TreeHost.for_mission(mission, setup)


def assert_replays(log: str | Path, mission: Mission | str | Path, overrides: Mapping[str, str] | None = None) -> None:
    """Assert that ``mission``'s tree answers the inputs recorded in ``log`` with the logged commands (for tests)."""
    result = replay_against(log, mission, overrides)
    assert result.identical, f"the replay diverged at {result.divergence}"
