"""The run recorder: one MCAP file per run and/or a live Foxglove server, JSON messages with JSON Schemas.

Channels (see ``docs/logs.md`` for every field):

=======================  =================================  ==============================================
topic                    schema                             what
=======================  =================================  ==============================================
``/events``              ``marsupial.Event``                run_start, state_change, preemption, operator,
                                                            outcome, run_end, error, milestone,
                                                            unintended_contact, rim_contact
``/metrics``             ``marsupial.Metric``               ``{name, value, labels}``
``/log``                 ``foxglove.Log``                   one text line per event, plus free text
``/tf``                  ``foxglove.FrameTransform``        ``world`` -> ``<robot>`` per robot (true pose)
``/truth/<robot>/pose``  ``foxglove.PoseInFrame``           robot base pose in ``world`` (simulator truth)
``/<robot>/pose``        ``foxglove.PoseInFrame``           the robot's onboard estimate (its navigation
                                                            frame, which starts at ``world``)
``/scene``               ``foxglove.SceneUpdate``           static scene geometry, once at start
``/<camera>/image``      ``foxglove.CompressedImage``       opt-in camera frames (png/jpeg)
``/tree``                ``nav2_msgs/msg/BehaviorTreeLog``  tree status changes (``event_log``), on change
``/tree/xml``            ``std_msgs/msg/String``            the tree as BehaviorTree.CPP XML (``data``)
=======================  =================================  ==============================================

The ``/tree`` pair follows what the community's Foxglove behaviour-tree panel
reads (a ``data`` string of XML on one topic, ``nav2_msgs`` ``event_log``
entries on another, both JSON-encoded here; the schema names are the ones
its topic pickers list). Node uids in ``event_log`` are the ``_uid``
attributes of the XML (:mod:`marsupial.trees.btxml`). A change is found by
comparing every node's status with the previous snapshot, in uid order — the
comparison py_trees' ``SnapshotVisitor`` makes, but over the whole tree, so
nodes halted without being ticked (a preempted skill going IDLE) are seen,
and on plain lists, about five times cheaper than its uuid-keyed dicts.

Time: every ``t`` argument is SIMULATED seconds; it becomes the message's
``log_time``/``publish_time`` in nanoseconds and must not decrease.
The file's metadata record ``marsupial`` holds the mission text and name,
seed, package version and command line; a second record ``outcome`` is
written at close.

The file is a complete MCAP (summary, indexes, CRCs) however the run ends:
:meth:`Recorder.close`, an exception inside ``with Recorder(...)``, Ctrl-C
or SIGTERM (after :meth:`Recorder.install_signal_handlers`), or an
interpreter exit that skipped the close. Only a hard kill (SIGKILL) leaves
a truncated file, which loses at most the chunk in progress (``chunk_size``).

Every message is built and encoded once and handed to each sink
(:mod:`marsupial.trees.sinks`): the MCAP file of ``path``, and any others
given, e.g. the live server of :mod:`marsupial.trees.live`.
"""

from __future__ import annotations

import atexit
import base64
import json
import re
import shlex
import signal
import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from importlib.resources import files
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

import marsupial

from .errors import suggest
from .exchange_log import SCHEMA as EXCHANGE_SCHEMA
from .exchange_log import TOPIC as EXCHANGE_TOPIC
from .messages import (
    WORLD_FRAME,
    encode,
    foxglove_time,
    json_default,
    ns_of,
    scene_update,
    xyz,
    xyzw,
)
from .sinks import McapSink, Sink

if TYPE_CHECKING:
    from marsupial.api.ticks import TreeStatus
    from marsupial.world.world import World

__all__ = [
    "CHANNEL_SCHEMAS",
    "EVENT_KINDS",
    "LOG_LEVELS",
    "SCHEMAS",
    "Recorder",
    "Terminated",
    "describe_event",
]

# ---------------------------------------------------------------- schemas
#: schema name -> JSON Schema, for every schema the recorder writes (``trees/schemas.json``: the Foxglove
#: well-known types with Foxglove's published names and field names, only the fields used here, and ours)
SCHEMAS: dict[str, dict[str, Any]] = json.loads(files("marsupial.trees").joinpath("schemas.json").read_text())
_LEVEL_NAMES = tuple(level["title"] for level in SCHEMAS["foxglove.Log"]["properties"]["level"]["oneOf"])

