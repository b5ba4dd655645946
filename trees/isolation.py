"""Where a run's tree runs: in the runner's process, or isolated in a process of its own (``--isolate``).

Both exchange the same messages (:mod:`marsupial.api.ticks`) in lockstep:
the runner sends a :class:`~marsupial.api.ticks.TickInput` and waits for
the :class:`~marsupial.api.ticks.TickOutput`. In-process
(:class:`LocalTreeSide`) the call is direct. Isolated
(:class:`IsolatedTreeSide`) the tree and its skills live in a child process
started with ``spawn`` (nothing of the world's process is inherited) and the
messages are pickled over a pipe; a skill that raises or a process that dies
ends the run with outcome ``error`` and a valid log, which the world's
process writes.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import traceback
from multiprocessing.connection import Connection
from typing import Any, Protocol

from marsupial.api.ticks import TickInput, TickOutput, TreeSetup

from .host import TreeHost
from .mission import Mission


class TreeSideError(RuntimeError):
    """The isolated tree side failed: a node raised (its traceback is the message) or its process died."""


class TreeSide(Protocol):
    """The tree as the runner drives it: tick, pause, stop, and what the progress line and log warnings need."""

    listens: frozenset[str]
    active: dict[str, tuple[str, ...]]

    def tick(self, message: TickInput) -> TickOutput:
        """Tick the tree once on ``message``."""

    def pause(self, message: TickInput) -> TickOutput:
        """Leave every robot safe: the operator paused the run."""

    def stop(self) -> TickOutput:
        """Stop the skills still running (end of the run)."""

    def close(self) -> None:
        """Release the tree side (end its process)."""


class LocalTreeSide:
    """The tree in the runner's process: direct calls to a :class:`TreeHost`."""

    def __init__(self, host: TreeHost):
        self._host = host
        self.listens = host.listens
        self.active: dict[str, tuple[str, ...]] = {}

    def _seen(self, output: TickOutput) -> TickOutput:
        self.active = output.active
        return output

    def tick(self, message: TickInput) -> TickOutput:
        """Tick the tree once on ``message``."""
        return self._seen(self._host.tick(message))

    def pause(self, message: TickInput) -> TickOutput:
        """Leave every robot safe: the operator paused the run."""
        return self._seen(self._host.pause(message))

    def stop(self) -> TickOutput:
        """Stop the skills still running (end of the run)."""
        return self._seen(self._host.stop())

    def close(self) -> None:
        """Nothing to release in-process."""


def _serve(connection: Connection, setup: TreeSetup, record_images: bool) -> None:
    """The isolated process: build the tree from ``setup``, then answer each request until told to stop."""
    try:
        host = TreeHost.from_setup(setup, record_images)
    except Exception:  # reported to the runner, which ends the run with the error
        connection.send(("error", traceback.format_exc()))
        return
    connection.send(("ready", host.listens))
    while True:
        try:
            request, message = connection.recv()
        except EOFError:
            return
        if request == "close":
            return
        try:
            output = getattr(host, request)(message) if message is not None else getattr(host, request)()
        except Exception:
            connection.send(("error", traceback.format_exc()))
            return
        connection.send(("ok", output))


class IsolatedTreeSide:
    """The tree in a child process of its own; the same messages, pickled over a pipe, in lockstep."""

    def __init__(self, setup: TreeSetup, record_images: bool = False):
        context = multiprocessing.get_context("spawn")
        self._connection, child = context.Pipe()
        self._process = context.Process(target=_serve, args=(child, setup, record_images), name="marsupial-tree",
                                        daemon=True)
        self._process.start()
        child.close()
        self.listens: frozenset[str] = self._answer()
        self.active: dict[str, tuple[str, ...]] = {}

    def _answer(self) -> Any:
        try:
            kind, payload = self._connection.recv()
        except (EOFError, ConnectionError):
            self._process.join(timeout=5)
            raise TreeSideError(f"the tree process ended (exit code {self._process.exitcode})") from None
        if kind == "error":
            raise TreeSideError(f"in the isolated tree process:\n{payload}")
        return payload

    def _call(self, request: str, message: TickInput | None = None) -> TickOutput:
        try:
            self._connection.send((request, message))
        except (BrokenPipeError, ConnectionError):
            raise TreeSideError(f"the tree process ended (exit code {self._process.exitcode})") from None
        output: TickOutput = self._answer()
        self.active = output.active
        return output

    def tick(self, message: TickInput) -> TickOutput:
        """Tick the tree once on ``message``."""
        return self._call("tick", message)

    def pause(self, message: TickInput) -> TickOutput:
        """Leave every robot safe: the operator paused the run."""
        return self._call("pause", message)

    def stop(self) -> TickOutput:
        """Stop the skills still running (end of the run)."""
        return self._call("stop")

    def close(self) -> None:
        """Ask the child to end, then make sure it has."""
        if self._process.is_alive():
            with contextlib.suppress(BrokenPipeError, ConnectionError):
                self._connection.send(("close", None))
            self._process.join(timeout=5)
            if self._process.is_alive():
                self._process.kill()
        self._connection.close()


def open_tree_side(mission: Mission, setup: TreeSetup, record_images: bool = False,
                   isolate: bool = False) -> LocalTreeSide | IsolatedTreeSide:
    """The run's tree side: in this process, or (``isolate``) in a process of its own."""
    if isolate:
        return IsolatedTreeSide(setup, record_images)
    return LocalTreeSide(TreeHost.for_mission(mission, setup, record_images))
