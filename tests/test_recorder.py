"""MCAP run recorder: every channel round-trips, Foxglove schema names, /tree on change, valid file on any ending."""

import base64
import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET

import cv2
import numpy as np
import py_trees
import pybullet
import pytest
from mcap.reader import make_reader
from py_trees.common import Status

import marsupial
from marsupial.trees.btxml import TreeTracker
from marsupial.trees.recorder import CHANNEL_SCHEMAS, EVENT_KINDS, SCHEMAS, Recorder
from marsupial.trees.replay import LogError, read_log
from marsupial.world import World
from marsupial.world.scene import SceneObject

FOXGLOVE_TOPICS = {
    "/tf": "foxglove.FrameTransform",
    "/uav/pose": "foxglove.PoseInFrame",
    "/truth/uav/pose": "foxglove.PoseInFrame",
    "/scene": "foxglove.SceneUpdate",
    "/uav/camera/image": "foxglove.CompressedImage",
    "/log": "foxglove.Log",
}


def read_valid(path):
    """Read ``path`` with CRC checks, summary included; return (summary, messages)."""
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None
        messages = [(c.topic, m.log_time, json.loads(m.data)) for _, c, m in reader.iter_messages()]
        metadata = {r.name: dict(r.metadata) for r in reader.iter_metadata()}
    assert summary.statistics.message_count == len(messages)
    return summary, messages, metadata


def add_box(world, label, half, position, rgba=(0.2, 0.4, 0.6, 1.0)):
    cid = world.client_id
    col = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, physicsClientId=cid)
    vis = pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=rgba, physicsClientId=cid)
    body = pybullet.createMultiBody(
        0.0, col, vis, position, [0, 0, math.sin(0.25), math.cos(0.25)], physicsClientId=cid
    )
    world.scene.objects[label] = SceneObject(label, body, "box", tuple(position), ("wall",))


def add_cylinder(world, label, radius, length, position):
    cid = world.client_id
    col = pybullet.createCollisionShape(pybullet.GEOM_CYLINDER, radius=radius, height=length, physicsClientId=cid)
    vis = pybullet.createVisualShape(pybullet.GEOM_CYLINDER, radius=radius, length=length, physicsClientId=cid)
    body = pybullet.createMultiBody(0.0, col, vis, position, physicsClientId=cid)
    world.scene.objects[label] = SceneObject(label, body, "cylinder", tuple(position), ())