#: event kind -> fields every event of that kind must carry (more are allowed)
EVENT_KINDS: dict[str, tuple[str, ...]] = {
    "run_start": (),
    "state_change": (),
    "preemption": ("preempted", "by", "why", "robot"),
    "operator": ("command", "source"),
    "outcome": ("node", "skill", "robot", "status", "message"),
    "run_end": ("outcome", "sim_time"),
    "error": ("message",),
    "milestone": ("robot", "what"),  # a result a skill reached (marsupial.trees.milestones)
    "unintended_contact": ("uav", "carrier", "uav_link", "carrier_link"),  # the referee (marsupial.world.scoring)
    "rim_contact": ("carrier", "part", "wall"),  # the referee (marsupial.world.rim_contacts)
}

#: fixed topic -> schema name (per-robot poses and camera images are added as they appear)
CHANNEL_SCHEMAS: dict[str, str] = {
    "/events": "marsupial.Event",
    "/metrics": "marsupial.Metric",
    "/log": "foxglove.Log",
    "/tf": "foxglove.FrameTransform",
    "/scene": "foxglove.SceneUpdate",
    "/tree": "nav2_msgs/msg/BehaviorTreeLog",
    "/tree/xml": "std_msgs/msg/String",
}
POSE_SCHEMA = "foxglove.PoseInFrame"  # /<robot>/pose
IMAGE_SCHEMA = "foxglove.CompressedImage"  # /<camera>/image

#: foxglove.Log level names (any case) -> enum value
LOG_LEVELS: dict[str, int] = {name.lower(): value for value, name in enumerate(_LEVEL_NAMES)}
_EVENT_LEVELS = {"error": LOG_LEVELS["error"], "preemption": LOG_LEVELS["warning"]}

SIGTERM_EXIT_CODE = 128 + signal.SIGTERM  # what a shell reports for a process ended by SIGTERM


class Terminated(SystemExit):
    """Raised in the main thread when SIGTERM arrives (after the recorder has been closed)."""

    def __init__(self) -> None:
        super().__init__(SIGTERM_EXIT_CODE)


_BARE = re.compile(r"[^\s\"'=]+")  # strings printed without quotes in event text


def _field_text(value: Any) -> str:
    """One field value as timeline text: bare words stay bare, other strings are quoted."""
    if isinstance(value, str):
        return value if _BARE.fullmatch(value) else json.dumps(value, ensure_ascii=False)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return repr(value)
    return json.dumps(value, separators=(",", ":"), default=json_default, sort_keys=True)


def describe_event(kind: str, fields: Mapping[str, Any]) -> str:
    """One-line text of an event: ``kind`` then ``key=value`` (required fields first, then the rest)."""
    required = EVENT_KINDS.get(kind, ())
    keys = [k for k in required if k in fields] + [k for k in fields if k not in required]
    return " ".join([kind] + [f"{k}={_field_text(fields[k])}" for k in keys])


def _metadata_text(value: Any) -> str:
    return value if isinstance(value, str) else json.dumps(value, default=json_default)


class _TreeTrack:
    """The tree the recorder follows: its nodes' names in uid order, and their statuses at the last snapshot."""

    def __init__(self, names: tuple[str, ...]):
        self.names = names
        self.statuses: tuple[str, ...] = ("IDLE",) * len(names)


