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

Message times are simulated nanoseconds, as in the log.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, cast

if TYPE_CHECKING:
    from foxglove.websocket import ServerListener

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "LATCHED_TOPICS", "LiveSink"]

DEFAULT_HOST = "127.0.0.1"  # only this machine; --host 0.0.0.0 opens the run to the network
DEFAULT_PORT = 8765  # Foxglove's default WebSocket port
#: topics written once per run (or per tree structure): re-sent to every client that subscribes later
LATCHED_TOPICS = frozenset({"/scene", "/tree/xml"})


class LiveSink:
    """A Foxglove WebSocket server on ``host:port`` (``port`` 0: any free port) as a recorder sink.

    The server starts in the constructor (clients may connect before the run
    starts) and stops at :meth:`close`. :attr:`url` is the address to open in
    Foxglove (**Open connection → Foxglove WebSocket**).
    """

    def __init__(self, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, name: str = "marsupial"):
        import foxglove
        from foxglove.websocket import Capability

        self._foxglove = foxglove
        self.host = host
        self.context = foxglove.Context()
        self._lock = threading.Lock()
        self._latest: dict[int, tuple[Any, int, bytes]] = {}  # latched channel id -> (channel, ns, data)
        self._resend: set[int] = set()  # latched channel ids a client subscribed to since their last message
        self._last_ns = -1
        self._stopped = False
        self.server = foxglove.start_server(
            name=name,
            host=host,
            port=port,
            capabilities=[Capability.Time],
            server_listener=cast("ServerListener", self),
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
        """The live view has no metadata records (the log file keeps them)."""

    def close(self) -> None:
        """Stop the server (clients are disconnected); safe to call more than once."""
        if not self._stopped:
            self._stopped = True
            self.server.stop()

    # ------------------------------------------------------------ ServerListener
    def on_subscribe(self, client: Any, channel: Any) -> None:
        """A client subscribed: a latched channel's last message goes out again with the next write."""
        with self._lock:
            if channel.id in self._latest:
                self._resend.add(channel.id)
