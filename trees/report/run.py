"""The report of one run: what its MCAP log holds, as one self-contained HTML page.

Sections: summary and outcome; top-down map (``/scene``, ``/truth/<robot>/pose``
solid, ``/<robot>/pose`` dashed); behaviour-tree timeline (``/tree``, ``/tree/xml``;
preemptions from ``/events``); events and operator commands; metric plots
(``/metrics``) and final values; recorded camera frames; the mission text.
Everything taken from the log is escaped (jinja2 autoescape; SVG text is
escaped by matplotlib). Times are simulated seconds, positions metres.
"""

from __future__ import annotations

import base64
import binascii
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .. import metrics
from ..metrics import MetricSpec
from ..milestones import story, tell
from ..recorder import IMAGE_SCHEMA, describe_event
from ..replay import RunLog, TreeSnapshot
from ..summary import OUTCOME_MEANINGS
from . import plots

__all__ = ["IMAGES_PER_CAMERA", "MAX_EVENT_ROWS", "phase_rows", "run_context", "tree_rows"]

MAX_EVENT_ROWS = 2000  # events listed in the table (a note says how many more there were)
IMAGES_PER_CAMERA = 6  # frames shown per camera, evenly spread over the run
_EVENT_CLASSES = {"error": "error", "preemption": "warning", "operator": "operator",
                  "unintended_contact": "error", "rim_contact": "error", "run_end": "end", "outcome": "outcome"}


def _depths(xml: str) -> dict[int, int]:
    """Depth (0 = root) of every node of a tree's BehaviorTree.CPP XML, by ``_uid``."""
    depths: dict[int, int] = {}

    def visit(element: ET.Element, depth: int) -> None:
        uid = element.get("_uid")
        if uid is not None:
            depths[int(uid)] = depth
        for child in element:
            visit(child, depth + (uid is not None))

    visit(ET.fromstring(xml), 0)
    return depths


def _guards(xml: str) -> tuple[set[int], dict[int, int]]:
    """(uids of the condition nodes, {uid of a node whose first child is a condition: that condition's uid}).

    Conditions are the nodes the XML's ``TreeNodesModel`` declares as ``Condition``; a guarded branch
    (``when: … do: …``) is a sequence whose first child is its guard.
    """
    root = ET.fromstring(xml)
    kinds = {node.get("ID") for model in root.iter("TreeNodesModel") for node in model if node.tag == "Condition"}
    conditions = {int(e.get("_uid", 0)) for e in root.iter() if e.tag in kinds and e.get("_uid") is not None}
    guarded = {}
    for element in root.iter():
        children = [child for child in element if child.get("_uid") is not None]
        if element.get("_uid") is not None and children and int(children[0].get("_uid", 0)) in conditions:
            guarded[int(element.get("_uid", 0))] = int(children[0].get("_uid", 0))
    return conditions, guarded


def _state(uid: int, snapshot: TreeSnapshot, conditions: set[int], guarded: dict[int, int]) -> str:
    """How the timeline shows node ``uid`` in ``snapshot``: its status, or HOLDS / NOT_HOLDING for a guard.

    A condition that does not hold, and a guarded branch that failed only because its guard did not hold,
    are NOT_HOLDING (drawn neutral): nothing went wrong.
    """
    status = snapshot.statuses.get(uid, "IDLE")
    if uid in conditions:
        return {"SUCCESS": "HOLDS", "FAILURE": "NOT_HOLDING"}.get(status, status)
    if status == "FAILURE" and uid in guarded and snapshot.statuses.get(guarded[uid]) == "FAILURE":
        return "NOT_HOLDING"
    return status


