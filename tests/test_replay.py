"""Log reader: the committed small log reads back (reader drift), regenerating it gives the same events
(writer drift), damaged files give a clear LogError, and compare_events finds tampering."""

import runpy
import shutil
from pathlib import Path

import numpy as np
import pytest

from marsupial.trees.replay import LogError, compare_events, format_timeline, read_log

DATA = Path(__file__).resolve().parent / "data"
SMALL_LOG = DATA / "small_run.mcap"


@pytest.fixture(scope="module")
def fresh_log(tmp_path_factory):
    """The small log regenerated now by the committed script."""
    path = tmp_path_factory.mktemp("fresh") / "small_run.mcap"
    runpy.run_path(str(DATA / "make_small_log.py"))["make_small_log"](path)
    return path


def test_committed_log_reads_back():
    assert SMALL_LOG.stat().st_size < 100_000
    log = read_log(SMALL_LOG)
    assert format_timeline(log) == (DATA / "small_run.timeline.txt").read_text()
    assert log.outcome == "success" and log.sim_time == 0.9 and log.seed == 7
    assert log.metadata["mission_name"] == "small_run"
    assert log.metadata["command_line"] == "marsupial run small_run --seed 7"
    assert log.metadata["mission"].startswith("mission: small_run\n")
    assert log.topic_names == [
        "/carrier/pose", "/events", "/log", "/metrics", "/scene", "/tf", "/tree", "/tree/xml",
        "/truth/carrier/pose", "/truth/uav/pose", "/uav/camera/image", "/uav/pose",
    ]
    t, xyz = log.poses("carrier")
    assert np.allclose(t, np.arange(10) * 0.1) and np.allclose(xyz[:, 0], 0.5 * t) and xyz.shape == (10, 3)
    _, estimated = log.poses("carrier", estimate=True)
    assert np.allclose(estimated[:, 0], 0.51 * t)  # the estimate, beside the truth
    t, battery = log.metric("battery", robot="uav")
    assert np.allclose(battery, 1.0 - 0.05 * np.arange(10))
    assert log.metric("battery", robot="carrier")[0].size == 0
    # the tree: takeoff finishes at 0.2 s, explore runs, dock preempts it at 0.6 s
    snaps = log.tree_snapshots
    assert [s.t for s in snaps] == [0.0, 0.2, 0.6]
    assert snaps[1].status("explore") == "RUNNING" and snaps[1].status("takeoff") == "SUCCESS"
    assert snaps[2].status("explore") == "IDLE" and snaps[2].status("dock") == "RUNNING"
    (preemption,) = log.events_of("preemption")
    assert preemption == {"t": 0.6, "kind": "preemption", "preempted": "explore", "by": "dock",
                          "why": "battery_below 0.75", "robot": "uav"}
    assert [e["id"] for e in log.messages("/scene")[0].data["entities"]] == ["floor", "crate", "barrel", "ball"]


def test_regenerated_log_has_the_same_events(fresh_log):
    committed, fresh = read_log(SMALL_LOG), read_log(fresh_log)
    assert compare_events(committed, fresh) == []
    assert format_timeline(fresh) == format_timeline(committed)
    assert [s.statuses for s in fresh.tree_snapshots] == [s.statuses for s in committed.tree_snapshots]
    for topic in committed.topic_names:
        assert [m.data for m in fresh.messages(topic)] == [m.data for m in committed.messages(topic)], topic


def test_compare_events_reports_tampering(fresh_log):
    a = read_log(SMALL_LOG)
    b = read_log(fresh_log)
    b.events[4]["why"] = "operator"  # the preemption's reason
    b.events.append({"t": 1.0, "kind": "error", "message": "late"})
    a.events[0]["wall_time"] = 12.5  # wall-clock fields are ignored
    diff = compare_events(a, b)
    assert diff == [
        "@ event 4",
        '-      0.600  preemption preempted=explore by=dock why="battery_below 0.75" robot=uav',
        "+      0.600  preemption preempted=explore by=dock why=operator robot=uav",
        "@ event 6",
        "+      1.000  error message=late",
    ]
    b.events[4]["t"] = 0.6000001  # times count to the nanosecond
    b.events[4]["why"] = "battery_below 0.75"
    assert compare_events(a, b)[0] == "@ event 4"


def test_damaged_files_raise_log_error(tmp_path):
    data = SMALL_LOG.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(LogError, match=rf"cut.mcap: not a complete MCAP file \(truncated at byte {len(data) // 2}\?\)"):
        read_log(cut)
    bad = tmp_path / "bad.mcap"
    for position in [*range(0, len(data), len(data) // 40), len(data) - 20]:  # header, chunk, summary, footer
        flipped = bytearray(data)
        flipped[position] ^= 0x5A
        bad.write_bytes(bytes(flipped))
        with pytest.raises(LogError, match=r"bad.mcap: (corrupt|not a complete) MCAP file|not an MCAP file"):
            read_log(bad)
    text = tmp_path / "notes.mcap"
    text.write_text("hello")
    with pytest.raises(LogError, match="not an MCAP file"):
        read_log(text)
    with pytest.raises(LogError, match="missing.mcap: no such log file"):
        read_log(tmp_path / "missing.mcap")


def test_unknown_names_list_what_the_log_has(tmp_path):
    log = read_log(shutil.copy(SMALL_LOG, tmp_path / "run.mcap"))
    with pytest.raises(LogError, match=r"unknown topic '/event'; did you mean '/events'\? Known: /carrier/pose"):
        log.messages("/event")
    with pytest.raises(LogError, match=r"unknown robot 'uv'; did you mean 'uav'\? Known: carrier, uav"):
        log.poses("uv")
    with pytest.raises(LogError, match=r"unknown metric 'batery'; did you mean 'battery'"):
        log.metric("batery")
    with pytest.raises(LogError, match=r"unknown event kind 'operater'; did you mean 'operator'"):
        log.events_of("operater")
    with pytest.raises(LogError, match=r"unknown tree node 'docking'; did you mean 'dock'"):
        log.tree_snapshots[-1].status("docking")