def test_every_channel_round_trips(tmp_path):
    path = tmp_path / "run.mcap"
    image = np.zeros((12, 16, 3), dtype=np.uint8)
    image[:, :8] = (255, 0, 0)  # left half red (RGB order)
    with World(seed=1) as world, Recorder(path, {"mission": "mission: x\n", "seed": 5}, record_images=True) as rec:
        add_box(world, "wall", [1.0, 0.1, 0.5], [3.0, 0.0, 0.5])
        add_cylinder(world, "barrel", 0.3, 0.9, [0.0, 2.0, 0.45])
        rec.log_scene(world)
        rec.log_event(0.0, "run_start", mission="x", seed=5)
        rec.log_robot_poses(
            0.5,
            {"uav": (np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 0.0, 1.0]))},
            {"uav": (np.array([1.1, 2.0, 3.0]), np.array([0.0, 0.0, 0.0, 1.0]))},
        )
        rec.log_metric(0.5, "battery", np.float32(0.75), robot="uav")
        rec.log_text(0.5, "warning", "low battery")
        assert rec.log_image(0.6, "uav/camera", image, format="png", stamp=0.55)
        assert rec.log_image(0.6, "uav/camera", image, format="jpeg")
        rec.log_event(0.7, "preemption", preempted="explore", by="dock", why="battery low", robot="uav")
        rec.log_event(0.7, "operator", command="dock", source="stdin")
        rec.log_event(0.8, "outcome", node="dock", skill="dock", robot="uav", status="SUCCESS", message="docked")
        rec.log_event(0.8, "state_change", node="dock", previous="RUNNING", current="SUCCESS")
        rec.log_event(0.9, "error", message="sensor dropout", robot="uav")
        rec.log_event(1.0, "run_end", outcome="success", sim_time=1.0)
    log = read_log(path)
    assert log.outcome == "success" and log.sim_time == 1.0 and log.seed == 5
    assert log.metadata["mission"] == "mission: x\n" and log.metadata["version"] == marsupial.__version__
    assert [e["kind"] for e in log.events] == [
        "run_start", "preemption", "operator", "outcome", "state_change", "error", "run_end",
    ]
    assert log.events[1] == {
        "t": 0.7,
        "kind": "preemption",
        "preempted": "explore",
        "by": "dock",
        "why": "battery low",
        "robot": "uav",
    }
    assert len(log.events_of("run_end")) == 1  # close() adds none when the run logged its own

    tf = log.messages("/tf")[0]
    assert tf.t == 0.5 and tf.data["parent_frame_id"] == "world" and tf.data["child_frame_id"] == "uav"
    assert tf.data["timestamp"] == {"sec": 0, "nsec": 500_000_000}
    assert tf.data["translation"] == {"x": 1.0, "y": 2.0, "z": 3.0} and tf.data["rotation"]["w"] == 1.0
    t, xyz, q = log.poses("uav", orientation=True)
    assert t.tolist() == [0.5] and xyz.tolist() == [[1.0, 2.0, 3.0]] and q.tolist() == [[0, 0, 0, 1]]
    assert log.messages("/truth/uav/pose")[0].data["frame_id"] == "world"
    _, estimated = log.poses("uav", estimate=True)  # the onboard estimate, beside the truth
    assert estimated.tolist() == [[1.1, 2.0, 3.0]]

    assert log.metrics == [{"t": 0.5, "name": "battery", "value": 0.75, "labels": {"robot": "uav"}}]
    lines = [(m.data["level"], m.data["message"]) for m in log.messages("/log")]
    assert (3, "low battery") in lines  # WARNING
    assert (3, 'preemption preempted=explore by=dock why="battery low" robot=uav') in lines
    assert (4, "error message=\"sensor dropout\" robot=uav") in lines  # ERROR
    assert sum(1 for _, text in lines if not text.startswith(("low battery",))) == len(log.events)

    png, jpeg = log.messages("/uav/camera/image")
    assert png.data["format"] == "png" and png.data["frame_id"] == "uav/camera"
    assert png.data["timestamp"] == {"sec": 0, "nsec": 550_000_000}
    decoded = cv2.imdecode(np.frombuffer(base64.b64decode(png.data["data"]), np.uint8), cv2.IMREAD_COLOR)
    assert np.array_equal(decoded[..., ::-1], image)  # lossless and back in RGB order
    assert jpeg.data["format"] == "jpeg"
    decoded = cv2.imdecode(np.frombuffer(base64.b64decode(jpeg.data["data"]), np.uint8), cv2.IMREAD_COLOR)
    assert decoded.shape == image.shape and decoded[6, 2, 2] > 200 and decoded[6, 13, 2] < 50

    (scene,) = log.messages("/scene")
    entities = {e["id"]: e for e in scene.data["entities"]}
    assert set(entities) == {"floor", "wall", "barrel"}
    (wall,) = entities["wall"]["cubes"]
    assert wall["size"] == pytest.approx({"x": 2.0, "y": 0.2, "z": 1.0})
    assert wall["pose"]["position"] == pytest.approx({"x": 3.0, "y": 0.0, "z": 0.5})
    assert wall["pose"]["orientation"]["z"] == pytest.approx(math.sin(0.25), abs=1e-6)
    assert wall["color"] == pytest.approx({"r": 0.2, "g": 0.4, "b": 0.6, "a": 1.0}, abs=1e-6)
    assert entities["wall"]["metadata"] == [{"key": "tags", "value": "wall"}]
    (barrel,) = entities["barrel"]["cylinders"]
    assert barrel["size"] == pytest.approx({"x": 0.6, "y": 0.6, "z": 0.9})
    assert entities["floor"]["cubes"][0]["size"]["x"] == world.scene.size[0]