def tree_rows(snapshots: list[TreeSnapshot], end: float) -> list[dict[str, Any]]:
    """One row per tree node (uid order): ``{"uid", "name", "depth", "guard", "intervals": [(start, end, state)]}``.

    A node's interval runs from the snapshot where its state became RUNNING,
    SUCCESS, FAILURE, HOLDS or NOT_HOLDING (guards, :func:`_state`) to the one
    where it changed again (or ``end``, s); IDLE spans are left out. A state
    reached at the last tick (the root's final SUCCESS) is an interval of
    length 0 at ``end``. ``guard``: whether the node is a condition.
    """
    if not snapshots:
        return []
    depths = _depths(snapshots[0].xml)
    conditions, guarded = _guards(snapshots[0].xml)
    names = snapshots[-1].names
    rows = []
    for uid in sorted(names):
        intervals, current, since = [], "IDLE", 0.0
        for snapshot in snapshots:
            state = _state(uid, snapshot, conditions, guarded)
            if state != current:
                if current != "IDLE":
                    intervals.append((since, snapshot.t, current))
                current, since = state, snapshot.t
        if current != "IDLE":
            intervals.append((since, max(end, since), current))
        rows.append({"uid": uid, "name": names[uid], "depth": depths.get(uid, 0), "guard": uid in conditions,
                     "intervals": intervals})
    return rows


def phase_rows(events: list[dict[str, Any]], end: float) -> list[dict[str, Any]]:
    """The phases skills report (``state_change`` events with a ``phase`` or ``state``), one row per node.

    ``{"name", "intervals": [(start s, end s, phase)]}``: a phase lasts until
    the node's next phase, its ``outcome`` event, or ``end`` (s).
    """
    rows: dict[str, list[list[Any]]] = {}
    for event in events:
        node = event.get("node")
        if node is None:
            continue
        phase = event.get("phase", event.get("state")) if event["kind"] == "state_change" else None
        spans = rows.get(node)
        if spans and spans[-1][1] is None and (phase is not None or event["kind"] == "outcome"):
            spans[-1][1] = event["t"]
        if phase is not None:
            rows.setdefault(node, []).append([event["t"], None, str(phase)])
    return [{"name": node, "intervals": [(a, end if b is None else b, phase) for a, b, phase in spans]}
            for node, spans in rows.items()]


def _description(mission_text: str) -> str:
    try:
        data = yaml.safe_load(mission_text)
    except yaml.YAMLError:
        return ""
    return " ".join(str(data.get("description", "")).split()) if isinstance(data, dict) else ""


def _metrics(log: RunLog) -> tuple[dict[str, dict[str, tuple[np.ndarray, np.ndarray]]], list[dict[str, Any]],
                                   dict[str, MetricSpec | None]]:
    """(series of the metrics with two samples or more, by name then label text; one row per metric and label
    set with the value its aggregation gives, unit and meaning; the declarations, by name)."""
    grouped = metrics.group_samples(log.metrics)
    order = sorted(grouped, key=lambda name: (not name.startswith("battery"), name))
    specs = {name: metrics.spec(name) for name in order}
    series, rows = {}, []
    for name in order:
        lines, spec = grouped[name], specs[name]
        for labels, samples in lines.items():
            rows.append({"name": name, "labels": labels, "value": metrics.summarize(spec, [v for _, v in samples]),
                         "meaning": spec.meaning if spec else "not declared in the metric registry",
                         "aggregation": spec.aggregation if spec else "", "t": samples[-1][0],
                         "samples": len(samples)})
        if max(len(samples) for samples in lines.values()) >= 2:
            series[name] = {labels: (np.array([t for t, _ in s]), np.array([v for _, v in s]))
                            for labels, s in lines.items()}
    return series, rows, specs


def _images(log: RunLog) -> list[dict[str, Any]]:
    """Up to :data:`IMAGES_PER_CAMERA` frames per camera topic as ``data:`` URLs (checked base64 only)."""
    frames = []
    for topic in log.topic_names:
        if log.schemas.get(topic) != IMAGE_SCHEMA:
            continue
        messages = log.messages(topic)
        picks = sorted({round(i) for i in np.linspace(0, len(messages) - 1, IMAGES_PER_CAMERA)}) if messages else []
        for i in picks:
            data = messages[i].data
            kind = "png" if data.get("format") == "png" else "jpeg"
            try:
                base64.b64decode(str(data.get("data", "")), validate=True)
            except (binascii.Error, ValueError):
                continue
            frames.append({"topic": topic, "t": messages[i].t, "src": f"data:image/{kind};base64,{data['data']}"})
    return frames


