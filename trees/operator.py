"""The operator: scripted, typed-in and programmatic commands, delivered at tick boundaries.

Commands come from three sources, all through one :class:`OperatorChannel`:

* the mission's ``operator:`` timeline (``{at: 95.0, say: deploy, why: ...}``,
  ``at`` in simulated seconds);
* lines typed on stdin during ``marsupial run --operator`` (``dock corridor
  ahead`` = command ``dock`` with reason ``corridor ahead``), queued by a
  reader thread;
* the Python API :meth:`OperatorChannel.say`.

The runner calls :meth:`OperatorChannel.poll` once per tick, before ticking
the tree: every command due by then is stamped with the simulated time at
which it is consumed, recorded, and

* ``abort`` / ``pause`` / ``resume`` (:data:`CONTROL_COMMANDS`) are handled by
  the runner above the tree: abort ends the mission with outcome
  ``aborted``; pause makes every robot safe and stops ticking the tree until
  ``resume``;
* any other command (``dock``, ``deploy``, …) is *latched*: the ``operator``
  condition naming it holds from then on until the command is handled.
  Inside ``priorities`` the command is handled when the branch it guards
  finishes (success or failure), so that branch keeps its priority while it
  runs, is resumed if something higher interrupts it, and does not restart
  afterwards. Elsewhere (a ``condition:`` leaf, an ``until`` guard) it is
  handled as soon as the condition reports that it holds. Saying a latched
  command again refreshes its reason and time.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterable
from typing import Any, TextIO

from marsupial.api.ticks import OperatorCommand

#: commands the runner handles above the tree
CONTROL_COMMANDS = ("abort", "pause", "resume")


def parse_line(line: str) -> tuple[str, str] | None:
    """``"dock corridor ahead"`` -> ``("dock", "corridor ahead")``; ``None`` for a blank line."""
    parts = line.strip().split(maxsplit=1)
    if not parts:
        return None
    return parts[0], parts[1] if len(parts) > 1 else ""


class OperatorChannel:
    """Queue of operator commands (scripted, typed in, sent by the API) and their history.

    Args:
        script: ``(at, say, why)`` triples of the mission's timeline (sim
            seconds), or ``(at, say, why, source)`` to replay commands of another
            source (``marsupial verify`` re-sends a log's live commands this way).
    """

    def __init__(self, script: Iterable[tuple[Any, ...]] = ()):
        entries = [(float(e[0]), e[1], e[2], e[3] if len(e) > 3 else "script") for e in script]
        self._script = sorted(entries, key=lambda e: e[0])
        self._next_scripted = 0
        self._queue: queue.SimpleQueue[tuple[str, str, str]] = queue.SimpleQueue()
        self.history: list[OperatorCommand] = []
        self._reader: threading.Thread | None = None

    # -------------------------------------------------------------- inputs
    def say(self, command: str, why: str = "", source: str = "api") -> None:
        """Send ``command`` (thread-safe); it is consumed at the next tick boundary."""
        self._queue.put((command, why, source))

    def read_from(self, stream: TextIO) -> threading.Thread:
        """Start a daemon thread queueing every line of ``stream`` as a command (``--operator``)."""

        def reader() -> None:
            for line in stream:
                parsed = parse_line(line)
                if parsed is not None:
                    self.say(*parsed, source="stdin")

        self._reader = threading.Thread(target=reader, name="operator-stdin", daemon=True)
        self._reader.start()
        return self._reader

    # -------------------------------------------------------------- ticking
    def poll(self, now: float) -> list[OperatorCommand]:
        """Consume the commands due at sim time ``now``: scripted ones first, then queued ones.

        They are kept in :attr:`history`; the runner handles the control
        commands and passes the others to the tree (:class:`OperatorLatch`).
        """
        due: list[tuple[str, str, str]] = []
        while self._next_scripted < len(self._script) and self._script[self._next_scripted][0] <= now + 1e-9:
            _, say, why, source = self._script[self._next_scripted]
            due.append((say, why, source))
            self._next_scripted += 1
        while True:
            try:
                due.append(self._queue.get_nowait())
            except queue.Empty:
                break
        consumed = [OperatorCommand(say, why, now, source) for say, why, source in due]
        self.history.extend(consumed)
        return consumed


class OperatorLatch:
    """The operator's pending commands as the tree sees them: latched when said, until a node handles them."""

    def __init__(self) -> None:
        self._latched: dict[str, OperatorCommand] = {}

    def latch(self, command: OperatorCommand) -> None:
        """Hold ``command`` until it is handled (a control command is the runner's and is not latched)."""
        if command.say not in CONTROL_COMMANDS:
            self._latched[command.say] = command

    def latched(self, name: str) -> OperatorCommand | None:
        """The pending (said, not yet handled) command ``name``, or ``None``."""
        return self._latched.get(name)

    def handle(self, name: str) -> OperatorCommand | None:
        """Mark command ``name`` as handled (un-latch it); returns it if it was pending."""
        return self._latched.pop(name, None)
