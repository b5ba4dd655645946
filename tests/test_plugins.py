"""Plug-ins: the example distribution's skill swapped in by a pin; a plug-in offering a shipped node's name leaves
shipped missions as they are (warned once); two other providers need a pin; bad pins; broken plug-ins listed."""

import importlib
import shutil
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import pytest
from click.testing import CliRunner

from marsupial.skills.generic import Hover
from marsupial.trees import metrics, registry
from marsupial.trees.cli import cli
from marsupial.trees.compiler import compile_mission
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import known_missions, load_mission
from marsupial.trees.registry import PluginCollision, Registry, installed
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


def visible(folder: Path, modules: str):
    """Make the distributions installed in ``folder`` visible to entry-point discovery (a generator: yield once)."""
    sys.path.insert(0, str(folder))
    importlib.invalidate_caches()
    installed.cache_clear()
    registry._reported.clear()
    yield folder
    sys.path.remove(str(folder))
    for name in [m for m in sys.modules if m.startswith(modules)]:
        del sys.modules[name]
    installed.cache_clear()
    registry._reported.clear()


@pytest.fixture
def with_plugin(plugin_dir):
    """Make the installed example visible to entry-point discovery for one test."""
    yield from visible(plugin_dir, "marsupial_plugin_example")


def fake_distribution(folder: Path, name: str, entry_points: str, module: str = "") -> Path:
    """A distribution ``name`` installed in ``folder``: its ``.dist-info`` with ``entry_points`` and a module."""
    info = folder / f"{name}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(entry_points)
    if module:
        (folder / f"{name}_nodes.py").write_text(module)
    return folder


@pytest.fixture
def with_fakes(tmp_path):
    """Two fake plug-ins: both offer a skill 'hover_twice' (no marsupial node has that name), one a broken 'orbit'."""
    module = "from marsupial.skills.generic import Hover\n\nclass Twice(Hover):\n    \"\"\"Hover, twice.\"\"\"\n"
    for name in ("fake_one", "fake_two"):
        fake_distribution(tmp_path, name, f"[marsupial.skills]\nhover_twice = {name}_nodes:Twice\n", module)
    fake_distribution(tmp_path, "fake_broken", "[marsupial.skills]\norbit = fake_broken_nodes:Orbit\n",
                      "raise ImportError('needs a library that is not installed')\n")
    yield from visible(tmp_path, "fake_")


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
    assert metrics.spec("hover_drift").unit == "m"  # the plug-in declares its metric


def test_a_plugin_offering_a_shipped_name_leaves_shipped_missions_as_they_are(with_plugin, tmp_path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for name in known_missions():
            compile_mission(load_mission(name))
        assert Registry().skill("hover") is Hover
        result = run_mission("demo_hover", log_path=tmp_path / "demo.mcap", progress=False)
    assert result.outcome == "success"
    [collision] = [w for w in caught if issubclass(w.category, PluginCollision)]  # once, however often resolved
    text = str(collision.message)
    assert "skill 'hover' is provided by marsupial (marsupial.skills.generic:Hover)" in text
    assert "and by marsupial-plugin-example (marsupial_plugin_example.hover:MeteredHover)" in text
    assert "missions use marsupial's unless they pin another" in text
    assert "plugins: {hover: marsupial_plugin_example.hover:MeteredHover}" in text
    assert "hover_drift" not in {m["name"] for m in read_log(tmp_path / "demo.mcap").metrics}


def test_the_cli_prints_the_collision_as_one_warning_line(with_plugin, tmp_path):
    result = CliRunner().invoke(cli, ["run", "demo_hover", "-q", "--no-log"])
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("warning:")]
    assert len(lines) == 1 and "skill 'hover' is provided by marsupial" in lines[0]


def test_a_name_from_two_other_distributions_needs_a_pin(with_fakes, tmp_path):
    path = tmp_path / "twice.yaml"
    path.write_text("mission: twice\nteam:\n  uav: {robot: bebop2}\ntree: {skill: hover_twice, robot: uav}\n")
    with pytest.raises(MissionError) as info:
        compile_mission(load_mission(str(path)))
    text = str(info.value)
    assert "'hover_twice' is provided by fake_one (fake_one_nodes:Twice) and fake_two (fake_two_nodes:Twice)" in text
    assert "twice.yaml:4:" in text and "plugins:" in text
    pinned = path.read_text() + "plugins: {hover_twice: fake_two_nodes:Twice}\n"
    path.write_text(pinned)
    assert type(compile_mission(load_mission(str(path))).root).__module__ == "fake_two_nodes"


def test_skills_command_lists_plugin_nodes(with_plugin):
    result = CliRunner().invoke(cli, ["skills"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert "[marsupial-plugin-example (marsupial_plugin_example.hover:MeteredHover)]" in result.output
    assert "altitude_above" in result.output and "condition" in result.output
    detail = CliRunner().invoke(cli, ["skills", "hover"], env={"COLUMNS": "200"})
    assert detail.exit_code == 0 and "max_drift" in detail.output and "hover_drift (m, max)" in detail.output


def test_skills_command_exits_1_when_a_plugin_cannot_be_loaded(with_fakes):
    result = CliRunner().invoke(cli, ["skills", "orbit"], env={"COLUMNS": "200"})
    assert result.exit_code == 1
    assert "error: skill 'orbit' of fake_broken (fake_broken_nodes:Orbit) cannot be loaded" in result.output
    assert "needs a library that is not installed" in result.output
    listing = CliRunner().invoke(cli, ["skills"], env={"COLUMNS": "200"})
    assert listing.exit_code == 1 and "cannot load" in listing.output and "goto" in listing.output
    assert CliRunner().invoke(cli, ["skills", "goto"]).exit_code == 0  # a healthy node is shown as usual


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
