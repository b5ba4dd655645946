"""Watch a run live in Foxglove: the recorder's messages served over the Foxglove WebSocket protocol.

``marsupial run --live`` adds a :class:`LiveSink` to the run's recorder
(:mod:`marsupial.trees.sinks`), so the live view carries exactly the channels,
schemas and JSON payloads of the MCAP log (``docs/logs.md``): ``/tf``, poses,
``/scene``, ``/tree`` and ``/tree/xml``, ``/events``, ``/log``, ``/metrics``
and, when recorded, camera images. The server is the official ``foxglove-sdk``
(its WebSocket subprotocol is ``foxglove.sdk.v1`` in 0.30); it also
broadcasts the run's clock (``Capability.Time``), so Foxglove's timeline
shows simulated time. A client that subscribes after the start is sent the
last ``/scene`` and ``/tree/xml`` message (they are written once), so it sees
the scene and the tree whenever it connects.

The server stays quiet: the sink implements every hook of the SDK's
``ServerListener`` (a missing one made the SDK print an ``AttributeError``
on every disconnect), and the SDK's own log lines go through
:class:`SdkLogLines`, which prints one clear line for a refused client (a
client that offers only the legacy subprotocol ``foxglove.websocket.v1`` is
refused by 0.30, and retries every half second) and passes other warnings
on as one line each. At the end of a run every client gets a status
message with the outcome before the server stops (the SDK then sends a
close frame without a status code, which clients report as 1005).

Message times are simulated nanoseconds, as in the log.
"""

from __future__ import annotations

import logging
import re
import sys
import threading
from collections.abc import Mapping
from typing import Any, TextIO

from foxglove.websocket import ServerListener

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "LATCHED_TOPICS", "SUBPROTOCOL", "LiveSink", "SdkLogLines"]

DEFAULT_HOST = "127.0.0.1"  # only this machine; --host 0.0.0.0 opens the run to the network
DEFAULT_PORT = 8765  # Foxglove's default WebSocket port
#: topics written once per run (or per tree structure): re-sent to every client that subscribes later
LATCHED_TOPICS = frozenset({"/scene", "/tree/xml"})
SUBPROTOCOL = "foxglove.sdk.v1"  # the WebSocket subprotocol of foxglove-sdk 0.30
LEGACY_SUBPROTOCOL = "foxglove.websocket.v1"  # what older Foxglove apps and libraries offer
_REFUSED = re.compile(r"Dropping client (?P<address>\S+?):\d+: handshake failed")


class SdkLogLines(logging.Handler):
    """The SDK's log records (logger ``foxglove``) as ``live:`` lines on ``stream``, warnings and errors only.

    A refused WebSocket handshake is explained once per client address (its
    retries are not printed again); any other record is printed as it is.
    """

    def __init__(self, stream: TextIO | None = None):
        super().__init__(logging.WARNING)
        self.stream = stream
        self.refused: set[str] = set()

    def emit(self, record: logging.LogRecord) -> None:
        """Print ``record`` as one line (see the class docstring)."""
        text = record.getMessage()
        refused = _REFUSED.search(text)
        if refused is not None:
            address = refused["address"]
            if address in self.refused:
                return
            self.refused.add(address)
            text = (
                f"a client at {address} was refused: its WebSocket handshake failed. This server speaks "
                f"{SUBPROTOCOL}; a client offering only the legacy {LEGACY_SUBPROTOCOL} (an older Foxglove app "
                "or library) cannot connect: update it (its retries are not printed)"
            )
        else:
            text = f"{record.levelname.lower()} from the Foxglove server: {text}"
        print(f"live: {text}", file=self.stream or sys.stderr, flush=True)


_sdk_lines: SdkLogLines | None = None


def _route_sdk_logs() -> SdkLogLines:
    """Send the SDK's log records to one :class:`SdkLogLines` (once per process; the root logger left as it was)."""
    global _sdk_lines
    if _sdk_lines is None:
        import foxglove

        root = logging.getLogger()
        handlers, level = list(root.handlers), root.level
        foxglove.set_log_level("WARNING")  # records now reach Python's logging; it may configure the root logger
        for handler in root.handlers[len(handlers):]:
            root.removeHandler(handler)
        root.setLevel(level)
        sdk = logging.getLogger("foxglove")
        sdk.propagate = False
        _sdk_lines = SdkLogLines()
        sdk.addHandler(_sdk_lines)
    return _sdk_lines


