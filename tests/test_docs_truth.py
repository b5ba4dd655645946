"""The docs say what the code does: every Foxglove message path docs/logs.md shows finds data in a real log,
and every mention of the default mission names the one ``marsupial run`` runs."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from marsupial.trees.cli import DEFAULT_MISSION, cli
from marsupial.trees.mission import known_missions
from marsupial.trees.replay import RunLog, read_log
from marsupial.trees.runner import run_mission

ROOT = Path(__file__).resolve().parents[1]
LOGS_MD = ROOT / "docs" / "logs.md"
#: a message path in backticks: a topic, optional {field==value} filters, an optional .field[index] path
MESSAGE_PATH = re.compile(r"`(?P<topic>/[A-Za-z0-9_/]+?)(?P<filters>(?:\{[^}`]+\})*)(?P<path>(?:\.[A-Za-z0-9_]+"
                          r"|\[\d+\])*)`")
FILTER = re.compile(r"\{(?P<field>[A-Za-z0-9_.]+)==(?P<value>\"[^\"]*\"|[^}]+)\}")


def documented_paths(text: str) -> list[str]:
    """The message paths (with a filter or a field path, not bare topics) shown in ``text``."""
    return [m.group(0).strip("`") for m in MESSAGE_PATH.finditer(text) if m["filters"] or m["path"]]


def evaluate(log: RunLog, path: str) -> list[Any]:
    """The values a Foxglove message path selects in ``log`` (``/topic{f==v}.a.b[0]``: the subset the docs use)."""
    match = MESSAGE_PATH.fullmatch(f"`{path}`")
    assert match, f"not a message path: {path}"
    values: list[Any] = [m.data for m in log.messages(match["topic"])]
    for wanted in FILTER.finditer(match["filters"]):
        expected = json.loads(wanted["value"])
        values = [v for v in values if _get(v, wanted["field"].split(".")) == expected]
    steps = re.findall(r"\.([A-Za-z0-9_]+)|\[(\d+)\]", match["path"])
    return [_get(v, [int(i) if i else name for name, i in steps]) for v in values]


def _get(value: Any, keys: list[Any]) -> Any:
    for key in keys:
        value = value[key] if isinstance(key, int) else value.get(key) if isinstance(value, dict) else None
    return value


@pytest.fixture(scope="module")
def demo_log(tmp_path_factory) -> RunLog:
    log = tmp_path_factory.mktemp("demo") / "demo_hover.mcap"
    assert run_mission("demo_hover", log_path=log, progress=False).outcome == "success"
    return read_log(log)


def test_logs_md_shows_message_paths():
    paths = documented_paths(LOGS_MD.read_text())
    assert '/metrics{name=="battery_soc"}.value' in paths and len(paths) >= 4


@pytest.mark.parametrize("path", documented_paths(LOGS_MD.read_text()))
def test_every_documented_message_path_finds_data(demo_log, path):
    values = evaluate(demo_log, path)
    assert values and all(v is not None for v in values), f"{path} selects nothing in a demo_hover log"


def test_the_evaluator_finds_nothing_for_a_wrong_name(demo_log):
    assert evaluate(demo_log, '/metrics{name=="battery"}.value') == []  # the old name docs/logs.md used
    assert evaluate(demo_log, "/uav/pose.pose.place") == [None] * len(demo_log.messages("/uav/pose"))


def mentions_of_the_default() -> list[tuple[str, str]]:
    """(file:line, line) of every line of the docs, README and missions calling something the default mission."""
    files = [*sorted((ROOT / "docs").rglob("*.md")), ROOT / "README.md", *sorted((ROOT / "missions").glob("*.yaml"))]
    return [(f"{path.relative_to(ROOT)}:{number}", line) for path in files
            for number, line in enumerate(path.read_text().splitlines(), 1)
            if re.search(r"default (mission|demo)|\(the default\)", line)]


def test_the_default_mission_is_named_right_everywhere():
    mentions = mentions_of_the_default()
    assert len(mentions) >= 2
    for where, line in mentions:
        named = [name for name in known_missions() if re.search(rf"\b{name}\b", line)]
        assert named == [DEFAULT_MISSION], f"{where}: {line.strip()}"
    help_text = CliRunner().invoke(cli, ["run", "--help"]).output
    assert f"default: {DEFAULT_MISSION}" in help_text
