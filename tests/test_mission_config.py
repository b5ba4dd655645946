"""The typed mission sections (marsupial.api.config) agree with the world that consumes them.

Team members are validated per robot kind when the mission loads: each kind's options must be keyword options of
its robot's constructor, its sensor settings the kind's sensors with the fields each sensor takes, so that a
mission that loads builds its world. Every mission the project ships loads, builds its world and meets the
JSON Schema (``marsupial schema``), which describes the typed sections too; docs/missions.md documents every key
of the schema, and every key of a typed section in a table beside its siblings.
"""

from __future__ import annotations

import dataclasses
import inspect
import re
from pathlib import Path
from typing import get_args

import pytest

import marsupial.api.config as config
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import load_mission, mission_dir, mission_schema
from marsupial.trees.mission.validation import tag_map
from marsupial.trees.runner import build_world
from marsupial.trees.yaml_source import load_yaml
from marsupial.world.robots import ROBOT_KINDS, robot_class
from marsupial.world.robots.diff_drive import DiffDriveLimits
from marsupial.world.robots.docking_device import DockingDevice
from marsupial.world.robots.mobile_manipulator import ARM_POSES
from marsupial.world.sensors.base import SensorConfig
from marsupial.world.sensors.camera import Intrinsics
from marsupial.world.sensors.lidar import LidarSpec

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "missions.md"
KINDS = tag_map(config.TeamMember)
SHIPPED = sorted(mission_dir().glob("*.yaml")) + sorted((ROOT / "benchmarks" / "missions").glob("*.yaml")) + [
    ROOT / "examples" / "plugin-example" / "mission.yaml"
]


def _fields(cls) -> set[str]:
    return {f.name for f in dataclasses.fields(cls)}


def test_every_robot_kind_has_a_configuration_model():
    assert set(KINDS) == set(ROBOT_KINDS)


@pytest.mark.parametrize("kind", sorted(ROBOT_KINDS))
def test_options_and_sensors_are_what_the_robot_takes(kind):
    model = KINDS[kind]
    constructor = inspect.signature(robot_class(kind).__init__).parameters
    options = model.model_fields["options"].annotation
    assert set(options.model_fields) <= set(constructor) - {"self", "world", "name", "pose", "sensors"}
    declared = robot_class(kind).declared_sensors()
    if "sensors" in model.model_fields:
        assert "sensors" in constructor
        assert set(model.model_fields["sensors"].annotation.model_fields) == declared
    else:
        assert "sensors" not in constructor


def test_settings_models_have_the_fields_the_world_reads():
    sampling = _fields(SensorConfig)
    assert set(config.SensorSettings.model_fields) == sampling
    assert set(config.CameraSettings.model_fields) == sampling | _fields(Intrinsics) | {
        "segmentation", "depth_noise_per_m"}
    assert set(config.LidarSettings.model_fields) == sampling | _fields(LidarSpec)
    assert set(config.DriveLimits.model_fields) == _fields(DiffDriveLimits)
    keywords = {p.name for p in inspect.signature(DockingDevice).parameters.values() if p.kind is p.KEYWORD_ONLY}
    assert set(config.DockingSettings.model_fields) == keywords
    names = get_args(tag_map(config.MobileManipulatorOptions.model_fields["arm_pose"].annotation)["text"])
    assert set(names) == set(ARM_POSES)


def test_only_the_keys_written_reach_the_constructor():
    member = config.MobileManipulatorConfig.model_validate({
        "robot": "mobile_manipulator", "sensors": {"lidar": {"rate_hz": 10}}, "options": {"docking": {"charger": False}}
    })
    assert member.constructor_options() == {"docking": {"charger": False}, "sensors": {"lidar": {"rate_hz": 10.0}}}
    assert config.SummitXLConfig.model_validate({"robot": "summit_xl"}).constructor_options() == {}


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_shipped_mission_loads_and_builds_its_world(path):
    mission = load_mission(path)
    build_world(mission, mission.spec.world.seed).close()


def test_the_json_schema_describes_the_typed_sections():
    jsonschema = pytest.importorskip("jsonschema")
    validator = jsonschema.Draft202012Validator(mission_schema())
    for path in SHIPPED:  # the sections other than the tree (the schema flags ``${name}`` in a number field)
        validator.validate({**load_yaml(path.read_text()).data, "tree": {"idle": True}})
    team = {"carrier": {"robot": "mobile_manipulator", "options": {"motors_on": False}}}  # a quadrotor's option
    assert not validator.is_valid({"mission": "m", "team": team, "tree": {"idle": True}})
    wind = {"disturbances": {"wind": {"gust": True}}}
    assert not validator.is_valid({"mission": "m", "world": wind, "tree": {"idle": True}})
    occlusion = {"disturbances": {"occlusion": {"robot": "uav", "link": "tag_bundle"}}}  # one entry without a list
    assert validator.is_valid({"mission": "m", "world": occlusion, "tree": {"idle": True}})


def _table_keys(text: str) -> list[set[str]]:
    """The keys (first column, in backticks) of each markdown table of ``text``."""
    tables: list[set[str]] = []
    previous = ""
    for line in text.splitlines():
        if line.startswith("|"):
            if not previous.startswith("|"):
                tables.append(set())
            tables[-1].update(re.findall(r"^\| `([\w.]+)`", line))
        previous = line
    return tables


def test_docs_document_every_mission_key():
    text = DOCS.read_text()
    schema = mission_schema()
    keys = set(schema["properties"]) | {key for d in schema["$defs"].values() for key in d.get("properties", {})}
    undocumented = sorted(k for k in keys if not re.search(rf"`(?:[\w.]+\.)?{re.escape(k)}[`.:= ]", text))
    assert not undocumented, f"docs/missions.md does not mention {undocumented}"
    tables = _table_keys(text)
    models = [m for m in vars(config).values() if isinstance(m, type) and issubclass(m, config.ConfigModel)]
    for model in models:
        own = set(vars(model).get("__annotations__", {})) & set(model.model_fields)
        assert any(own <= table for table in tables), f"docs/missions.md has no table of {model.__name__}: {own}"


def test_overrides_know_the_keys_of_the_robot_kind():
    overrides = {"team.uav.options.motors_on": "true", "team.uav.sensors.sonar.rate_hz": "10",
                 "world.disturbances.wind.gust": "2"}
    mission = load_mission("demo_hover", overrides)  # sections the file leaves out are made
    assert mission.spec.team["uav"].constructor_options() == {"motors_on": True, "sensors": {"sonar": {"rate_hz": 10}}}
    assert mission.spec.world.disturbances.given() == {"wind": {"gust": 2.0}}
    with pytest.raises(MissionError, match="expected one of team.uav.options.battery_capacity_mAh, "
                                           "team.uav.options.battery_soc, team.uav.options.motors_on; did you mean"):
        load_mission("demo_hover", {"team.uav.options.motor_on": "true"})
