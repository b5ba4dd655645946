"""The live view: ``marsupial run demo_hover --live`` serves the run over the Foxglove WebSocket protocol.

A plain websocket client (subprotocol ``foxglove.sdk.v1``, what foxglove-sdk 0.30 speaks) connects, gets
the server info and the channel advertisements (the recorder's topics and schemas), subscribes, and
receives messages — the scene although it was written before the client came (latched topics).
"""

from __future__ import annotations

import asyncio
import json
import re
import struct
import subprocess
import sys
from pathlib import Path

import pytest

websockets = pytest.importorskip("websockets", reason="websockets is not installed (pip install '.[test]')")

from marsupial.trees.recorder import CHANNEL_SCHEMAS  # noqa: E402

SUBPROTOCOL = "foxglove.sdk.v1"
MESSAGE_DATA = 1  # binary opcode of a message (then subscription id u32, log time u64 ns, payload)


def start_live(tmp_path, *args: str) -> tuple[subprocess.Popen, str, str]:
    """Start ``marsupial run … --live`` on a free port; returns the process, its URL and its announcement line."""
    process = subprocess.Popen(
        [sys.executable, "-m", "marsupial.trees.cli", "run", *args, "--live", "--port", "0", "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
    )
    line = process.stdout.readline()
    match = re.search(r"ws://[\w.:\[\]]+", line)
    if match is None:
        process.kill()
        pytest.fail(f"no live server announced: {line!r} {process.stderr.read()}")
    return process, match.group(0), line


async def watch(url: str) -> tuple[dict, dict, dict]:
    """Connect, collect advertisements until /scene, /tf and /tree are there, subscribe to /scene and /tf."""
    async with websockets.connect(url, subprotocols=[SUBPROTOCOL], open_timeout=10) as ws:
        assert ws.subprotocol == SUBPROTOCOL
        info, channels = None, {}
        while info is None or not {"/scene", "/tf", "/tree", "/events"} <= set(channels):
            frame = await asyncio.wait_for(ws.recv(), 10)
            if isinstance(frame, bytes):  # the server's clock (binary time messages)
                continue
            message = json.loads(frame)
            if message["op"] == "serverInfo":
                info = message
            elif message["op"] == "advertise":
                channels.update({c["topic"]: c for c in message["channels"]})
        wanted = {1: "/scene", 2: "/tf"}
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": sid, "channelId": channels[topic]["id"]} for sid, topic in wanted.items()]}))
        received = {}
        while len(received) < len(wanted):
            frame = await asyncio.wait_for(ws.recv(), 10)
            if isinstance(frame, bytes) and frame[0] == MESSAGE_DATA:
                sid, ns = struct.unpack_from("<IQ", frame, 1)
                received.setdefault(wanted[sid], (ns, json.loads(frame[13:])))
        return info, channels, received


@pytest.mark.slow
def test_a_foxglove_client_watches_demo_hover(tmp_path):
    process, url, line = start_live(tmp_path, "demo_hover", "--speed", "4", "--no-log")
    try:
        assert url.startswith("ws://127.0.0.1:") and "this machine only" in line
        info, channels, received = asyncio.run(watch(url))
    finally:
        out, err = process.communicate(timeout=120)
    assert process.returncode == 0, err
    assert info["name"] == "marsupial" and "time" in info["capabilities"]
    for topic in ("/tf", "/tree", "/tree/xml", "/events", "/log", "/metrics", "/scene"):
        channel = channels[topic]
        assert (channel["schemaName"], channel["encoding"], channel["schemaEncoding"]) == (
            CHANNEL_SCHEMAS[topic], "json", "jsonschema")
    assert channels["/truth/uav/pose"]["schemaName"] == "foxglove.PoseInFrame" and "/uav/pose" in channels
    scene_ns, scene = received["/scene"]
    assert scene_ns == 0 and [e["id"] for e in scene["entities"]] == ["floor"]  # sent again to the late client
    tf_ns, tf = received["/tf"]
    assert tf["child_frame_id"] == "uav" and tf_ns == tf["timestamp"]["sec"] * 10**9 + tf["timestamp"]["nsec"]
    assert not (tmp_path / "runs").exists()  # --no-log


def test_live_says_when_it_is_open_to_the_network(tmp_path):
    process, url, line = start_live(tmp_path, "demo_hover", "--speed", "50", "--until", "1", "--host", "0.0.0.0")
    out, err = process.communicate(timeout=120)
    assert process.returncode == 1, err  # time limit
    assert url.startswith("ws://0.0.0.0:") and "open to the network on 0.0.0.0" in line
    assert "log: runs/demo_hover-" in out  # the live view does not replace the log


def test_the_shipped_foxglove_layout_uses_recorded_topics():
    layout = json.loads((Path(__file__).resolve().parents[1] / "docs" / "foxglove" / "marsupial.json").read_text())
    panels = layout["configById"]
    pose = re.compile(r"/(truth/)?\w+/pose")
    three_d = next(config for panel, config in panels.items() if panel.startswith("3D!"))
    assert three_d["followTf"] == "world"
    assert all(topic in CHANNEL_SCHEMAS or pose.fullmatch(topic) for topic in three_d["topics"])
    tree = next(config for panel, config in panels.items() if "behavior-tree" in panel)
    assert (tree["behaviorTreeXmlTopic"], tree["behaviorTreeLogsTopic"]) == ("/tree/xml", "/tree")
    plotted = [p["value"] for panel, config in panels.items() if panel.startswith("Plot!") for p in config["paths"]]
    assert '/metrics{name=="battery_soc"}.value' in plotted
    assert panels["Log!marsupial"]["topicToRender"] == "/log"

    def leaves(node):
        return [node] if isinstance(node, str) else leaves(node["first"]) + leaves(node["second"])

    assert sorted(leaves(layout["layout"])) == sorted(panels)  # every configured panel is placed, and only those


def test_a_port_in_use_is_bad_input(tmp_path):
    from marsupial.trees.live import LiveSink

    taken = LiveSink(port=0)
    port = taken.port
    try:
        result = subprocess.run(
            [sys.executable, "-m", "marsupial.trees.cli", "run", "demo_hover", "--live", "--port", str(port)],
            capture_output=True, text=True, cwd=tmp_path, timeout=120,
        )
    finally:
        taken.close()
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert f"--live: cannot serve on 127.0.0.1:{port}" in result.stderr and "Address already in use" in result.stderr
    assert not (tmp_path / "runs").exists()  # nothing ran


async def visit(url: str, subprotocol: str) -> str:
    """Connect with only ``subprotocol``, read the server info, leave; returns the server's name or the refusal."""
    try:
        async with websockets.connect(url, subprotocols=[subprotocol], open_timeout=10) as ws:
            while True:
                frame = await asyncio.wait_for(ws.recv(), 10)
                if isinstance(frame, str) and json.loads(frame)["op"] == "serverInfo":
                    return json.loads(frame)["name"]
    except websockets.exceptions.InvalidStatus as refused:
        return f"refused: HTTP {refused.response.status_code}"


async def stay(url: str) -> tuple[list[dict], int | None]:
    """Connect and listen until the server closes; returns the status messages heard and the close code."""
    statuses = []
    async with websockets.connect(url, subprotocols=[SUBPROTOCOL], open_timeout=10) as ws:
        try:
            while True:
                frame = await asyncio.wait_for(ws.recv(), 30)
                if isinstance(frame, str) and json.loads(frame)["op"] == "status":
                    statuses.append(json.loads(frame))
        except websockets.exceptions.ConnectionClosedOK:
            pass
        return statuses, ws.close_code


async def visits_while_one_stays(url: str) -> tuple[list[str], list[dict], int | None]:
    """One client stays to the end while five visit and three legacy ones are refused: (visits, statuses, close code).

    The staying client connects first, so a run that ends early on a fast machine cannot leave it unheard.
    """
    staying = asyncio.create_task(stay(url))
    results = [await visit(url, SUBPROTOCOL) for _ in range(5)]
    results += [await visit(url, "foxglove.websocket.v1") for _ in range(3)]
    statuses, code = await staying
    return results, statuses, code


def test_clients_come_and_go_quietly_and_hear_how_the_run_ended(tmp_path):
    """Five clients connect and leave, a legacy client is refused thrice, one stays: the run prints one line for it."""
    process, url, _ = start_live(tmp_path, "demo_hover", "--speed", "2", "--no-log")
    try:
        results, statuses, code = asyncio.run(visits_while_one_stays(url))
    finally:
        out, err = process.communicate(timeout=120)
    assert process.returncode == 0, err
    assert results == ["marsupial"] * 5 + ["refused: HTTP 400"] * 3
    assert "Traceback" not in err and "AttributeError" not in err and "Callback failed" not in err
    [refusal] = [line for line in err.splitlines() if "refused" in line]  # once, not once per attempt
    assert refusal.startswith("live: a client at 127.0.0.1 was refused") and "foxglove.websocket.v1" in refusal
    assert [s["message"] for s in statuses] == ["run ended: success at 12.9 s (simulated); the live view stops"]
    assert code == 1005  # the SDK's close frame carries no status code; the connection still closes cleanly


def test_the_live_sink_implements_every_listener_hook():
    from foxglove.websocket import ServerListener

    from marsupial.trees.live import LiveSink

    hooks = [name for name in dir(ServerListener) if name.startswith("on_")]
    assert len(hooks) >= 12 and ServerListener in LiveSink.__mro__
    assert all(callable(getattr(LiveSink, name)) for name in hooks)
