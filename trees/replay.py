"""Read a run's MCAP log back as Python objects: events, metrics, tree statuses, poses, any topic.

::

    from marsupial.trees.replay import read_log, format_timeline
    log = read_log("run.mcap")
    log.outcome                      # "success"
    log.events[0]                    # {"t": 0.0, "kind": "run_start", ...}
    t, xyz = log.poses("uav")        # numpy arrays (N,), (N, 3)
    print(format_timeline(log))

Times are simulated seconds (the messages' ``log_time`` / 1e9). A file
that is not a complete MCAP (a run killed with SIGKILL, a copy cut short)
raises :class:`LogError` naming the file, never a parser traceback.
"""

from __future__ import annotations

import difflib
import io
import json
import struct
import zlib
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader

from .errors import suggest
from .recorder import EVENT_KINDS, describe_event

__all__ = [
    "LogError",
    "Message",
    "RunLog",
    "TreeSnapshot",
    "compare_events",
    "format_timeline",
    "read_log",
    "read_topics",
]

MCAP_MAGIC = b"\x89MCAP0\r\n"
_FOOTER = struct.Struct("<BQQQI")  # opcode, record length, summary_start, summary_offset_start, summary_crc
_FOOTER_OPCODE = 0x02
_DATA_END = struct.Struct("<BQI")  # opcode, record length, data_section_crc
_DATA_END_OPCODE = 0x0F

#: event fields that describe the machine or the wall clock, not the run: ignored by :func:`compare_events`
VOLATILE_FIELDS = frozenset({"wall_time", "wall_clock", "elapsed_wall", "rtf", "pid", "host"})


class LogError(Exception):
    """A run log that cannot be read (missing, truncated, corrupt) or a name it does not contain."""


@dataclass(frozen=True)
class Message:
    """One decoded message: simulated time ``t`` (s) and its JSON ``data``."""

    t: float
    data: dict[str, Any]


@dataclass
class TreeSnapshot:
    """The tree after one ``/tree`` message.

    Attributes:
        t: simulated time (s).
        event_log: the status changes of this message (``node_name``, ``uid``,
            ``previous_status``, ``current_status``, ``timestamp``).
        statuses: every node's status at ``t`` by uid (IDLE/RUNNING/SUCCESS/FAILURE).
        names: node name by uid.
        xml: the tree's BehaviorTree.CPP XML (``_uid`` attributes are the uids).
    """

    t: float
    event_log: list[dict[str, Any]]
    statuses: dict[int, str]
    names: dict[int, str]
    xml: str

    def status(self, node_name: str) -> str:
        """Status of the node called ``node_name`` (the first in uid order if names repeat)."""
        for uid, name in self.names.items():
            if name == node_name:
                return self.statuses[uid]
        raise LogError(_unknown("tree node", node_name, self.names.values()))


def _unknown(kind: str, name: str, known: Any) -> str:
    known = sorted(set(known))
    close = suggest(name, known)
    hint = f"; did you mean '{close}'?" if close else ""
    return f"unknown {kind} '{name}'{hint} Known: {', '.join(known) or '(none)'}"


def _xml_nodes(xml: str) -> tuple[dict[int, str], dict[int, str]]:
    """(names, IDLE statuses) by ``_uid`` of the nodes in a tree's XML."""
    import xml.etree.ElementTree as ET

    names = {}
    for element in ET.fromstring(xml).iter():
        uid = element.get("_uid")
        if uid is not None:
            names[int(uid)] = element.get("name", element.tag)
    return names, dict.fromkeys(names, "IDLE")