def test_schema_names_and_encodings_match_foxglove(tmp_path):
    path = tmp_path / "run.mcap"
    with World() as world, Recorder(path, record_images=True) as rec:
        rec.log_scene(world)
        rec.log_robot_poses(0.0, {"uav": ([0, 0, 0], [0, 0, 0, 1])}, {"uav": ([0, 0, 0], [0, 0, 0, 1])})
        rec.log_image(0.0, "uav/camera", np.zeros((4, 4, 3), np.uint8))
        rec.log_metric(0.0, "m", 1)
        rec.log_tree(0.0, TreeTracker().status(py_trees.behaviours.Success("s")))
    summary, _, _ = read_valid(path)
    topics = {c.topic: summary.schemas[c.schema_id] for c in summary.channels.values()}
    for topic, name in {**CHANNEL_SCHEMAS, **FOXGLOVE_TOPICS}.items():
        schema = topics[topic]
        assert schema.name == name and schema.encoding == "jsonschema"
        body = json.loads(schema.data)
        assert body == SCHEMAS[name] and body["title"] == name and body["type"] == "object"
    # schemas.json knows every kind
    assert SCHEMAS["marsupial.Event"]["properties"]["kind"]["enum"] == list(EVENT_KINDS)
    assert {c.message_encoding for c in summary.channels.values()} == {"json"}
    fields = {
        "foxglove.FrameTransform": {"timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"},
        "foxglove.PoseInFrame": {"timestamp", "frame_id", "pose"},
        "foxglove.SceneUpdate": {"deletions", "entities"},
        "foxglove.CompressedImage": {"timestamp", "frame_id", "data", "format"},
        "foxglove.Log": {"timestamp", "level", "message", "name", "file", "line"},
    }
    for name, expected in fields.items():
        assert set(SCHEMAS[name]["properties"]) == expected
    levels = SCHEMAS["foxglove.Log"]["properties"]["level"]["oneOf"]
    assert [(v["title"], v["const"]) for v in levels] == [
        ("UNKNOWN", 0), ("DEBUG", 1), ("INFO", 2), ("WARNING", 3), ("ERROR", 4), ("FATAL", 5),
    ]
    assert SCHEMAS["marsupial.Event"]["properties"]["kind"]["enum"] == list(EVENT_KINDS)


def snap(rec, tracker, t, root):
    """Log the tree's statuses as a run does: what the tracker reports changed, written by the recorder."""
    status = tracker.status(root)
    return status is not None and rec.log_tree(t, status)


def test_tree_is_snapshot_only_on_change(tmp_path):
    path = tmp_path / "run.mcap"
    takeoff = py_trees.behaviours.StatusQueue(
        "takeoff", [Status.RUNNING, Status.RUNNING, Status.SUCCESS], Status.SUCCESS
    )
    hover = py_trees.behaviours.Running("hover")
    root = py_trees.composites.Sequence("mission", memory=True, children=[takeoff, hover])
    written, tracker = [], TreeTracker()
    with Recorder(path) as rec:
        snap(rec, tracker, 0.0, root)  # before the first tick: everything IDLE
        for tick in range(1, 6):
            root.tick_once()
            written.append(snap(rec, tracker, tick * 0.1, root))
        root.stop(Status.INVALID)  # halted: back to IDLE
        written.append(snap(rec, tracker, 0.6, root))
    assert written == [True, False, True, False, False, True]
    log = read_log(path)
    snaps = log.tree_snapshots
    assert [s.t for s in snaps] == [0.0, 0.1, 0.3, 0.6]
    assert snaps[0].event_log == [] and set(snaps[0].statuses.values()) == {"IDLE"}
    entry = snaps[1].event_log[0]
    assert entry == {
        "timestamp": {"sec": 0, "nsec": 100_000_000},
        "node_name": "mission",
        "uid": 1,
        "previous_status": "IDLE",
        "current_status": "RUNNING",
    }
    assert [(e["uid"], e["node_name"], e["current_status"]) for e in snaps[1].event_log] == [
        (1, "mission", "RUNNING"), (2, "takeoff", "RUNNING"),
    ]
    assert [(e["node_name"], e["previous_status"], e["current_status"]) for e in snaps[2].event_log] == [
        ("takeoff", "RUNNING", "SUCCESS"), ("hover", "IDLE", "RUNNING"),
    ]
    assert snaps[2].statuses == {1: "RUNNING", 2: "SUCCESS", 3: "RUNNING"}
    assert snaps[2].status("hover") == "RUNNING"
    assert snaps[3].statuses == {1: "IDLE", 2: "IDLE", 3: "IDLE"}
    # the uids of the event log are the _uid attributes of the XML on /tree/xml
    (xml_message,) = log.messages("/tree/xml")
    doc = ET.fromstring(xml_message.data["data"])
    by_uid = {int(e.get("_uid")): e.get("name") for e in doc.iter() if e.get("_uid")}
    assert by_uid == {1: "mission", 2: "takeoff", 3: "hover"}
    assert all(by_uid[e["uid"]] == e["node_name"] for s in snaps for e in s.event_log)


