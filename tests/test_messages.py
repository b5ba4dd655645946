"""The tick exchange: the contract without the simulator, isolated trees, and recorded inputs replayed into skills."""

from __future__ import annotations

import base64
import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

from marsupial.trees import exchange_log
from marsupial.trees.against import replay_against
from marsupial.trees.cli import cli
from marsupial.trees.errors import MissionError
from marsupial.trees.replay import compare_events, read_log
from marsupial.trees.runner import run_mission


def test_the_plugin_contract_imports_without_pybullet_or_opencv():
    code = (
        "import sys; sys.modules['pybullet'] = None; sys.modules['cv2'] = None\n"
        "import marsupial.api, marsupial.api.views, marsupial.api.ticks, marsupial.api.commands\n"
        "import marsupial.api.readings, marsupial.api.model, marsupial.api.capabilities, marsupial.api.priors\n"
        "import marsupial.api.tags, marsupial.api.silhouette, marsupial.trees.skill\n"
        "assert 'pybullet' not in {m for m in sys.modules if sys.modules[m] is not None}\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A demo_hover run (20 s) logged with its recorded inputs."""
    log = tmp_path_factory.mktemp("replay") / "demo.mcap"
    result = run_mission("demo_hover", log_path=log, until=20.0, progress=False, record_inputs=True)
    assert result.outcome in ("success", "time_limit"), result.message
    return log


def test_the_unchanged_mission_answers_its_recorded_inputs_as_logged(recorded: Path):
    result = replay_against(recorded, "demo_hover")
    assert result.identical and result.ticks > 100 and result.commands > 100
    out = CliRunner().invoke(cli, ["replay", str(recorded), "--against", "demo_hover"])
    assert out.exit_code == 0 and out.output.startswith("identical: ")


def test_a_changed_parameter_diverges_at_the_first_tick_it_matters(recorded: Path):
    out = CliRunner().invoke(cli, ["replay", str(recorded), "--against", "demo_hover",
                                   "--set", "params.cruise_height=2.0"])
    assert out.exit_code == 1
    first, logged, replayed = out.output.splitlines()[:3]
    assert first.startswith("diverged at tick 2 (t = 0.100 s), node 'take off':")
    assert logged.strip().startswith("logged:   FlyVelocity(robot='uav'")
    assert replayed.strip().startswith("replayed: FlyVelocity(robot='uav'")


def test_a_log_without_recorded_inputs_is_refused(tmp_path: Path):
    log = tmp_path / "plain.mcap"
    run_mission("demo_hover", log_path=log, until=1.0, progress=False)
    out = CliRunner().invoke(cli, ["replay", str(log), "--against", "demo_hover"])
    assert out.exit_code == 2 and "has no recorded inputs" in out.output


def test_a_record_naming_foreign_code_is_refused():
    class Evil:
        def __reduce__(self):
            return (print, ("pwned",))

    text = base64.b64encode(pickle.dumps(Evil())).decode()
    with pytest.raises(exchange_log.ExchangeLogError, match="builtins.print, which is not one of"):
        exchange_log.decode(text)


def test_images_travel_lossless_and_smaller():
    import numpy as np

    rng = np.random.default_rng(0)
    rgb = np.zeros((120, 160, 3), dtype=np.uint8)
    rgb[40:80, 50:110] = rng.integers(0, 255, (40, 60, 3), dtype=np.uint8)
    text = exchange_log.encode({"frame": rgb})
    assert np.array_equal(exchange_log.decode(text)["frame"], rgb)
    assert len(base64.b64decode(text)) < rgb.nbytes / 2


@pytest.mark.slow
def test_an_isolated_tree_records_the_same_run(tmp_path: Path):
    logs = {}
    for isolate in (False, True):
        logs[isolate] = tmp_path / f"{isolate}.mcap"
        result = run_mission("demo_hover", log_path=logs[isolate], progress=False, isolate=isolate)
        assert result.outcome == "success", result.message
    assert compare_events(read_log(logs[False]), read_log(logs[True])) == []


def test_a_skill_that_crashes_in_the_isolated_tree_leaves_a_valid_log(tmp_path: Path):
    plugin = tmp_path / "crashing.py"
    plugin.write_text(textwrap.dedent('''
        from marsupial.trees.skill import Skill

        class Crash(Skill):
            """Raises at its third tick."""

            uses_robot = False

            def start(self):
                self.ticks = 0

            def step(self):
                self.ticks += 1
                if self.ticks == 3:
                    raise ValueError("boom")
                from py_trees.common import Status
                return Status.RUNNING
    '''))
    mission = tmp_path / "crash.yaml"
    mission.write_text(textwrap.dedent("""\
        mission: crash
        plugins: {crash: crashing:Crash}
        team: {uav: {robot: bebop2, pose: [0, 0, 0, 0]}}
        tree: {skill: crash}
    """))
    sys.path.insert(0, str(tmp_path))
    try:
        result = run_mission(mission, log_path=tmp_path / "crash.mcap", progress=False, isolate=True)
    finally:
        sys.path.remove(str(tmp_path))
    assert result.outcome == "error" and "ValueError: boom" in result.message and "isolated tree" in result.message
    log = read_log(tmp_path / "crash.mcap")  # a valid MCAP: read back whole
    assert log.outcome == "error" and [e["kind"] for e in log.events][0] == "run_start"


def test_a_mission_whose_team_differs_from_the_run_is_refused(recorded: Path, tmp_path: Path):
    other = tmp_path / "other.yaml"
    other.write_text(textwrap.dedent("""\
        mission: other
        team: {drone: {robot: bebop2, pose: [0, 0, 0, 0]}}
        tree: {skill: hover, robot: drone}
    """))
    with pytest.raises(MissionError, match=r"the mission's team \['drone'\] is not the run's \['uav'\]"):
        replay_against(recorded, other)
