"""The marsupial command: bad input (exit 2, file:line), signals, verify, drawing, export, listing."""

import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
import xml.etree.ElementTree as ET

import pytest
from click.testing import CliRunner
from mcap.reader import make_reader
from mcap.writer import Writer

from marsupial.trees.cli import DEFAULT_MISSION, cli
from marsupial.trees.mission import known_missions
from marsupial.trees.operator import OperatorChannel
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission

GOOD = """\
mission: good
team:
  uav: {robot: bebop2, pose: [0, 0, 1.0, 0]}
tree:
  sequence:
    - {skill: hover, robot: uav, params: {seconds: 0.5}}
    - {skill: wait, params: {seconds: 0.2}}
"""


@pytest.fixture(autouse=True)
def in_tmp_folder(tmp_path, monkeypatch):
    """Every command runs in the test's folder, so default logs (``runs/``) land there, not in the repository."""
    monkeypatch.chdir(tmp_path)


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], env={"COLUMNS": "200"})


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


# ---------------------------------------------------------------- bad input
BAD_INPUTS = {
    "malformed_yaml": ("mission: x\ntree: {sequence: [{skill: wait}\n", 3, "x.yaml:"),
    "unknown_key": (GOOD.replace("tree:", "treee:"), 4, "did you mean 'tree'?"),
    "unknown_skill": (GOOD.replace("skill: hover", "skill: hovr"), 6, "did you mean 'hover'?"),
    "wrong_parameter_type": (
        GOOD.replace("seconds: 0.5", "seconds: half"),
        6,
        "params.seconds: invalid value 'half'; expected a number",
    ),
    "subtree_cycle": ("mission: x\ntree: {subtree: a.yaml}\n", 2, "cycle"),
    "missing_subtree_file": ("mission: x\ntree: {subtree: nowhere.yaml}\n", 2, "nowhere"),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_input_exits_2_with_a_file_line_message_and_no_log(tmp_path, case):
    text, line, expected = BAD_INPUTS[case]
    write(tmp_path, "a.yaml", "subtree: a\ntree: {subtree: b.yaml}\n")
    write(tmp_path, "b.yaml", "subtree: b\ntree: {subtree: a.yaml}\n")
    mission = write(tmp_path, "x.yaml", text)
    log = tmp_path / "run.mcap"
    result = invoke("run", mission, "--log", log, "-q")
    assert result.exit_code == 2, result.output
    message = result.stderr
    assert "Traceback" not in result.output
    assert f"x.yaml:{line}:" in message or (case == "subtree_cycle" and ".yaml:" in message), message
    assert expected in message
    assert not log.exists()


def test_missing_mission_file_and_unknown_mission_name(tmp_path):
    result = invoke("run", tmp_path / "absent.yaml", "-q")
    assert result.exit_code == 2 and "absent.yaml' not found" in result.stderr
    result = invoke("run", "demo_hovr", "-q")
    assert result.exit_code == 2 and "did you mean 'demo_hover'?" in result.stderr


def test_bad_set_override_exits_2(tmp_path):
    result = invoke("run", write(tmp_path, "m.yaml", GOOD), "--set", "wrld.seed=3", "-q")
    assert result.exit_code == 2 and "wrld.seed" in result.stderr


# ---------------------------------------------------------------- runs, verify, replay
def test_run_verify_and_replay(tmp_path):
    log = tmp_path / "run.mcap"
    result = invoke("run", write(tmp_path, "m.yaml", GOOD), "--log", log, "--seed", "4")
    assert result.exit_code == 0, result.output
    assert "success" in result.output and "seed" in result.output  # the summary table
    assert read_log(log).seed == 4
    result = invoke("verify", log)
    assert result.exit_code == 0, result.output
    assert "verified" in result.output
    result = invoke("replay", log)
    assert result.exit_code == 0 and "outcome=success" in result.output and "hover@uav" in result.output


def test_verify_replays_live_operator_commands(tmp_path):
    log = tmp_path / "run.mcap"
    channel = OperatorChannel()
    channel.say("abort", "seen from the window")
    result = run_mission(str(write(tmp_path, "m.yaml", GOOD)), log_path=log, progress=False, operator=channel)
    assert result.outcome == "aborted"
    result = invoke("verify", log)
    assert result.exit_code == 0, result.output + result.stderr


def tamper(source, target):
    """Copy an MCAP log, changing the status of its first skill outcome event to FAILURE."""
    with open(source, "rb") as f_in, open(target, "wb") as f_out:
        reader = make_reader(f_in)
        writer = Writer(f_out)
        writer.start()
        schemas, channels, changed = {}, {}, False
        for schema, channel, message in reader.iter_messages():
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id]
                )
            data = message.data
            payload = json.loads(data) if channel.topic == "/events" else None
            if payload and payload["kind"] == "outcome" and not changed:
                payload["status"], changed = "FAILURE", True
                data = json.dumps(payload).encode()
            writer.add_message(channels[channel.id], message.log_time, data, message.publish_time)
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, record.metadata)
        writer.finish()
    assert changed


