"""Hostile and edge inputs: exit 2 with a located message (no traceback, no hang), or a correct run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from mcap.writer import Writer
from py_trees.common import Status

from marsupial.trees.errors import MissionError
from marsupial.trees.mission import load_mission
from marsupial.trees.runner import run_mission
from marsupial.trees.skill import NodeParams, Skill

BASE = """\
mission: hostile
team:
  uav: {robot: bebop2, pose: [0, 0, 1, 0]}
run: {tick_hz: 10, until: 2}
tree:
  skill: wait
  params: {seconds: 0.5}
"""


def marsupial(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run the CLI in a fresh interpreter (what a user sees: exit code, stdout, stderr)."""
    return subprocess.run(
        [sys.executable, "-m", "marsupial.trees.cli", *args], capture_output=True, text=True, timeout=300, cwd=cwd
    )


def mission_file(tmp_path: Path, text: str, name: str = "m.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def assert_bad_input(result: subprocess.CompletedProcess, *fragments: str) -> None:
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    for fragment in fragments:
        assert fragment in result.stderr, result.stderr


def test_alias_expansion_is_bounded(tmp_path):
    rows = ["a: &a [x, x, x, x, x, x, x, x, x, x]"]
    rows += [f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join(['*' + chr(97 + i)] * 10)}]" for i in range(8)]
    path = mission_file(tmp_path, BASE + "params:\n  " + "\n  ".join(rows) + "\n")
    assert_bad_input(marsupial("tree", str(path)), "m.yaml:", "more than 100,000 values after alias expansion")


def test_deep_nesting_is_refused_with_a_location(tmp_path):
    deep = "tree: " + "{sequence: [" * 100 + "{skill: wait}" + "]}" * 100 + "\n"
    path = mission_file(tmp_path, BASE.replace("tree:\n  skill: wait\n  params: {seconds: 0.5}\n", deep))
    # the 65th level starts at the 33rd '{sequence: [' (two levels each) of line 5, column 7 + 32 * 12
    assert_bad_input(marsupial("tree", str(path)), "m.yaml:5:391:", "nested deeper than 64 levels")
    with pytest.raises(MissionError, match="nested deeper than 64 levels") as caught:  # the composer's recursion
        load_mission(mission_file(tmp_path, "tree: " + "[" * 5000 + "]" * 5000, "deeper.yaml"))
    assert caught.value.location.endswith("deeper.yaml:1:71")  # the 65th '[' (the first is level 1, column 7)
    block = "tree:\n" + "".join("  " * i + "- sequence:\n" for i in range(40)) + "  " * 40 + "- {skill: wait}\n"
    with pytest.raises(MissionError, match="nested deeper than 64 levels") as caught:
        load_mission(mission_file(tmp_path, block, "block.yaml"))
    assert caught.value.location.endswith("block.yaml:33:65")  # block style: the key whose value is level 65


@pytest.mark.parametrize(
    ("value", "expected"), [("480", "expected a value <= 240"), ("1e-300", "expected a value >= 0.01")]
)
def test_tick_rate_is_bounded(tmp_path, value, expected):
    path = mission_file(tmp_path, BASE.replace("tick_hz: 10", f"tick_hz: {value}"))
    assert_bad_input(marsupial("tree", str(path)), "m.yaml:4:", "run.tick_hz", expected)


def test_negative_seeds_are_refused_everywhere(tmp_path):
    path = mission_file(tmp_path, BASE.replace("run:", "world: {seed: -1}\nrun:"))
    assert_bad_input(marsupial("tree", str(path)), "world.seed: invalid value -1; expected a value >= 0")
    good = mission_file(tmp_path, BASE, "good.yaml")
    assert_bad_input(marsupial("run", str(good), "--set", "world.seed=-3"), "value set by --set world.seed=-3")
    for given, shown in (("-3", "-3"), ("abc", "'abc'"), ("1.5", "'1.5'")):
        expected = f"'--seed': {shown} is not a seed; expected an integer ≥ 0"
        assert_bad_input(marsupial("run", str(good), "--seed", given), expected)
    assert_bad_input(
        marsupial("campaign", str(good), "--trials", "1", "--seed", "-1", "--out", str(tmp_path / "c")), "--seed"
    )
    with pytest.raises(MissionError, match="seed -1 is not a seed; expected an integer >= 0"):
        run_mission(good, seed=-1, progress=False)


@pytest.mark.parametrize("value", [".nan", ".inf", "-.inf"])
def test_non_finite_numbers_are_refused(tmp_path, value):
    path = mission_file(tmp_path, BASE.replace("pose: [0, 0, 1, 0]", f"pose: [0, {value}, 1, 0]"))
    assert_bad_input(marsupial("tree", str(path)), "m.yaml:3:", "team.uav.pose[1]", "expected a finite number")
    path = mission_file(tmp_path, BASE.replace("seconds: 0.5", f"seconds: {value}"), "param.yaml")
    assert_bad_input(marsupial("tree", str(path)), "tree.params.seconds", "expected a finite number")


