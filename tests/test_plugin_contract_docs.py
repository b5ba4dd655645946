"""docs/plugins.md and docs/sensing.md say what the plug-in contract is: their tables follow the code.

- the opening skill of docs/plugins.md stays a complete skill in under 40 lines;
- the capabilities table names every capability of ``marsupial.api.capabilities`` with exactly the robot
  kinds whose views provide it;
- the views table names every robot kind's view class and every command of it;
- the readings table of docs/sensing.md names the reading type of every kind of sensor the robots carry;
- no page names a module or an interface the contract replaced.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from marsupial.api import capabilities
from marsupial.api.views import WheeledView
from marsupial.world import World
from marsupial.world.gateway import RobotGateway

ROOT = Path(__file__).resolve().parents[1]
PLUGINS = (ROOT / "docs" / "plugins.md").read_text()
SENSING = (ROOT / "docs" / "sensing.md").read_text()
KINDS = ("bebop2", "ardrone2", "tello", "summit_xl", "mobile_manipulator", "child_ugv", "mother_ugv", "mms")
#: names of what the contract replaced, and where it went
STALE = {
    "marsupial.world.capabilities": "marsupial.api.capabilities",
    "marsupial.world.errors": "marsupial.api.errors",
    "marsupial.world.kinematics": "marsupial.api.kinematics",
    "marsupial.world.onboard": "marsupial.api.views",
    "marsupial.world.ugv_criterion": "marsupial.tools.ugv_criterion",
    "context.onboard": "self.member(name)",
    "onboard interface": "the robot's view",
    "CommandPort": "the node's outbox (marsupial.trees.arbitration)",
    "SensorPort": "a view's sensor(name)",
    "truth_trap": "tests/reachability.py",
}


@pytest.fixture(scope="module")
def views() -> dict[str, type]:
    """The view class of every robot kind."""
    with World() as world:
        return {kind: world.add_robot(kind, kind).view_class for kind in KINDS}


def _table_rows(text: str, heading: str) -> list[list[str]]:
    """The cells of the first table under ``heading`` (a markdown heading line), its header and rule left out."""
    lines = text.split(heading, 1)[1].splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    end = next((i for i in range(start, len(lines)) if not lines[i].startswith("|")), len(lines))
    return [[cell.strip() for cell in line.strip("|").split("|")] for line in lines[start + 2:end]]


def _names(cell: str) -> set[str]:
    return set(re.findall(r"`([^`]+)`", cell))


def test_the_opening_skill_is_complete_in_under_40_lines() -> None:
    opening = PLUGINS.split("## A complete skill", 1)[1]
    code = opening.split("```python\n", 1)[1].split("\n```", 1)[0]
    assert len(code.splitlines()) < 40
    assert "class Orbit(Skill[" in code and "sensors = (" in code and "claims = (" in code


def test_the_capabilities_table_follows_the_views(views: dict[str, type]) -> None:
    rows = {_names(row[0]).pop(): row[2] for row in _table_rows(PLUGINS, "## Capabilities and resources")}
    assert set(rows) == {cap.__name__ for cap in capabilities.CAPABILITIES}
    wheeled = {kind for kind, view in views.items() if issubclass(view, WheeledView)}
    for cap in capabilities.CAPABILITIES:
        kinds = {kind for kind, view in views.items() if capabilities.provides(view, cap)}
        if rows[cap.__name__] == "every wheeled kind":
            assert kinds == wheeled, cap.__name__
        else:
            assert _names(rows[cap.__name__]) == kinds, cap.__name__


def test_the_views_table_names_every_view_and_command(views: dict[str, type]) -> None:
    rows = _table_rows(PLUGINS, "## Views: the robot as a node sees it")
    table = "\n".join("|".join(row) for row in rows)
    for kind, view in views.items():
        [row] = [r for r in rows if f"`{view.__name__}`" in r[0]]
        assert f"`{kind}`" in row[1], (kind, view.__name__)
        for command in view.commands:
            assert command.rpartition(".")[2] in table, (view.__name__, command)


def test_the_readings_table_names_every_sensor_kind() -> None:
    table = SENSING.split("## Which sensors are delivered, and what a reading holds", 1)[1].split("\n## ", 1)[0]
    with World(noise_scale=0.0) as world:
        robots = [world.add_robot(kind, kind) for kind in KINDS]
        world.step(0.5)
        for robot in robots:
            for name, facts in RobotGateway(robot).model().sensors.items():
                if not facts.queued:  # cameras and LiDARs: not rendered here (their types are named below)
                    continue
                reading = robot.sensor(name).read()
                assert reading is not None, (robot.kind, name)
                data = type(reading.data).__name__
                assert f"`{data}" in table, (robot.kind, name, data)
    for name in ("CameraImage", "RangeScan"):
        assert f"`{name}(" in table


@pytest.mark.parametrize("page", sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"], ids=lambda p: p.name)
def test_no_page_names_what_the_contract_replaced(page: Path) -> None:
    text = page.read_text()
    found = [f"{old} (now {new})" for old, new in STALE.items() if old.lower() in text.lower()]
    assert found == [], f"{page.name}: {found}"
