"""Property: any mutation of a valid mission gives a located error (exit 2) or a valid run — never a crash or hang.

Hypothesis takes the shipped ``demo_hover`` mission (and a mission with every
typed section the world reads: robot options, sensor settings, disturbances,
mutated in those sections), replaces one value at a random key path (or adds
a key) with a hostile value — NaN, infinities,
booleans, strings, negative and huge numbers, empty or nested containers,
control characters — and then loads, compiles and runs the result for a
short simulated time. Allowed outcomes: a :class:`MissionError` whose text
starts with ``file:line:column:`` (what the CLI prints before exiting 2), or
a run that ends by itself or at its time limit (never with an exception in a
skill) and leaves a readable log.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import marsupial.missions
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import load_mission
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission

SOURCE = Path(marsupial.missions.__file__).resolve().parent / "demo_hover.yaml"
TYPED = Path(__file__).parent / "data" / "missions" / "typed_sections.yaml"
LOCATED = re.compile(r"^[^\n]+\.yaml:\d+:\d+: ")
OUTCOMES = {"success", "failure", "time_limit"}

HOSTILE = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, True, False, None, "", "x\x07y", "${nope}", -1, 0, 1e308, -1e308,
                     2**70, [], {}, [[[]]], {"a": {"b": {}}}, "[1, 2]", 1e-300]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**65), max_value=2**65),
    st.text(max_size=8),
    st.lists(st.floats(allow_nan=False, allow_infinity=False, min_value=-50, max_value=50), max_size=5),
)


def key_paths(value: Any, path: tuple = ()) -> list[tuple]:
    """Every key path of a YAML value (mappings and lists), the root excluded."""
    paths = []
    if isinstance(value, dict):
        for key, child in value.items():
            paths += [path + (key,)] + key_paths(child, path + (key,))
    elif isinstance(value, list):
        for index, child in enumerate(value):
            paths += [path + (index,)] + key_paths(child, path + (index,))
    return paths


PATHS = key_paths(yaml.safe_load(SOURCE.read_text()))
TYPED_PATHS = [p for p in key_paths(yaml.safe_load(TYPED.read_text())) if p[0] in ("world", "team")]


def mutated(source: Path, path: tuple, value: Any, add_key: bool) -> dict:
    data = yaml.safe_load(source.read_text())
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    if add_key and isinstance(parent, dict):
        parent["unexpected_key"] = value
    else:
        parent[path[-1]] = value
    return data


def to_yaml(data: dict) -> str:
    """YAML text of ``data`` with NaN and infinities written the YAML way."""
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=10_000)


FUZZ = settings(
    max_examples=25,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


def fails_located_or_runs(folder: Path, data: dict, what: str) -> None:
    """Load and run ``data`` for at most 1 simulated second: a located error, or a run that ends without a crash."""
    mission_path = folder / "mutant.yaml"
    mission_path.write_text(to_yaml(data))
    try:
        mission = load_mission(mission_path)
        result = run_mission(
            mission, until=min(mission.spec.run.until or 1.0, 1.0), log_path=folder / "run.mcap", progress=False
        )
    except MissionError as err:
        assert LOCATED.match(str(err)), f"{what}: unlocated error {err}"
        return
    assert result.outcome in OUTCOMES, (what, result.outcome, result.message)  # no crash in a skill
    assert read_log(folder / "run.mcap").outcome == result.outcome


@pytest.mark.slow
@FUZZ
@given(path=st.sampled_from(PATHS), value=HOSTILE, add_key=st.booleans())
def test_a_mutated_mission_fails_located_or_runs(tmp_path_factory, path, value, add_key):
    data = mutated(SOURCE, path, value, add_key)
    fails_located_or_runs(tmp_path_factory.mktemp("fuzz"), data, f"{path}={value!r}")


@pytest.mark.slow
@FUZZ
@given(path=st.sampled_from(TYPED_PATHS), value=HOSTILE, add_key=st.booleans())
def test_a_mutated_typed_section_fails_located_or_runs(tmp_path_factory, path, value, add_key):
    data = mutated(TYPED, path, value, add_key)
    fails_located_or_runs(tmp_path_factory.mktemp("fuzz"), data, f"{path}={value!r}")


def test_the_unmutated_missions_run(tmp_path):
    for source in (SOURCE, TYPED):
        fails_located_or_runs(tmp_path, yaml.safe_load(source.read_text()), source.name)
        assert read_log(tmp_path / "run.mcap").outcome in OUTCOMES  # ran, not refused
