"""The sensing boundary holds: skills and conditions decide only from what the robots sense.

Two checks (``docs/world.md``, "Sensing boundary"):

- static: no module under ``skills/`` (nor the built-in conditions) imports
  pybullet or the world's bodies, scenes and contacts, or names an
  attribute that leads to the world or a body (``.world``, ``.body_id``,
  ``.client_id``, a robot's ``pose()``/``velocity()``/``link_pose()``);
- at run time: every shipped mission runs for a while with the truth trap
  (:mod:`tests.truth_trap`) installed, and no truth accessor may be reached
  from decision code.
"""

from __future__ import annotations

import ast
from pathlib import Path

import py_trees
import pytest
from truth_trap import truth_trap

import marsupial.missions
import marsupial.skills
import marsupial.trees
from marsupial.trees import metrics
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission

SKILLS_DIR = Path(marsupial.skills.__file__).resolve().parent
CONDITIONS = Path(marsupial.trees.__file__).resolve().parent / "conditions.py"
DECISION_CODE = sorted(SKILLS_DIR.rglob("*.py")) + [CONDITIONS]
MISSIONS_DIR = Path(marsupial.missions.__file__).resolve().parent

FORBIDDEN_MODULES = (
    "pybullet",
    "pybullet_utils",
    "marsupial.world.world",
    "marsupial.world.robots",
    "marsupial.world.scene",
    "marsupial.world.contacts",
    "marsupial.world.scoring",
    "marsupial.world.disturbances",
    "marsupial.world.estimation",
)
FORBIDDEN_ATTRIBUTES = frozenset({"world", "body_id", "client_id", "cid", "_robot", "bullet"})
#: private names of the onboard ports' classes: their internals hold the truth the ports filter
PRIVATE_PORT_PREFIXES = ("_Onboard", "_SensorPort", "_RunContext", "_DockingPort", "_LinkPort")
TRUTH_CALLS = frozenset({"pose", "velocity", "link_pose", "mounted_frame", "optical_pose", "platform_pose",
                         "acceleration", "distance_to", "offset_to", "in_contact", "part_a_pose", "part_b_pose"})
#: how long each shipped mission runs under the trap (s, simulated): long enough to reach its first skills
#: of every family (usar_docking's first operator docking is requested at 95 s)
TRAP_RUN_S = {"usar_docking": 140.0, "aperture_scouts": 180.0}
DEFAULT_TRAP_RUN_S = 25.0


def _module_of(node: ast.ImportFrom, path: Path) -> str:
    if node.level == 0:
        return node.module or ""
    package = (
        ["marsupial", "skills", *path.relative_to(SKILLS_DIR).parts[:-1]]
        if SKILLS_DIR in path.parents
        else ["marsupial", "trees"]
    )
    base = package[: len(package) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _model_fact(name: str) -> bool:
    """An importable fact of a robot's model.

    An UPPER_CASE constant or a ``…Limits``/``…Spec``/``…Gains``/``…Mount`` type.
    """
    return name.isupper() or name.endswith(("Limits", "Spec", "Gains", "Mount"))


def boundary_findings(path: Path) -> list[str]:
    """Where the decision-code module at ``path`` reaches past the sensing boundary (``file:line: what``)."""
    tree = ast.parse(path.read_text(), str(path))
    found = []
    for node in ast.walk(tree):
        modules: list[str] = []
        if isinstance(node, ast.Import):
            modules = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _module_of(node, path)
            if base.startswith("marsupial.world.robots") and all(_model_fact(alias.name) for alias in node.names):
                continue  # datasheet constants and spec types of the robots' models (no body, no world)
            modules = [base] + [f"{base}.{alias.name}" for alias in node.names]
        for module in modules:
            if any(module == bad or module.startswith(bad + ".") for bad in FORBIDDEN_MODULES):
                found.append(f"{path.name}:{node.lineno}: imports {module}")
                break
        if isinstance(node, ast.Attribute) and (
            node.attr in FORBIDDEN_ATTRIBUTES or node.attr.startswith(PRIVATE_PORT_PREFIXES)
        ):
            found.append(f"{path.name}:{node.lineno}: uses .{node.attr}")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in TRUTH_CALLS:
            found.append(f"{path.name}:{node.lineno}: calls .{node.func.attr}()")
    return found


@pytest.mark.parametrize("path", DECISION_CODE, ids=lambda p: str(p.relative_to(p.parents[1])))
def test_decision_code_does_not_reach_the_world(path: Path) -> None:
    assert boundary_findings(path) == []


def test_the_static_check_finds_a_skill_reaching_the_world() -> None:
    bad = SKILLS_DIR / "_boundary_probe.py"
    bad.write_text("import pybullet\n\ndef f(self):\n    return self.world.robot('uav').pose()\n")
    try:
        found = boundary_findings(bad)
    finally:
        bad.unlink()
    assert sorted(found) == [
        "_boundary_probe.py:1: imports pybullet",
        "_boundary_probe.py:4: calls .pose()",
        "_boundary_probe.py:4: uses .world",
    ]


SHIPPED = sorted(p.stem for p in MISSIONS_DIR.glob("*.yaml"))


@pytest.mark.parametrize("mission", SHIPPED)
def test_shipped_mission_decides_without_truth(mission: str, tmp_path: Path) -> None:
    """No truth read from decision code; and (the same run's log) every metric it records is declared."""
    py_trees.blackboard.Blackboard.clear()
    log = tmp_path / f"{mission}.mcap"
    with truth_trap() as trap:
        result = run_mission(mission, until=TRAP_RUN_S.get(mission, DEFAULT_TRAP_RUN_S), progress=False, log_path=log)
    assert result.outcome in ("success", "time_limit"), result.message
    assert trap.violations == [], trap.violations[0]
    recorded = read_log(log).metrics
    assert recorded and metrics.undeclared(m["name"] for m in recorded) == []  # marsupial.trees.metrics


def test_the_trap_catches_a_truth_read_from_a_skill() -> None:
    from skill_harness import Harness

    from marsupial.trees.skill import Skill
    from marsupial.world import World

    class Cheat(Skill):
        """Reads the body's true pose through the interface's private slot (what the trap must catch)."""

        def step(self):
            self.robot._onboard._Onboard__robot.pose()
            return py_trees.common.Status.SUCCESS

    with World(seed=1) as world, truth_trap() as trap:
        world.add_robot("bebop2", "uav", pose=[0, 0, 1, 0])
        harness = Harness(world)
        harness.run(harness.node(Cheat, robot="uav"), 0.2)
    assert trap.violations and "Robot.pose" in trap.violations[0]