# ---------------------------------------------------------------- recorder
class Recorder:
    """Writes one run to an MCAP file (JSON messages, JSON Schemas; times are SIM seconds).

    Use it as a context manager so the file is finalised whatever happens::

        with Recorder("run.mcap", {"mission": text, "mission_name": "landing", "seed": 7}) as rec:
            rec.install_signal_handlers()
            rec.log_scene(world)
            rec.log_event(0.0, "run_start", mission="landing", seed=7)
            ...
            rec.log_event(t, "run_end", outcome="success", sim_time=t)
        # closed here: outcome taken from run_end, or "error"/"interrupted"/"terminated"

    Args:
        path: the ``.mcap`` file to write (replaced if it exists); ``None``: no file (``sinks`` only).
        metadata: run metadata (``mission`` text, ``mission_name``, ``seed``,
            ``command_line`` …); ``version`` (package version) and
            ``command_line`` (``sys.argv``) are filled in when absent. Values
            that are not strings are stored as JSON text.
        record_images: write :meth:`log_image` frames (off: calls return at once).
        chunk_size: uncompressed bytes per zstd chunk; a chunk reaches the disk
            when full, so this bounds what a hard kill can lose.
        sinks: more outputs for the same messages (:class:`~marsupial.trees.sinks.Sink`),
            e.g. a :class:`~marsupial.trees.live.LiveSink`; closed with the recorder.

    After :meth:`close`, further log calls are ignored (a run ended by a
    signal may still unwind through code that logs).
    """

    def __init__(
        self,
        path: str | Path | None,
        metadata: Mapping[str, Any] | None = None,
        *,
        record_images: bool = False,
        chunk_size: int = 256 * 1024,
        sinks: Sequence[Sink] = (),
    ):
        self.path = Path(path) if path is not None else None
        self.record_images = bool(record_images)
        self.t = 0.0  # sim time (s) of the latest message
        #: the run's clock (sim s); when set, the closing ``run_end`` and ``outcome`` carry the time the run reached
        self.time_source: Callable[[], float] | None = None
        self._last_ns = 0
        self._channels: dict[str, list[Any]] = {}  # topic -> one channel handle per sink
        self._tree: _TreeTrack | None = None
        self._run_end: dict[str, Any] | None = None
        self._closing = False
        self._closed = False
        self._busy = False
        self._pending: int | None = None  # signal number received during a write
        self._saved_handlers: dict[int, Any] = {}

        info = {"version": marsupial.__version__, "command_line": shlex.join(sys.argv)}
        info.update(metadata or {})
        self._sinks: list[Sink] = ([McapSink(self.path, chunk_size)] if self.path is not None else []) + list(sinks)
        for sink in self._sinks:
            sink.metadata("marsupial", {str(k): _metadata_text(v) for k, v in info.items()})
        atexit.register(self._close_at_exit)

    # ------------------------------------------------------------ lifecycle
    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: Any) -> None:
        if exc_type is None:
            self.close()
        elif issubclass(exc_type, Terminated):
            self.close("terminated")
        elif issubclass(exc_type, KeyboardInterrupt):
            self.close("interrupted")
        elif issubclass(exc_type, SystemExit):
            self.close("exited")
        else:
            if not self._closed:
                self.log_event(self.t, "error", message=f"{exc_type.__name__}: {exc}")
            self.close("error")

    @property
    def closed(self) -> bool:
        """True once the file has been finalised."""
        return self._closed

    def close(self, outcome: str | None = None, **details: Any) -> None:
        """Finalise the file: a ``run_end`` event (unless one was logged), the ``outcome`` metadata, the summary.

        Args:
            outcome: how the run ended (``success``, ``failure``, ``aborted`` …);
                default: the ``run_end`` event's outcome, else ``"unknown"``.
            details: more ``key=value`` pairs for the ``outcome`` metadata record.

        Safe to call more than once; signals arriving meanwhile are held until it is done.
        """
        if self._closed or self._closing:
            return
        self._closing = True
        try:
            if outcome is None:
                outcome = str(self._run_end["outcome"]) if self._run_end else "unknown"
            if self.time_source is not None:
                self.t = max(self.t, float(self.time_source()))
            if self._run_end is None:
                self._write_event(self.t, "run_end", {"outcome": outcome, "sim_time": self.t})
            record = {"outcome": outcome, "sim_time": self.t, **details}
            for sink in self._sinks:
                sink.metadata("outcome", {str(k): _metadata_text(v) for k, v in record.items()})
        finally:
            try:
                for sink in self._sinks:
                    sink.close()
            finally:
                self._closed = True
            atexit.unregister(self._close_at_exit)
            self._restore_signal_handlers()
        if self._pending is not None:  # a signal came in during a normal close: act on it now
            raise self._signal_exception(self._pending)

    def _close_at_exit(self) -> None:
        self.close("incomplete")

    # ------------------------------------------------------------ signals
    def install_signal_handlers(self) -> bool:
        """Make SIGINT and SIGTERM close this file cleanly, then end the program.

        SIGINT raises ``KeyboardInterrupt`` and SIGTERM :class:`Terminated`
        (a ``SystemExit`` with code 143) after the file has been closed with
        outcome ``interrupted``/``terminated``. A signal that arrives while a
        message is being written waits until that write is complete; one that
        arrives during the close waits until the close is done. The previous
        handlers come back at close. Returns False (and does nothing) when
        not called from the main thread, where Python cannot take signals.
        """
        if threading.current_thread() is not threading.main_thread():
            return False
        for signum in (signal.SIGINT, signal.SIGTERM):
            if signum not in self._saved_handlers:
                self._saved_handlers[signum] = signal.signal(signum, self._on_signal)
        return True

    def _restore_signal_handlers(self) -> None:
        if self._saved_handlers and threading.current_thread() is threading.main_thread():
            for signum, handler in self._saved_handlers.items():
                signal.signal(signum, handler)
            self._saved_handlers.clear()

    @staticmethod
    def _signal_exception(signum: int) -> BaseException:
        return Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()

    @staticmethod
    def _signal_outcome(signum: int) -> str:
        return "terminated" if signum == signal.SIGTERM else "interrupted"

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        if self._closing or self._busy:
            if self._pending is None:
                self._pending = signum
            return
        self.close(self._signal_outcome(signum))
        raise self._signal_exception(signum)

    def _after_write(self) -> None:
        signum, self._pending = self._pending, None
        self.close(self._signal_outcome(signum))  # type: ignore[arg-type]
        raise self._signal_exception(signum)  # type: ignore[arg-type]

    # ------------------------------------------------------------ writing
    def _channel(self, topic: str, schema_name: str) -> list[Any]:
        channels = self._channels.get(topic)
        if channels is None:
            schema = json.dumps(SCHEMAS[schema_name], separators=(",", ":")).encode()
            channels = self._channels[topic] = [sink.channel(topic, schema_name, schema) for sink in self._sinks]
        return channels

    def _write(self, topic: str, schema_name: str, ns: int, payload: dict[str, Any]) -> None:
        """Send one message to every sink; ``ns`` must not be earlier than the previous message's."""
        data = encode(payload)
        self._busy = True
        try:
            for sink, channel in zip(self._sinks, self._channel(topic, schema_name), strict=True):
                sink.write(channel, ns, data)
        finally:
            self._busy = False
        if self._pending is not None and not self._closing:
            self._after_write()

    def _time(self, t: float, what: str) -> int | None:
        """``t`` in ns, checked to be >= 0 and not earlier than the last message; ``None`` once closed."""
        if self._closed:
            return None
        ns = ns_of(t)
        if ns < 0:
            raise ValueError(f"{what} at t={t!r} s: simulated time starts at 0")
        if ns < self._last_ns:
            raise ValueError(
                f"{what} at t={t!r} s is earlier than the last logged message (t={self.t!r} s); "
                "log in non-decreasing simulated time"
            )
        self._last_ns, self.t = ns, float(t)
        return ns

    def _write_event(self, t: float, kind: str, fields: dict[str, Any]) -> None:
        ns = self._time(t, f"event {kind!r}")
        if ns is None:
            return
        if kind == "run_end":
            self._run_end = fields
        self._write("/events", "marsupial.Event", ns, {"kind": kind, **fields})
        self._write_log(ns, _EVENT_LEVELS.get(kind, LOG_LEVELS["info"]), describe_event(kind, fields), "events")

    def _write_log(self, ns: int, level: int, message: str, name: str) -> None:
        self._write(
            "/log",
            "foxglove.Log",
            ns,
            {"timestamp": foxglove_time(ns), "level": level, "message": message, "name": name},
        )

    # ------------------------------------------------------------ public logging
    def log_event(self, t: float, kind: str, **fields: Any) -> None:
        """Record a run event on ``/events`` (and its text on ``/log``).

        ``kind`` is one of :data:`EVENT_KINDS`; each kind requires its fields
        (``preemption``: preempted, by, why, robot; ``operator``: command,
        source; ``outcome``: node, skill, robot, status, message; ``run_end``:
        outcome, sim_time; ``error``: message; ``unintended_contact``: uav,
        carrier, uav_link, carrier_link; ``rim_contact``: carrier, part, wall) and may carry more.
        ``t`` is simulated seconds.
        """
        required = EVENT_KINDS.get(kind)
        if required is None:
            close = suggest(kind, EVENT_KINDS)
            hint = f"; did you mean '{close}'?" if close else ""
            raise ValueError(f"unknown event kind '{kind}'; expected one of {', '.join(EVENT_KINDS)}{hint}")
        missing = [f for f in required if f not in fields]
        if missing:
            raise ValueError(
                f"event '{kind}' needs the field(s) {', '.join(missing)}; got {', '.join(fields) or 'none'}"
            )
        self._write_event(t, kind, fields)

    def log_metric(self, t: float, name: str, value: float, **labels: Any) -> None:
        """Record a scalar ``value`` (SI units) called ``name`` on ``/metrics``; labels become strings."""
        ns = self._time(t, f"metric {name!r}")
        if ns is not None:
            payload = {"name": name, "value": float(value), "labels": {k: str(v) for k, v in labels.items()}}
            self._write("/metrics", "marsupial.Metric", ns, payload)

    def log_exchange(self, t: float, kind: str, tick: int, data: str) -> None:
        """One message of the tick exchange on ``/replay`` (``--record-inputs``; :mod:`.exchange_log`)."""
        ns = self._time(t, "replay record")
        if ns is not None:
            self._write(EXCHANGE_TOPIC, EXCHANGE_SCHEMA, ns, {"kind": kind, "tick": tick, "data": data})

    def log_text(self, t: float, level: str | int, message: str, name: str = "marsupial") -> None:
        """A free text line on ``/log`` (foxglove.Log); ``level`` is debug/info/warning/error/fatal or its number."""
        if isinstance(level, str):
            if level.lower() not in LOG_LEVELS:
                raise ValueError(f"unknown log level '{level}'; expected one of {', '.join(LOG_LEVELS)}")
            level = LOG_LEVELS[level.lower()]
        elif not 0 <= int(level) < len(_LEVEL_NAMES):
            raise ValueError(f"log level must be 0..{len(_LEVEL_NAMES) - 1}, got {level}")
        ns = self._time(t, "log line")
        if ns is not None:
            self._write_log(ns, int(level), str(message), name)

    def log_robot_poses(
        self,
        t: float,
        poses: Mapping[str, tuple[Sequence[float], Sequence[float]]],
        estimates: Mapping[str, tuple[Sequence[float], Sequence[float]]] | None = None,
    ) -> None:
        """True base poses in the world frame and onboard estimates: ``{name: (position m, quaternion [x, y, z, w])}``.

        Each robot gets a ``/tf`` transform ``world`` -> ``<name>`` and a
        ``/truth/<name>/pose`` PoseInFrame from ``poses`` (simulator truth),
        and a ``/<name>/pose`` PoseInFrame from ``estimates`` (what the robot
        believes, in its navigation frame, which starts at ``world``), so any
        log shows the estimation error.
        """
        ns = self._time(t, "robot poses")
        if ns is None:
            return
        stamp = foxglove_time(ns)
        for name, (position, quaternion) in (estimates or {}).items():
            self._write(
                f"/{name}/pose",
                POSE_SCHEMA,
                ns,
                {
                    "timestamp": stamp,
                    "frame_id": WORLD_FRAME,
                    "pose": {"position": xyz(position), "orientation": xyzw(quaternion)},
                },
            )
        for name, (position, quaternion) in poses.items():
            translation, rotation = xyz(position), xyzw(quaternion)
            self._write(
                "/tf",
                "foxglove.FrameTransform",
                ns,
                {
                    "timestamp": stamp,
                    "parent_frame_id": WORLD_FRAME,
                    "child_frame_id": name,
                    "translation": translation,
                    "rotation": rotation,
                },
            )
            self._write(
                f"/truth/{name}/pose",
                POSE_SCHEMA,
                ns,
                {
                    "timestamp": stamp,
                    "frame_id": WORLD_FRAME,
                    "pose": {"position": translation, "orientation": rotation},
                },
            )

    def log_tree(self, t: float, tree: TreeStatus) -> bool:
        """Snapshot the tree's statuses on ``/tree`` if any changed since the last call (call after each tick).

        ``tree`` comes from the tree side (:class:`~marsupial.api.ticks.TreeStatus`).
        The first call, and any call after the tree's structure changed
        (``tree.xml`` given), also writes the tree as BehaviorTree.CPP XML on
        ``/tree/xml``. Each ``/tree`` message lists the nodes whose status
        changed (``event_log``, in uid order), statuses as
        IDLE/RUNNING/SUCCESS/FAILURE; halted and preempted nodes show up as
        going to IDLE. Returns whether a snapshot was written.
        """
        if self._closed:
            return False
        track = self._tree
        fresh = tree.xml is not None or track is None
        if fresh:
            track = _TreeTrack(tree.names or tuple(f"node_{i}" for i in range(1, len(tree.statuses) + 1)))
        assert track is not None
        if not fresh and tree.statuses == track.statuses:
            return False
        ns = self._time(t, "tree snapshot")
        if ns is None:
            return False
        if fresh:
            self._tree = track
            if tree.xml is not None:
                self._write("/tree/xml", "std_msgs/msg/String", ns, {"data": tree.xml})
        stamp = foxglove_time(ns)
        changes = [
            {
                "timestamp": stamp,
                "node_name": name,
                "uid": uid,
                "previous_status": before,
                "current_status": now,
            }
            for uid, (name, before, now) in enumerate(zip(track.names, track.statuses, tree.statuses, strict=True),
                                                      start=1)
            if before != now
        ]
        track.statuses = tree.statuses
        self._write("/tree", "nav2_msgs/msg/BehaviorTreeLog", ns, {"timestamp": stamp, "event_log": changes})
        return True

    def log_scene(self, world: World, t: float = 0.0) -> None:
        """The world's static scene on ``/scene`` (one SceneUpdate, :func:`~marsupial.trees.messages.scene_update`)."""
        ns = self._time(t, "scene")
        if ns is not None:
            self._write("/scene", "foxglove.SceneUpdate", ns, scene_update(world, foxglove_time(ns)))

    def log_image(
        self,
        t: float,
        camera: str,
        rgb: Any,
        format: str = "jpeg",
        frame_id: str | None = None,
        stamp: float | None = None,
        jpeg_quality: int = 90,
    ) -> bool:
        """An RGB frame (H x W x 3 uint8, or H x W grey) on ``/<camera>/image`` if images are recorded.

        Args:
            t: simulated time of the write (s).
            camera: sensor name, e.g. ``"uav/camera"`` -> topic ``/uav/camera/image``.
            rgb: the image, RGB channel order.
            format: ``"jpeg"`` or ``"png"``.
            frame_id: optical frame name (default: ``camera``).
            stamp: time the frame was taken (s; default ``t``), the message's ``timestamp``.
            jpeg_quality: 0..100 for jpeg.

        Returns whether the frame was written (False when ``record_images`` is off).
        """
        if not self.record_images or self._closed:
            return False
        import cv2
        import numpy as np

        if format not in ("jpeg", "png"):
            raise ValueError(f"image format must be 'jpeg' or 'png', got {format!r}")
        image = np.asarray(rgb)
        if image.dtype != np.uint8 or not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
            raise ValueError(f"expected an H x W x 3 (RGB) or H x W uint8 image, got {image.dtype} {image.shape}")
        bgr = image[..., ::-1] if image.ndim == 3 else image
        params = [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)] if format == "jpeg" else []
        ok, encoded = cv2.imencode(".jpg" if format == "jpeg" else ".png", np.ascontiguousarray(bgr), params)
        if not ok:
            raise ValueError(f"OpenCV could not encode a {image.shape} image as {format}")
        ns = self._time(t, f"image of {camera}")
        if ns is None:
            return False
        payload = {
            "timestamp": foxglove_time(ns_of(t if stamp is None else stamp)),
            "frame_id": frame_id or camera,
            "data": base64.b64encode(encoded.tobytes()).decode("ascii"),
            "format": format,
        }
        self._write(f"/{camera.strip('/')}/image", IMAGE_SCHEMA, ns, payload)
        return True