def _event_rows(log: RunLog) -> list[dict[str, Any]]:
    rows = []
    for event in log.events[:MAX_EVENT_ROWS]:
        fields = {k: v for k, v in event.items() if k not in ("t", "kind")}
        text = describe_event(event["kind"], fields)[len(event["kind"]):].strip()
        rows.append({"t": event["t"], "kind": event["kind"], "text": text,
                     "class": _EVENT_CLASSES.get(event["kind"], "")})
    return rows


def run_context(log: RunLog, links: Mapping[str, str] | None = None) -> dict[str, Any]:
    """Everything the run template shows, from a read log (``links``: extra ``{text: href}`` in the header)."""
    meta = log.metadata
    end = log.sim_time if log.sim_time is not None else max((e["t"] for e in log.events), default=0.0)
    robots = sorted(name[len("/truth/"):-len("/pose")] for name in log.schemas
                    if name.startswith("/truth/") and name.endswith("/pose"))
    paths = {}
    for robot in robots:
        tracks = {"truth": log.poses(robot)[1]}
        if f"/{robot}/pose" in log.schemas:
            tracks["estimate"] = log.poses(robot, estimate=True)[1]
        paths[robot] = tracks
    scene = log.messages("/scene")[0].data if log.schemas.get("/scene") and log.messages("/scene") else None
    rows = tree_rows(log.tree_snapshots, end)
    row_of: dict[str, int] = {}
    for index, row in enumerate(rows):
        row_of.setdefault(row["name"], index)
    preemptions = [{"t": e["t"], "row": row_of.get(e["preempted"]), "event": e} for e in log.events_of("preemption")]
    operator = [{"t": e["t"], "command": e["command"]} for e in log.events_of("operator")]
    series, metric_rows, specs = _metrics(log)
    phases = phase_rows(log.events, end)
    run_end: dict[str, Any] = next((e for e in reversed(log.events) if e["kind"] == "run_end"), {})
    errors = [e for e in log.events if e["kind"] == "error"]
    estimate_errors = {}
    for robot, tracks in paths.items():
        if "estimate" in tracks and len(tracks["estimate"]) == len(tracks["truth"]) and len(tracks["truth"]):
            gap = np.linalg.norm(tracks["estimate"] - tracks["truth"], axis=1)
            worst = int(np.argmax(gap))
            estimate_errors[robot] = {"final": float(gap[-1]), "max": float(gap[worst]),
                                      "max_t": float(log.poses(robot)[0][worst])}
    told = story(log.events)
    return {
        "title": f"{meta.get('mission_name', '?')} — marsupial run report",
        "mission": meta.get("mission_name", "?"),
        "description": _description(meta.get("mission", "")),
        "outcome": log.outcome or "unknown",
        "success": log.outcome == "success",
        "seed": meta.get("seed", "?"),
        "sim_time": end,
        "ticks": run_end.get("ticks"),
        "version": meta.get("version", "?"),
        "command_line": meta.get("command_line", ""),
        "overrides": meta.get("overrides", "{}"),
        "log_name": Path(log.path).name,
        "errors": errors,
        "robots": robots,
        "outcome_meaning": OUTCOME_MEANINGS.get(log.outcome or "", ""),
        "milestones": {robot: tell(items, limit=len(items)) for robot, items in told.items()},
        "estimate_errors": estimate_errors,
        "map_svg": plots.map_svg(scene, paths),
        "timeline_svg": plots.timeline_svg(rows, end, preemptions, operator, log.outcome) if rows else None,
        "phases_svg": plots.phases_svg(phases, end) if phases else None,
        "nodes": rows,
        "preemptions": preemptions,
        "operator": log.events_of("operator"),
        "events": _event_rows(log),
        "events_left_out": max(0, len(log.events) - MAX_EVENT_ROWS),
        "metric_svgs": plots.metric_svgs(series, end, specs),
        "metric_rows": metric_rows,
        "images": _images(log),
        "mission_text": meta.get("mission", ""),
        "links": dict(links or {}),
        "status_colours": plots.STATUS_COLOURS,
        "status_labels": plots.STATUS_LABELS,
    }