@pytest.mark.parametrize("value", ["3.4e38", "-1000.5"])
def test_a_start_pose_beyond_a_kilometre_is_refused(tmp_path, value):
    # pybullet's single-precision contacts: a start at float32's largest value overflowed the model set-up
    path = mission_file(tmp_path, BASE.replace("pose: [0, 0, 1, 0]", f"pose: [{value}, 0, 1, 0]"))
    bound = "expected a value <= 1000" if value[0] != "-" else "expected a value >= -1000"
    assert_bad_input(marsupial("tree", str(path)), "m.yaml:3:", "team.uav.pose[0]", bound)


@pytest.mark.parametrize(("where", "text"), [("seconds: 0.5", "seconds: true"), ("tick_hz: 10", "tick_hz: '10'")])
def test_booleans_and_strings_are_not_numbers(tmp_path, where, text):
    path = mission_file(tmp_path, BASE.replace(where, text))
    assert_bad_input(marsupial("tree", str(path)), "expected a number")


TYPED = """\
mission: typed
world:
  disturbances:
    wind: {gust: .nan, gusty: 2}
    occlusion: {robot: uav, start: true}
    kidnap: {robot: uav, at: 1.0, pose: [0, 0, none]}
team:
  uav: {robot: bebop2, pose: [0, 0, 1, 0], sensors: {sonar: {rate_hz: .inf}}, options: {battery_soc: false}}
  ugv: {robot: summit_xl, options: {limits: {max_sped: 1.0}, localization: 3}}
tree: {idle: true}
"""


def test_typed_sections_refuse_each_bad_value_at_its_line(tmp_path):
    # wrong type, unknown key, NaN and booleans for numbers, in the disturbances, sensor settings and options
    result = marsupial("tree", str(mission_file(tmp_path, TYPED)))
    assert_bad_input(
        result,
        "m.yaml:4:12: world.disturbances.wind.gust: invalid value nan; expected a finite number",
        "m.yaml:4:24: world.disturbances.wind.gusty: unknown key 'gusty'; expected one of gust, gust_elevation_deg, "
        "gust_gap_s, gust_period_s, steady; did you mean 'gust'?",
        "m.yaml:5:29: world.disturbances.occlusion.start: invalid value True; expected a number",
        "m.yaml:6:48: world.disturbances.kidnap.pose[2]: invalid value 'none'; expected a number",
        "m.yaml:8:62: team.uav.sensors.sonar.rate_hz: invalid value inf; expected a finite number",
    )
    assert "… and 3 more errors" in result.stderr  # the team's: at most 5 are listed
    team = TYPED.split("team:")[1]
    result = marsupial("tree", str(mission_file(tmp_path, "mission: typed\nteam:" + team, "team.yaml")))
    assert_bad_input(
        result,
        "team.yaml:3:89: team.uav.options.battery_soc: invalid value False; expected a number",
        "team.yaml:4:46: team.ugv.options.limits.max_sped: unknown key 'max_sped'",
        "did you mean 'max_speed'?",
        "team.yaml:4:62: team.ugv.options.localization: invalid value 3; expected 'odometry' or 'map'",
    )


@pytest.mark.parametrize(("entry", "message"), [
    ("{robot: bebop2, options: {motors_on: false}, sensors: {lidar: {}}}",
     "m.yaml:3:63: team.uav.sensors.lidar: unknown key 'lidar'; expected one of barometer, battery, flow, "
     "front_camera, imu, sonar"),
    ("{robot: husky}", "m.yaml:3:9: team.uav.robot: unknown robot 'husky'; expected one of ardrone2, bebop2, "
     "child_ugv, mms, mobile_manipulator, mother_ugv, summit_xl, tello"),
    ("{pose: [0, 0, 1, 0]}", "m.yaml:3:3: team.uav.robot: missing required key 'robot'; expected one of ardrone2"),
    ("{robot: summit_xl, sensors: {lidar: {}}}",
     "m.yaml:3:27: team.uav.sensors: unknown key 'sensors'; expected one of options, pose"),
])
def test_robot_kinds_take_their_own_options_and_sensors(tmp_path, entry, message):
    path = mission_file(tmp_path, BASE.replace("{robot: bebop2, pose: [0, 0, 1, 0]}", entry))
    with pytest.raises(MissionError) as caught:
        load_mission(path)
    assert message in str(caught.value)


def test_a_disturbance_the_built_world_cannot_resolve_exits_2_at_its_line(tmp_path):
    disturbances = "world: {disturbances: {occlusion: [{robot: uav}, {robot: uav, link: tag_bundel}]}}\nrun:"
    path = mission_file(tmp_path, BASE.replace("run:", disturbances))
    assert_bad_input(marsupial("run", str(path), "--no-log", "-q"),
                     "m.yaml:4:63: world.disturbances.occlusion[1].link: unknown link of bebop2 'tag_bundel'",
                     "did you mean 'tag_bundle'?")


@pytest.mark.parametrize("until", ["-5", "nan", "inf"])
def test_until_must_be_a_finite_positive_time(tmp_path, until):
    result = marsupial("run", str(mission_file(tmp_path, BASE)), "--until", until)
    assert_bad_input(result, "'--until'", "expected a finite number of simulated seconds > 0")


