"""Typed skills: mypy refuses a command the robot's capability lacks and a value of the wrong type under a typed key."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from py_trees.common import Status

from marsupial.api.capabilities import Rotorcraft
from marsupial.api.keys import Key
from marsupial.trees.skill import NodeParams, Skill

ROOT = Path(__file__).resolve().parents[1]
#: import package -> folder, as pyproject.toml's package-dir maps them (mypy cannot follow the editable install)
PACKAGES = {"api": "api", "trees": "trees", "skills": "skills", "world": "world", "missions": "missions",
            "tools": "marsupial/tools"}


def _package_root(tmp_path: Path) -> Path:
    """A folder where ``marsupial`` is laid out as installed (links to the sources), for mypy."""
    package = tmp_path / "site" / "marsupial"
    if package.exists():
        return package.parent
    package.mkdir(parents=True)
    for module in (ROOT / "marsupial").glob("*.py"):
        (package / module.name).symlink_to(module)
    for name, folder in PACKAGES.items():
        (package / name).symlink_to(ROOT / folder, target_is_directory=True)
    return package.parent


def mypy(tmp_path: Path, code: str) -> str:
    """mypy's report on ``code`` (a module importing marsupial), with the project's configuration."""
    snippet = tmp_path / "snippet.py"
    snippet.write_text(textwrap.dedent(code))
    env = {**os.environ, "MYPYPATH": str(_package_root(tmp_path))}
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml"), "--cache-dir",
         str(tmp_path / "cache"), "--follow-imports", "silent", str(snippet)],
        capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600,
    )
    return done.stdout + done.stderr


SKILL = """\
from py_trees.common import Status

from marsupial.api.capabilities import Rotorcraft
from marsupial.api.keys import Key
from marsupial.trees.skill import NodeParams, Skill

HEIGHT: Key[float] = Key("{robot}/height", float)


class Climb(Skill[NodeParams, Rotorcraft]):
    \"\"\"Climbs; keeps the height it estimates on the blackboard.\"\"\"

    writes = (HEIGHT,)

    def step(self) -> Status:
        self.robot.%s(0.0, 0.0, 0.5)
        self.write(HEIGHT.at(robot=self.robot_name), %s)
        return Status.RUNNING
"""


@pytest.mark.slow
def test_mypy_accepts_a_typed_skill_and_refuses_a_missing_command_or_a_mistyped_value(tmp_path: Path) -> None:
    good = mypy(tmp_path, SKILL % ("command_velocity", "float(self.robot.estimate().position[2])"))
    assert "Success: no issues found" in good, good
    bad = mypy(tmp_path, SKILL % ("comand_velocity", "self.robot.estimate()"))
    assert '"Rotorcraft" has no attribute "comand_velocity"' in bad, bad
    # a StateEstimate under a Key[float]: no type fits both (mypy says so on the write's line)
    assert 'snippet.py:17: error: Cannot infer value of type parameter "V" of "write" of "MissionNode"' in bad, bad


def test_a_typed_key_refuses_a_value_of_another_type_at_run_time() -> None:
    height: Key[float] = Key("{robot}/height", float)

    class Writer(Skill[NodeParams, Rotorcraft]):
        writes = (height,)

        def step(self) -> Status:
            self.write(height.at(robot="uav"), "high")  # type: ignore[arg-type]
            return Status.RUNNING

    node = Writer("writer", robot="uav")
    assert node.write_keys(node.params, "uav") == ("uav/height",)
    with pytest.raises(TypeError, match="blackboard key 'uav/height' holds float, not str"):
        node.step()