def test_tree_structure_change_rewrites_xml(tmp_path):
    path = tmp_path / "run.mcap"
    root = py_trees.composites.Sequence("mission", memory=True, children=[py_trees.behaviours.Success("a")])
    tracker = TreeTracker()
    with Recorder(path) as rec:
        root.tick_once()
        snap(rec, tracker, 0.0, root)
        root.add_child(py_trees.behaviours.Success("b"))
        assert snap(rec, tracker, 0.1, root)  # same statuses, new structure
    log = read_log(path)
    assert [m.t for m in log.messages("/tree/xml")] == [0.0, 0.1]
    assert log.tree_snapshots[1].names == {1: "mission", 2: "a", 3: "b"}
    # a fresh structure starts from IDLE, so current statuses are listed again
    assert [e["node_name"] for e in log.tree_snapshots[1].event_log] == ["mission", "a"]


def test_bad_input_is_rejected_clearly(tmp_path):
    with Recorder(tmp_path / "run.mcap") as rec:
        rec.log_metric(1.0, "x", 1.0)
        with pytest.raises(ValueError, match=r"t=0.5 s is earlier than the last logged message \(t=1.0 s\)"):
            rec.log_event(0.5, "run_start")
        with pytest.raises(ValueError, match="unknown event kind 'premption'.*did you mean 'preemption'"):
            rec.log_event(1.0, "premption")
        with pytest.raises(ValueError, match="event 'preemption' needs the field.s. by, why"):
            rec.log_event(1.0, "preemption", preempted="a", robot="uav")
        with pytest.raises(ValueError, match="unknown log level 'loud'"):
            rec.log_text(1.0, "loud", "x")
        rec.record_images = True
        with pytest.raises(ValueError, match="expected an H x W x 3"):
            rec.log_image(1.0, "cam", np.zeros((4, 4), np.float32))
        with pytest.raises(TypeError, match="type object cannot be logged as JSON"):
            rec.log_event(1.0, "state_change", what=object())
        rec.log_metric(1.0, "nan", float("nan"))  # JSON has no NaN: stored as null
    log = read_log(tmp_path / "run.mcap")
    assert log.metrics[-1]["value"] is None and np.isnan(log.metric("nan")[1][0])
    assert log.outcome == "unknown" and log.events[-1]["kind"] == "run_end"


def test_images_are_opt_in_and_close_is_final(tmp_path):
    path = tmp_path / "run.mcap"
    rec = Recorder(path)
    assert not rec.log_image(0.0, "cam", np.zeros((2, 2, 3), np.uint8))
    rec.log_event(0.0, "run_start")
    rec.close("aborted", reason="operator")
    rec.close("success")  # no effect
    rec.log_event(1.0, "error", message="after close")  # ignored
    assert rec.closed
    summary, messages, metadata = read_valid(path)
    assert "/cam/image" not in {c.topic for c in summary.channels.values()}
    assert metadata["outcome"] == {"outcome": "aborted", "sim_time": "0.0", "reason": "operator"}
    assert [m[2]["kind"] for m in messages if m[0] == "/events"] == ["run_start", "run_end"]


