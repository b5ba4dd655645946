"""Where the recorder's messages go: an MCAP file, a live Foxglove server, or both (one message code path).

:class:`~marsupial.trees.recorder.Recorder` builds every message once (topic,
schema name, JSON bytes, simulated time in ns) and hands it to each of its
sinks. A sink declares a channel once per topic (:meth:`Sink.channel`) and then
receives the encoded messages of that channel (:meth:`Sink.write`), so a live
viewer sees exactly the channels, schemas and payloads a log file holds.
:class:`McapSink` is the file; :class:`marsupial.trees.live.LiveSink` the
Foxglove WebSocket server.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol

from mcap.writer import CompressionType, Writer

import marsupial

__all__ = ["McapSink", "Sink"]


class Sink(Protocol):
    """An output of the recorder. Times are simulated nanoseconds; payloads are JSON bytes."""

    def channel(self, topic: str, schema_name: str, schema: bytes) -> Any:
        """Declare ``topic`` with its JSON Schema (``schema``, UTF-8 JSON); returns the handle :meth:`write` takes."""

    def write(self, channel: Any, ns: int, data: bytes) -> None:
        """Send one message (JSON bytes) on a declared channel at simulated time ``ns``."""

    def metadata(self, name: str, record: Mapping[str, str]) -> None:
        """Store a named record of strings (run metadata at start, the outcome at close)."""

    def close(self) -> None:
        """Finish: nothing is written after this."""


class McapSink:
    """An MCAP file: JSON messages with JSON Schemas, zstd chunks of ``chunk_size`` bytes, CRCs on every record."""

    def __init__(self, path: str | Path, chunk_size: int = 256 * 1024):
        self.path = Path(path)
        self._schema_ids: dict[str, int] = {}
        self._file = open(self.path, "wb")  # noqa: SIM115 - closed by close()
        self.writer = Writer(self._file, chunk_size=int(chunk_size), compression=CompressionType.ZSTD,
                             enable_data_crcs=True)
        self.writer.start(profile="", library=f"marsupial {marsupial.__version__}")

    def channel(self, topic: str, schema_name: str, schema: bytes) -> int:
        """Register ``topic`` (message encoding ``json``) and its schema (encoding ``jsonschema``, once per name)."""
        schema_id = self._schema_ids.get(schema_name)
        if schema_id is None:
            schema_id = self._schema_ids[schema_name] = self.writer.register_schema(schema_name, "jsonschema", schema)
        return self.writer.register_channel(topic, "json", schema_id)

    def write(self, channel: int, ns: int, data: bytes) -> None:
        """Append one message with ``log_time`` = ``publish_time`` = ``ns``."""
        self.writer.add_message(channel, ns, data, ns)

    def metadata(self, name: str, record: Mapping[str, str]) -> None:
        """An MCAP metadata record."""
        self.writer.add_metadata(name, dict(record))

    def close(self) -> None:
        """Write the summary, indexes and CRCs, and close the file (closed even if finishing fails)."""
        try:
            self.writer.finish()  # type: ignore[no-untyped-call]
        finally:
            self._file.close()