def test_verify_fails_on_a_tampered_log(tmp_path):
    log, tampered = tmp_path / "run.mcap", tmp_path / "tampered.mcap"
    assert invoke("run", write(tmp_path, "m.yaml", GOOD), "--log", log, "-q").exit_code == 0
    tamper(log, tampered)
    result = invoke("verify", tampered)
    assert result.exit_code == 1
    assert "differs" in result.stderr and "status=FAILURE" in result.stderr and "status=SUCCESS" in result.stderr


def test_mission_failure_exits_1(tmp_path):
    mission = write(tmp_path, "m.yaml", "mission: f\ntree: {invert: {skill: wait, params: {seconds: 0.1}}}\n")
    result = invoke("run", mission, "-q")
    assert result.exit_code == 1


@pytest.mark.slow
@pytest.mark.parametrize(
    "signum, code, outcome", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")]
)
def test_a_signal_leaves_a_readable_log(tmp_path, signum, code, outcome):
    mission = write(tmp_path, "long.yaml", GOOD.replace("seconds: 0.5", "seconds: 100000"))
    log = tmp_path / "run.mcap"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    process = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from marsupial.trees.cli import main; main()",
            "run",
            str(mission),
            "--log",
            str(log),
            "-q",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    deadline = time.monotonic() + 60
    while not (log.exists() and log.stat().st_size > 0) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # let it tick for a while
    process.send_signal(signum)
    _, err = process.communicate(timeout=60)
    assert process.returncode == code, err.decode()
    run_log = read_log(log)
    assert run_log.outcome == outcome
    assert run_log.sim_time > 1.0 and run_log.events[0]["kind"] == "run_start"


# ---------------------------------------------------------------- other commands
def test_tree_drawings(tmp_path):
    mission = write(tmp_path, "m.yaml", GOOD)
    result = invoke("tree", mission)
    assert result.exit_code == 0 and "hover@uav" in result.output and "sequence" in result.output
    result = invoke("tree", mission, "--format", "dot")
    assert result.exit_code == 0 and result.output.lstrip().startswith("digraph")
    result = invoke("tree", mission, "--format", "svg", "-o", tmp_path / "tree.svg")
    if shutil.which("dot") is None:
        assert result.exit_code == 2 and "Graphviz's 'dot' program is not installed" in result.stderr
    else:
        assert result.exit_code == 0 and (tmp_path / "tree.svg").read_text().lstrip().startswith("<")


def test_export_writes_behaviortree_cpp_xml(tmp_path):
    out = tmp_path / "tree.xml"
    result = invoke("export", write(tmp_path, "m.yaml", GOOD), "--format", "btcpp-xml", "-o", out)
    assert result.exit_code == 0, result.output
    root = ET.parse(out).getroot()
    assert root.get("BTCPP_format") == "4"
    assert [e.get("name") for e in root.iter() if e.get("robot") == "uav"] == ["hover@uav"]


def test_skills_and_schema():
    result = invoke("skills")
    assert result.exit_code == 0
    rows = {line.split("│")[1].strip(): line for line in result.output.splitlines() if line.count("│") == 5}
    assert "skill" in rows["goto"] and "skill" in rows["drive_to"] and "Rotorcraft" in rows["goto"]
    assert "condition" in rows["battery_below"] and "condition" in rows["operator"]
    result = invoke("schema")
    schema = json.loads(result.output)
    assert "Node" in schema["$defs"] and "tree" in schema["properties"]


def test_run_without_a_mission_runs_the_default_one(tmp_path):
    assert DEFAULT_MISSION in known_missions()
    log = tmp_path / "default.mcap"
    result = invoke("run", "-q", "--until", "2", "--log", log)
    assert result.exit_code == 1, result.output + result.stderr  # stopped by the 2 s limit, not by an error
    run = read_log(log)
    assert f"mission: {DEFAULT_MISSION}" in run.metadata["mission"] and run.outcome == "time_limit"
