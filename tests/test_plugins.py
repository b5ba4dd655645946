"""Plug-ins: the example distribution's skill swapped in by a pin, duplicates without a pin, bad pins."""

import importlib
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

from marsupial.trees.cli import cli
from marsupial.trees.compiler import compile_mission
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import load_mission
from marsupial.trees.registry import Registry, installed
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "plugin-example"


@pytest.fixture(scope="module")
def plugin_dir(tmp_path_factory):
    """The example plug-in installed (pip, from a built wheel) into a private --target folder."""
    work = tmp_path_factory.mktemp("plugin")
    source = shutil.copytree(EXAMPLE, work / "src")  # keep build artefacts out of the repository
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    built = subprocess.run(
        [*pip, "wheel", "--no-deps", "-w", str(work / "dist"), str(source)], capture_output=True, text=True
    )
    assert built.returncode == 0, built.stderr
    [wheel] = (work / "dist").glob("*.whl")
    target = work / "site"
    done = subprocess.run(
        [*pip, "install", "--no-deps", "--target", str(target), str(wheel)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    return target


@pytest.fixture
def with_plugin(plugin_dir):
    """Make the installed example visible to entry-point discovery for one test."""
    sys.path.insert(0, str(plugin_dir))
    importlib.invalidate_caches()
    installed.cache_clear()
    yield plugin_dir
    sys.path.remove(str(plugin_dir))
    for name in [m for m in sys.modules if m.startswith("marsupial_plugin_example")]:
        del sys.modules[name]
    installed.cache_clear()


def test_pinned_plugin_skill_runs_in_place_of_the_builtin(with_plugin, tmp_path):
    providers = Registry().providers("skill", "hover")
    assert sorted(p.distribution for p in providers) == ["marsupial", "marsupial-plugin-example"]
    log_path = tmp_path / "plugin.mcap"
    result = run_mission(str(EXAMPLE / "mission.yaml"), log_path=log_path, progress=False, until=30)
    assert result.outcome == "success"
    log = read_log(log_path)
    t, drift = log.metric("hover_drift", robot="uav")
    assert len(t) >= 19 and drift.max() < 0.3  # 2 s of hovering at 10 Hz, held in place
    [hover] = [e for e in log.events_of("outcome") if e["skill"] == "hover"]
    assert hover["status"] == "SUCCESS"


def test_a_name_from_two_distributions_needs_a_pin(with_plugin):
    with pytest.raises(MissionError) as info:
        compile_mission(load_mission("demo_hover"))
    text = str(info.value)
    assert "skill 'hover' is provided by" in text
    assert "marsupial (marsupial.skills.generic:Hover)" in text
    assert "marsupial-plugin-example (marsupial_plugin_example.hover:MeteredHover)" in text
    assert "demo_hover.yaml:" in text and "plugins:" in text


def test_skills_command_lists_plugin_nodes(with_plugin):
    result = CliRunner().invoke(cli, ["skills"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert "marsupial-plugin-example: marsupial_plugin_example.hover:MeteredHover" in result.output
    assert "condition altitude_above" in result.output and "max_drift" in result.output


@pytest.mark.parametrize(
    "pin, message",
    [
        ("marsupial.trees.errors:MissionError", "is not a Skill"),
        ("no_such_package.nodes:Hover", "cannot import module 'no_such_package.nodes'"),
        ("marsupial.skills.generic:Hovr", "has no 'Hovr'; did you mean 'Hover'?"),
    ],
)
def test_bad_pins_are_reported_at_the_plugins_entry(tmp_path, pin, message):
    path = tmp_path / "m.yaml"
    path.write_text(textwrap.dedent(f"""\
        mission: pinned
        team:
          uav: {{robot: bebop2}}
        plugins:
          hover: {pin}
        tree: {{skill: hover, robot: uav}}
    """))
    with pytest.raises(MissionError) as info:
        compile_mission(load_mission(str(path)))
    assert message in str(info.value)
    assert (info.value.line, info.value.key_path) == (5, ("plugins", "hover"))