def test_error_text_is_printed_literally(tmp_path):
    path = mission_file(tmp_path, BASE.replace("pose: [0, 0, 1, 0]", "pose: [1]"))
    assert_bad_input(marsupial("run", str(path), "--quiet"), "[x, y], [x, y, yaw] or [x, y, z, yaw]")


def test_a_campaign_of_a_mission_that_does_not_compile_exits_2(tmp_path):
    path = mission_file(tmp_path, BASE.replace("skill: wait", "skill: wiat"))
    result = marsupial("campaign", str(path), "--trials", "2", "--out", str(tmp_path / "c"))
    assert_bad_input(result, "unknown skill 'wiat'", "did you mean 'wait'?")
    assert not (tmp_path / "c" / "summary.json").exists()


def test_control_characters_in_node_names_are_refused(tmp_path):
    path = mission_file(tmp_path, BASE.replace("  skill: wait", '  skill: wait\n  name: "dock\\x07now"'))
    assert_bad_input(marsupial("tree", str(path)), "tree.name", "printable text (no control characters)")


def test_a_subtree_outside_the_mission_folder_is_not_read(tmp_path):
    inner = tmp_path / "missions"
    inner.mkdir()
    (tmp_path / "secret.yaml").write_text("subtree: secret\ntree: {skill: wait}\n")
    tree = "tree:\n  subtree: ../secret.yaml\n"
    path = mission_file(inner, BASE.replace("tree:\n  skill: wait\n  params: {seconds: 0.5}\n", tree))
    assert_bad_input(marsupial("tree", str(path)), "subtree '../secret.yaml' is outside the mission's folder")
    etc = mission_file(
        inner,
        BASE.replace(
            "tree:\n  skill: wait\n  params: {seconds: 0.5}\n", "tree: {subtree: ../../../../../../etc/passwd}\n"
        ),
        "etc.yaml",
    )
    assert_bad_input(marsupial("tree", str(etc)), "outside the mission's folder")
    env = {**os.environ, "MARSUPIAL_SUBTREE_PATH": str(tmp_path)}
    allowed = subprocess.run(
        [sys.executable, "-m", "marsupial.trees.cli", "tree", str(path)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert allowed.returncode == 0, allowed.stderr


def test_replay_of_a_foreign_mcap_file_exits_2(tmp_path):
    foreign = tmp_path / "other.mcap"
    with foreign.open("wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema("x", "jsonschema", b"{}")
        channel = writer.register_channel("/chatter", "json", schema)
        writer.add_message(channel, log_time=0, data=json.dumps({"a": 1}).encode(), publish_time=0)
        writer.finish()
    for command in ("replay", "verify"):
        assert_bad_input(marsupial(command, str(foreign)), "not a marsupial run log")


class BadStatus(Skill):
    """Returns a number instead of a status on its fourth tick (a plug-in bug)."""

    class Params(NodeParams):
        """No parameters."""

    uses_robot = False

    def start(self) -> None:
        self.ticks = 0

    def step(self) -> Status:
        self.ticks += 1
        return Status.RUNNING if self.ticks < 4 else 3  # type: ignore[return-value]


def test_a_tick_that_returns_no_status_ends_the_run_with_a_named_error(tmp_path):
    text = BASE.replace(
        "tree:\n  skill: wait\n  params: {seconds: 0.5}\n",
        "plugins: {wait: test_hostile_input:BadStatus}\ntree: {skill: wait, name: buggy}\n",
    )
    result = run_mission(mission_file(tmp_path, text), progress=False, log_path=tmp_path / "run.mcap")
    assert result.outcome == "error"
    assert "BadStatus 'buggy' returned 3 from its tick; expected a py_trees Status" in result.message
    assert result.ticks == 3  # the summary counts the ticks completed before the error (not 0)
    from marsupial.trees.replay import read_log

    log = read_log(tmp_path / "run.mcap")
    assert log.outcome == "error" and log.sim_time == pytest.approx(result.sim_time)


def test_verify_works_from_the_log_alone(tmp_path):
    folder = tmp_path / "project"
    (folder / "subtrees").mkdir(parents=True)
    (folder / "subtrees" / "pause.yaml").write_text(
        "subtree: pause\nparams: {s: 0.3}\ntree: {skill: wait, params: {seconds: '${s}'}}\n"
    )
    tree = "tree:\n  sequence:\n    - {subtree: pause, params: {s: 0.2}}\n    - {skill: wait, params: {seconds: 0.1}}\n"
    path = mission_file(folder, BASE.replace("tree:\n  skill: wait\n  params: {seconds: 0.5}\n", tree))
    log = tmp_path / "run.mcap"
    assert marsupial("run", str(path), "--log", str(log), "--quiet").returncode == 0
    (folder / "subtrees" / "pause.yaml").unlink()  # the files on disk are gone or changed ...
    path.write_text("mission: changed\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    result = marsupial("verify", str(log), cwd=elsewhere)  # ... and verify runs from another folder
    assert result.returncode == 0 and "verified" in result.stdout, result.stderr
