"""The metric registry: declarations are checked, every metric the code records is declared, docs/logs.md's
table is the registry's, and values reduce and read as their aggregation says. The end-of-run summary and the
progress line built on it (the runs' logs read back)."""

from __future__ import annotations

import ast
import io
from pathlib import Path

import pytest
from rich.console import Console

from marsupial.trees import metrics
from marsupial.trees.metrics import MetricSpec
from marsupial.trees.progress import RobotStatus, progress_text
from marsupial.trees.runner import run_mission

ROOT = Path(__file__).resolve().parents[1]
RECORDING_CODE = [*sorted((ROOT / "skills").rglob("*.py")), *sorted((ROOT / "world").rglob("*.py")),
                  *sorted((ROOT / "trees").rglob("*.py"))]
TABLE_START = "<!-- metric table: generated from marsupial.trees.metrics.markdown_table() -->\n"
TABLE_END = "<!-- end of the metric table -->"


def recorded_names(path: Path) -> list[tuple[int, str]]:
    """(line, name) of every ``….metric("name", …)`` call with a literal name in ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "metric"
                and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            found.append((node.lineno, node.args[0].value))
    return found


def test_every_metric_the_code_records_is_declared():
    """Short runs miss metrics recorded late (ground_landing): every literal metric name in the code is declared."""
    calls = [(path, line, name) for path in RECORDING_CODE for line, name in recorded_names(path)]
    assert len(calls) >= 30
    missing = [f"{path.relative_to(ROOT)}:{line}: {name}" for path, line, name in calls
               if metrics.spec(name) is None]
    assert missing == []


def test_an_undeclared_metric_is_found():
    assert metrics.undeclared(["battery_soc[uav]", "docking_time", "no_such_metric[uav,x]"]) == ["no_such_metric"]


@pytest.mark.parametrize("kwargs, message", [
    ({"name": "a[b]", "unit": "m", "meaning": "x"}, "without '['"),
    ({"name": "a", "unit": "m", "meaning": "x", "aggregation": "median"}, "aggregation 'median'"),
    ({"name": "a", "unit": "", "meaning": "x"}, "a unit and a one-line meaning"),
    ({"name": "a", "unit": "m", "meaning": "two\nlines"}, "a unit and a one-line meaning"),
])
def test_a_bad_declaration_is_refused(kwargs, message):
    with pytest.raises(ValueError, match=message.replace("[", r"\[")):
        MetricSpec(**kwargs)


def test_a_metric_declared_twice_differently_names_both_owners():
    first = MetricSpec("test_twice", "m", "a length")
    metrics.declare(first, owner="pkg.a:A")
    metrics.declare(first, owner="pkg.b:B")  # the same declaration again: fine
    with pytest.raises(ValueError) as info:
        metrics.declare(MetricSpec("test_twice", "s", "a time"), owner="pkg.c:C")
    assert "pkg.c:C" in str(info.value) and "pkg.a:A, pkg.b:B" in str(info.value)
    assert metrics.owners("test_twice[uav]") == ("pkg.a:A", "pkg.b:B")


def test_docs_logs_table_is_the_registry():
    text = (ROOT / "docs" / "logs.md").read_text()
    assert TABLE_START in text and TABLE_END in text
    table = text.split(TABLE_START, 1)[1].split(TABLE_END, 1)[0]
    expected = metrics.markdown_table()
    assert table == expected, f"regenerate the table of docs/logs.md:\n{expected}"
    assert "| `docking_time` | s | each |" in table and "| `battery_soc` | fraction | last |" in table


@pytest.mark.parametrize("aggregation, values, reduced, text", [
    ("last", [0.9, 0.8], 0.8, "80.0 %"),
    ("max", [0.1, 0.3, 0.2], 0.3, "max 0.3 m"),
    ("mean_abs", [0.1, -0.3], 0.2, "mean |·| 0.2 m"),
    ("total", [0, 1, 2], 2.0, "2"),
    ("each", [5.5, 7.1], 7.1, "5.5 s, 7.1 s"),
    ("count", [1.0, 1.0, 1.0], 3.0, "3 times"),
])
def test_values_reduce_and_read_as_their_aggregation_says(aggregation, values, reduced, text):
    unit = {"last": "fraction", "total": "count", "each": "s", "count": "flag"}.get(aggregation, "m")
    spec = MetricSpec("x", unit, "a quantity", aggregation)
    assert metrics.reduce(aggregation, values) == pytest.approx(reduced)
    assert metrics.summarize(spec, values) == text


def test_progress_line_labels_its_values():
    robots = [RobotStatus("uav", ("explore",), 0.97), RobotStatus("carrier", ())]
    text = progress_text(120.0, 900.0, 12.0, False, robots)
    assert text.startswith("t 120.0 / 900.0 s (13 %) · 10.0× real time · ETA ≤ 1 min 18 s")
    assert text.endswith("uav: explore, battery 97 % · carrier: idle")
    assert "no time limit" in progress_text(5.0, None, 1.0, False, robots)
    assert "PAUSED by the operator" in progress_text(5.0, 10.0, 1.0, True, robots)


def summary_of(tmp_path: Path, **kwargs) -> str:
    out = io.StringIO()
    result = run_mission("demo_hover", console=Console(file=out, width=200), **kwargs)
    assert result.outcome == "success"
    return out.getvalue()


def test_summary_tells_the_milestones_and_the_metrics_with_units(tmp_path):
    text = summary_of(tmp_path, log_path=tmp_path / "run.mcap")
    assert "success  (the mission's tree succeeded)" in text and "of the 60 s time limit" in text
    assert "reached (0.0, 0.0, 1.5) m at 2.2 s (take off)" in text and "(land, motors off)" in text
    assert "battery_soc" in text and "%" in text and "battery state of charge" in text


def test_summary_without_a_log_says_where_milestones_are(tmp_path):
    text = summary_of(tmp_path)
    assert "milestones: in the log (this run wrote none)" in text and "battery state of charge" in text