# ------------------------------------------------------------------ endings
SCRIPT = textwrap.dedent(
    """
    import os, signal, sys
    from marsupial.trees.recorder import Recorder

    path, mode = sys.argv[1], sys.argv[2]
    with Recorder(path, {"mission": "endings", "seed": 1}, chunk_size=4096) as rec:
        rec.install_signal_handlers()
        writer = rec._sinks[0].writer
        if mode == "signal_in_write":  # SIGINT arrives in the middle of a message write
            real_add = writer.add_message
            def add_message(*args, **kwargs):
                if writer_calls.append(1) or len(writer_calls) == 1000:
                    os.kill(os.getpid(), signal.SIGINT)
                return real_add(*args, **kwargs)
            writer_calls = []
            writer.add_message = add_message
        if mode == "signal_in_close":  # a second SIGTERM arrives while the first one closes the file
            real_finish = writer.finish
            def finish():
                os.kill(os.getpid(), signal.SIGTERM)
                real_finish()
            writer.finish = finish
        rec.log_event(0.0, "run_start", mission="endings")
        for i in range(1, 10**7):
            t = i * 0.01
            rec.log_metric(t, "i", i)
            rec.log_robot_poses(t, {"r": ([t, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])})
            if i == 300:
                print("ready", flush=True)
                if mode == "raise":
                    raise RuntimeError("skill exploded")
                if mode in ("success", "failure"):
                    rec.log_event(t, "run_end", outcome=mode, sim_time=t)
                    break
                if mode == "signal_in_close":
                    os.kill(os.getpid(), signal.SIGTERM)
    """
)


def run_script(tmp_path, mode, send=()):
    """Run the recording script in ``mode``; send the signals in ``send`` once it is ready."""
    script = tmp_path / "record.py"
    script.write_text(SCRIPT)
    path = tmp_path / f"{mode}.mcap"
    proc = subprocess.Popen(
        [sys.executable, str(script), str(path), mode],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout.readline().strip() == "ready"
    for signum in send:
        proc.send_signal(signum)
    _, stderr = proc.communicate(timeout=30)
    return proc.returncode, stderr, path


@pytest.mark.parametrize(
    ("mode", "send", "outcome", "returncodes"),
    [
        ("success", (), "success", {0}),
        ("failure", (), "failure", {0}),
        ("raise", (), "error", {1}),
        ("loop", (signal.SIGINT,), "interrupted", {-signal.SIGINT}),
        ("loop", (signal.SIGTERM,), "terminated", {143}),
        # a second SIGTERM after the close has put the default handler back may kill the process
        ("loop", (signal.SIGTERM, signal.SIGTERM), "terminated", {143, -signal.SIGTERM}),
        ("signal_in_write", (), "interrupted", {-signal.SIGINT}),
        ("signal_in_close", (), "terminated", {143}),
    ],
)
def test_file_is_valid_however_the_run_ends(tmp_path, mode, send, outcome, returncodes):
    code, stderr, path = run_script(tmp_path, mode, send)
    assert code in returncodes, stderr
    summary, messages, metadata = read_valid(path)
    assert metadata["marsupial"]["mission"] == "endings"
    assert metadata["outcome"]["outcome"] == outcome
    events = [m[2] for m in messages if m[0] == "/events"]
    assert events[0]["kind"] == "run_start" and events[-1] == {
        "kind": "run_end", "outcome": outcome, "sim_time": pytest.approx(float(metadata["outcome"]["sim_time"]))
    }
    times = [m[1] for m in messages]
    assert times == sorted(times) and len(times) > 600
    if mode == "raise":
        assert "RuntimeError: skill exploded" in stderr
        assert any(e == {"kind": "error", "message": "RuntimeError: skill exploded"} for e in events)
    if mode in ("signal_in_write", "signal_in_close"):
        assert read_log(path).outcome == outcome


def test_a_hard_kill_leaves_a_file_the_reader_rejects_clearly(tmp_path):
    code, _, path = run_script(tmp_path, "loop", send=(signal.SIGKILL,))
    assert code == -signal.SIGKILL
    with pytest.raises(LogError, match=r"not a complete MCAP file \(truncated at byte \d+\?\)"):
        read_log(path)
    assert os.path.getsize(path) > 4096  # full chunks reached the disk before the kill