@dataclass
class RunLog:
    """A run log read into memory (see :func:`read_log`).

    Attributes:
        path: the file.
        metadata: the ``marsupial`` metadata record (strings: ``mission``,
            ``mission_name``, ``seed``, ``version``, ``command_line`` …).
        end: the ``outcome`` metadata record written at close (``{}`` if absent).
        events: ``/events`` as dicts ``{"t": s, "kind": ..., **fields}``.
        metrics: ``/metrics`` as dicts ``{"t", "name", "value", "labels"}``.
        tree_snapshots: one :class:`TreeSnapshot` per ``/tree`` message.
        schemas: topic -> schema name.
    """

    path: Path
    metadata: dict[str, str]
    end: dict[str, str]
    events: list[dict[str, Any]]
    metrics: list[dict[str, Any]]
    tree_snapshots: list[TreeSnapshot]
    schemas: dict[str, str]
    _topics: dict[str, list[Message]] = field(repr=False)

    @property
    def outcome(self) -> str | None:
        """How the run ended (``success``, ``failure``, ``interrupted`` …), ``None`` if not recorded."""
        return self.end.get("outcome")

    @property
    def sim_time(self) -> float | None:
        """Simulated time (s) at the end of the run, ``None`` if not recorded."""
        value = self.end.get("sim_time")
        return None if value is None else float(value)

    @property
    def seed(self) -> int | None:
        """The run's seed, ``None`` if not recorded."""
        value = self.metadata.get("seed")
        return None if value in (None, "null") else int(value)

    @property
    def topic_names(self) -> list[str]:
        """Topics present in the file, sorted."""
        return sorted(self.schemas)

    def messages(self, topic: str) -> list[Message]:
        """All messages of ``topic`` in time order; :class:`LogError` names the topics if it is absent."""
        try:
            return self._topics[topic]
        except KeyError:
            raise LogError(f"{self.path}: {_unknown('topic', topic, self.schemas)}") from None

    def poses(self, robot: str, orientation: bool = False, estimate: bool = False) -> tuple[np.ndarray, ...]:
        """``(t, xyz)`` of ``robot``'s base: arrays (N,) s and (N, 3) m.

        By default the TRUE pose in the world frame (``/truth/<robot>/pose``:
        for scoring); with ``estimate=True`` the robot's onboard estimate
        (``/<robot>/pose``, its navigation frame). With ``orientation=True``:
        ``(t, xyz, quaternions)``, quaternions (N, 4) ``[x, y, z, w]``.
        """
        topic = f"/{robot}/pose" if estimate else f"/truth/{robot}/pose"
        if topic not in self._topics:
            robots = [name[7:-5] for name in self.schemas if name.startswith("/truth/") and name.endswith("/pose")]
            raise LogError(f"{self.path}: {_unknown('robot', robot, robots)}")
        messages = self._topics[topic]
        t = np.array([m.t for m in messages])
        xyz = np.array([[m.data["pose"]["position"][k] for k in "xyz"] for m in messages]).reshape(-1, 3)
        if not orientation:
            return t, xyz
        q = np.array([[m.data["pose"]["orientation"][k] for k in "xyzw"] for m in messages]).reshape(-1, 4)
        return t, xyz, q

    def metric(self, name: str, **labels: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(t, values)`` of metric ``name`` whose labels include ``labels`` (NaN where null)."""
        wanted = {k: str(v) for k, v in labels.items()}
        rows = [
            (m["t"], np.nan if m["value"] is None else m["value"])
            for m in self.metrics
            if m["name"] == name and all(m["labels"].get(k) == v for k, v in wanted.items())
        ]
        if not rows and name not in {m["name"] for m in self.metrics}:
            raise LogError(f"{self.path}: {_unknown('metric', name, (m['name'] for m in self.metrics))}")
        t, values = zip(*rows, strict=True) if rows else ((), ())
        return np.array(t, dtype=float), np.array(values, dtype=float)

    def events_of(self, kind: str) -> list[dict[str, Any]]:
        """The events of one ``kind`` (see ``EVENT_KINDS``)."""
        if kind not in EVENT_KINDS:
            raise LogError(_unknown("event kind", kind, EVENT_KINDS))
        return [e for e in self.events if e["kind"] == kind]


def _check_integrity(path: Path, data: bytes) -> None:
    """Magic bytes at both ends, and the summary and data-section CRCs the writer stored.

    (The mcap reader checks chunk CRCs only; these two cover the rest of the file.)
    """
    magic = len(MCAP_MAGIC)
    if data[:magic] != MCAP_MAGIC:
        raise LogError(f"{path}: not an MCAP file (it does not start with the MCAP magic bytes)")
    footer_at = len(data) - magic - _FOOTER.size
    if footer_at < magic or data[-magic:] != MCAP_MAGIC or data[footer_at] != _FOOTER_OPCODE:
        raise LogError(f"{path}: not a complete MCAP file (truncated at byte {len(data)}?)")
    _, _, summary_start, _, summary_crc = _FOOTER.unpack_from(data, footer_at)
    if summary_start == 0 or summary_start > footer_at:
        raise LogError(f"{path}: not a complete MCAP file (no summary section)")
    if summary_crc and zlib.crc32(data[summary_start : footer_at + _FOOTER.size - 4]) != summary_crc:
        raise LogError(f"{path}: corrupt MCAP file (summary CRC mismatch)")
    data_end_at = summary_start - _DATA_END.size
    opcode, length, data_crc = _DATA_END.unpack_from(data, data_end_at)
    if opcode != _DATA_END_OPCODE or length != 4:
        raise LogError(f"{path}: corrupt MCAP file (no data-end record before the summary)")
    if data_crc and zlib.crc32(data[:data_end_at]) != data_crc:
        raise LogError(f"{path}: corrupt MCAP file (data section CRC mismatch)")


def read_log(path: str | Path) -> RunLog:
    """Read a run log written by :class:`~marsupial.trees.recorder.Recorder` (every CRC checked).

    Raises :class:`LogError` if the file is missing, truncated or corrupt.
    """
    path = Path(path)
    if not path.is_file():
        raise LogError(f"{path}: no such log file")
    data = path.read_bytes()
    _check_integrity(path, data)
    topics: dict[str, list[Message]] = {}
    schemas: dict[str, str] = {}
    records: dict[str, dict[str, str]] = {}
    try:
        reader = make_reader(io.BytesIO(data), validate_crcs=True)
        summary = reader.get_summary()
        if summary is None:
            raise LogError(f"{path}: not a complete MCAP file (no summary section)")
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            schemas[channel.topic] = schema.name if schema is not None else ""
            topics.setdefault(channel.topic, []).append(Message(message.log_time / 1e9, json.loads(message.data)))
        for record in reader.iter_metadata():
            records[record.name] = dict(record.metadata)
    except LogError:
        raise
    except Exception as err:  # any parser/CRC/decompression failure is a damaged file
        raise LogError(f"{path}: corrupt MCAP file ({type(err).__name__}: {err})") from None
    for channel in summary.channels.values():  # topics registered but never written
        schemas.setdefault(channel.topic, summary.schemas[channel.schema_id].name if channel.schema_id else "")
        topics.setdefault(channel.topic, [])
    return RunLog(
        path=path,
        metadata=records.get("marsupial", {}),
        end=records.get("outcome", {}),
        events=[{"t": m.t, **m.data} for m in topics.get("/events", [])],
        metrics=[{"t": m.t, **m.data} for m in topics.get("/metrics", [])],
        tree_snapshots=_tree_snapshots(topics),
        schemas=schemas,
        _topics=topics,
    )


def read_topics(path: str | Path, topics: Iterable[str]) -> dict[str, list[Message]]:
    """Only the messages of ``topics`` of a log, by topic in time order (cheaper than :func:`read_log`).

    For a log just written (the end-of-run summary reads ``/events`` and
    ``/metrics`` back); :class:`LogError` if it cannot be read.
    """
    wanted = list(topics)
    found: dict[str, list[Message]] = {topic: [] for topic in wanted}
    try:
        with open(path, "rb") as file:
            for _, channel, message in make_reader(file).iter_messages(topics=wanted):
                found[channel.topic].append(Message(message.log_time / 1e9, json.loads(message.data)))
    except Exception as err:  # a missing, cut or corrupt file
        raise LogError(f"{path}: cannot read {', '.join(wanted)} ({type(err).__name__}: {err})") from None
    return found


def _tree_snapshots(topics: dict[str, list[Message]]) -> list[TreeSnapshot]:
    """Replay ``/tree/xml`` and ``/tree`` in time order into full status snapshots."""
    xml_messages = topics.get("/tree/xml", [])
    snapshots: list[TreeSnapshot] = []
    xml = ""
    names: dict[int, str] = {}
    statuses: dict[int, str] = {}
    i = 0
    for message in topics.get("/tree", []):
        while i < len(xml_messages) and xml_messages[i].t <= message.t:
            xml = xml_messages[i].data["data"]
            names, statuses = _xml_nodes(xml)
            i += 1
        for change in message.data["event_log"]:
            statuses[change["uid"]] = change["current_status"]
            names.setdefault(change["uid"], change["node_name"])
        snapshots.append(TreeSnapshot(message.t, message.data["event_log"], dict(statuses), names, xml))
    return snapshots


def _event_line(event: dict[str, Any]) -> str:
    fields = {k: v for k, v in event.items() if k not in ("t", "kind")}
    return f"{event['t']:10.3f}  {describe_event(event['kind'], fields)}"


def format_timeline(log: RunLog) -> str:
    """The run's events as text, one line per event: sim time (s), kind, ``key=value`` details."""
    lines = [_event_line(e) for e in log.events]
    return "\n".join(lines) + ("\n" if lines else "")


def compare_events(a: RunLog, b: RunLog, ignore: frozenset[str] = VOLATILE_FIELDS) -> list[str]:
    """Differences between two runs' event sequences (``[]`` if identical).

    Events are compared on time (to the nanosecond), kind and every field
    except ``ignore`` (wall-clock and machine fields). Each difference is a
    line ``- <a's event>`` (only in ``a``) or ``+ <b's event>`` (only in
    ``b``), preceded by ``@ event i`` giving its index in ``a``.
    """

    def key(event: dict[str, Any]) -> str:
        kept = {k: v for k, v in event.items() if k not in ignore and k != "t"}
        return json.dumps([round(event["t"] * 1e9), kept], sort_keys=True, default=str)

    keys_a, keys_b = [key(e) for e in a.events], [key(e) for e in b.events]
    out: list[str] = []
    matcher = difflib.SequenceMatcher(a=keys_a, b=keys_b, autojunk=False)
    for op, i1, i2, j1, j2 in matcher.get_opcodes():
        if op == "equal":
            continue
        out.append(f"@ event {i1}")
        out += [f"- {_event_line(e)}" for e in a.events[i1:i2]]
        out += [f"+ {_event_line(e)}" for e in b.events[j1:j2]]
    return out