#: wall seconds the server stays up after the run-end status, so that clients receive it
END_GRACE_S = 1.0


class LiveSink(ServerListener):
    """A Foxglove WebSocket server on ``host:port`` (``port`` 0: any free port) as a recorder sink.

    The server starts in the constructor (clients may connect before the run
    starts) and stops at :meth:`close`. :attr:`url` is the address to open in
    Foxglove (**Open connection → Foxglove WebSocket**). As the server's
    listener it inherits every hook of ``ServerListener`` (the SDK's
    defaults: nothing to do) and overrides :meth:`on_subscribe`.
    """

    def __init__(self, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, name: str = "marsupial"):
        import foxglove
        from foxglove.websocket import Capability

        _route_sdk_logs()
        self._foxglove = foxglove
        self.host = host
        self.context = foxglove.Context()
        self._lock = threading.Lock()
        self._latest: dict[int, tuple[Any, int, bytes]] = {}  # latched channel id -> (channel, ns, data)
        self._resend: set[int] = set()  # latched channel ids a client subscribed to since their last message
        self._last_ns = -1
        self._stopped = False
        self._told_end = False
        self.server = foxglove.start_server(
            name=name,
            host=host,
            port=port,
            capabilities=[Capability.Time],
            server_listener=self,
            context=self.context,
        )

    @property
    def port(self) -> int:
        """The port the server listens on (the one chosen when ``port`` was 0)."""
        return int(self.server.port)

    @property
    def url(self) -> str:
        """``ws://host:port`` for Foxglove's WebSocket connection."""
        return f"ws://{self.host}:{self.port}"

    # ------------------------------------------------------------ Sink
    def channel(self, topic: str, schema_name: str, schema: bytes) -> tuple[Any, int | None]:
        """Advertise ``topic`` (JSON messages, its JSON Schema) to every connected and future client.

        Returns the SDK's channel and, for a latched topic, its id.
        """
        foxglove = self._foxglove
        channel = foxglove.Channel(
            topic,
            schema=foxglove.Schema(name=schema_name, encoding="jsonschema", data=schema),
            message_encoding="json",
            context=self.context,
        )
        return channel.base, channel.id() if topic in LATCHED_TOPICS else None

    def write(self, channel: tuple[Any, int | None], ns: int, data: bytes) -> None:
        """Send a message to the clients subscribed to ``channel``; keep latched topics' last message."""
        base, latched_id = channel  # the SDK's channel core: bytes are sent as they are (already JSON)
        if self._resend:
            with self._lock:
                resend = [self._latest[cid] for cid in self._resend if cid in self._latest]
                self._resend.clear()
            for old_base, old_ns, old_data in resend:
                old_base.log(old_data, old_ns)
        if latched_id is not None:
            with self._lock:
                self._latest[latched_id] = (base, ns, data)
        base.log(data, ns)
        if ns != self._last_ns:
            self._last_ns = ns
            self.server.broadcast_time(ns)

    def metadata(self, name: str, record: Mapping[str, str]) -> None:
        """Tell every client how the run ended (the ``outcome`` record, written at its end) as a status message.

        Other records (the run's metadata) stay in the log file.
        """
        if name == "outcome" and not self._stopped:
            from foxglove.websocket import StatusLevel

            outcome, at = record.get("outcome", "?"), record.get("sim_time", "?")
            level = StatusLevel.Info if outcome == "success" else StatusLevel.Warning
            self.server.publish_status(f"run ended: {outcome} at {at} s (simulated); the live view stops", level,
                                       id="run_end")
            self._told_end = True

    def close(self) -> None:
        """Stop the server (clients are disconnected); safe to call more than once.

        After the run-end status it waits :data:`END_GRACE_S` of wall time first: the server sends from its own
        thread, and stopping at once can cut the status off before a client has it.
        """
        if not self._stopped:
            self._stopped = True
            if self._told_end:
                threading.Event().wait(END_GRACE_S)
            self.server.stop()

    # ------------------------------------------------------------ ServerListener
    def on_subscribe(self, client: Any, channel: Any) -> None:
        """A client subscribed: a latched channel's last message goes out again with the next write."""
        with self._lock:
            if channel.id in self._latest:
                self._resend.add(channel.id)
