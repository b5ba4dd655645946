"""The sensing boundary holds by construction: nothing a node holds leads to the simulator or the referee.

Two checks (``docs/sensing.md``):

- static: no module under ``skills/`` (nor the built-in conditions) imports
  pybullet, the simulator or the runtime's world side, names an attribute
  that leads to a body, or uses the introspection that would dig past
  private names (``gc``, ``inspect``, ``sys._getframe``, ``vars()``,
  ``__dict__``, ``getattr``/``setattr`` of a private name);
- at run time: every shipped mission (and a small mission for every node no
  shipped mission uses) runs to its end while the object graph reachable
  from each of its nodes is walked (:mod:`tests.reachability`) at the node's
  first tick and every :data:`WALK_EVERY` ticks after; the first simulator
  object, world-side runtime object or referee score board reached fails the
  test with its path. Each mission's nodes must all have been ticked, so
  every registered node is ticked at least once in the suite.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import py_trees
import pytest
from reachability import first_forbidden

import marsupial.missions
import marsupial.skills
import marsupial.trees
from marsupial.trees import metrics
from marsupial.trees.compiler import compile_mission
from marsupial.trees.host import TreeHost
from marsupial.trees.mission import load_mission
from marsupial.trees.registry import Registry
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission

SKILLS_DIR = Path(marsupial.skills.__file__).resolve().parent
CONDITIONS = Path(marsupial.trees.__file__).resolve().parent / "conditions.py"
DECISION_CODE = sorted(SKILLS_DIR.rglob("*.py")) + [CONDITIONS]
MISSIONS_DIR = Path(marsupial.missions.__file__).resolve().parent
COVERAGE_DIR = Path(__file__).parent / "data" / "coverage_missions"

FORBIDDEN_MODULES = (
    "pybullet", "pybullet_utils", "gc", "inspect", "marsupial.world", "marsupial.trees.bridge",
    "marsupial.trees.runner", "marsupial.trees.isolation", "marsupial.trees.host", "marsupial.trees.recorder",
)
FORBIDDEN_ATTRIBUTES = frozenset({"world", "body_id", "client_id", "cid", "bullet", "__dict__", "_getframe"})
INTROSPECTION_CALLS = frozenset({"vars", "globals", "locals"})
#: ticks between two walks of a node's graph after its first tick
WALK_EVERY = 200
#: nodes of a mission's tree that its run does not tick, and why (they are ticked by another mission of the suite)
NOT_TICKED = {
    "aperture_scouts": {"scout_return", "scout_land"},  # scout_object's recall branch: the mission scripts no recall
    # landing_cycle's re-localisation: the platform is not lost in these runs (coverage: landing_relocalize)
    "landing_circular": {"relocalize"},
    "landing_linear": {"relocalize"},
    "landing_lifelong": {"relocalize"},
}


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


def _imports(node: ast.AST, path: Path) -> list[str]:
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if isinstance(node, ast.ImportFrom):
        base = _module_of(node, path)
        return [base] + [f"{base}.{alias.name}" for alias in node.names]
    return []


def _private_access(node: ast.Call) -> bool:
    """``getattr(x, "_name")`` / ``setattr(x, "_name", v)``: reaching a private attribute by its name."""
    return (
        isinstance(node.func, ast.Name) and node.func.id in ("getattr", "setattr", "delattr", "hasattr")
        and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant)
        and isinstance(node.args[1].value, str) and node.args[1].value.startswith("_")
    )


def _findings(node: ast.AST, path: Path) -> Iterator[str]:
    for module in _imports(node, path):
        if any(module == bad or module.startswith(bad + ".") for bad in FORBIDDEN_MODULES):
            yield f"{path.name}:{node.lineno}: imports {module}"  # type: ignore[attr-defined]
            break
    if isinstance(node, ast.Attribute) and node.attr in FORBIDDEN_ATTRIBUTES:
        yield f"{path.name}:{node.lineno}: uses .{node.attr}"
    if isinstance(node, ast.Call):
        if isinstance(node.func, ast.Name) and node.func.id in INTROSPECTION_CALLS:
            yield f"{path.name}:{node.lineno}: calls {node.func.id}()"
        if _private_access(node):
            yield f"{path.name}:{node.lineno}: reaches a private attribute by name"


def boundary_findings(path: Path) -> list[str]:
    """Where the decision-code module at ``path`` reaches past the sensing boundary (``file:line: what``)."""
    tree = ast.parse(path.read_text(), str(path))
    return [finding for node in ast.walk(tree) for finding in _findings(node, path)]


@pytest.mark.parametrize("path", DECISION_CODE, ids=lambda p: str(p.relative_to(p.parents[1])))
def test_decision_code_does_not_reach_the_world(path: Path) -> None:
    assert boundary_findings(path) == []


def test_the_static_check_finds_a_skill_reaching_the_world() -> None:
    bad = SKILLS_DIR / "_boundary_probe.py"
    bad.write_text(
        "import gc\nimport pybullet\n\ndef f(self):\n    getattr(self.robot, '_state')\n"
        "    return self.world.robot('uav').__dict__, vars(self)\n"
    )
    try:
        found = boundary_findings(bad)
    finally:
        bad.unlink()
    assert sorted(found) == [
        "_boundary_probe.py:1: imports gc",
        "_boundary_probe.py:2: imports pybullet",
        "_boundary_probe.py:5: reaches a private attribute by name",
        "_boundary_probe.py:6: calls vars()",
        "_boundary_probe.py:6: uses .__dict__",
        "_boundary_probe.py:6: uses .world",
    ]


# ----------------------------------------------------------------- reachability
SHIPPED = sorted(MISSIONS_DIR.glob("*.yaml"))
COVERAGE = sorted(COVERAGE_DIR.glob("*.yaml"))


def _kinds(path: Path) -> set[str]:
    """The registered node kinds a mission's tree uses (its subtrees inlined)."""
    py_trees.blackboard.Blackboard.clear()
    return {node.kind for node in compile_mission(load_mission(path)).nodes}


class _Walker:
    """Walks each node's reachable graph after its first tick and every :data:`WALK_EVERY` ticks; kinds ticked."""

    def __init__(self) -> None:
        self.ticked: set[str] = set()
        self.hits: list[str] = []
        self._walked: dict[int, int] = {}

    def after_tick(self, host: TreeHost) -> None:
        tick = host.context.arbiter.tick
        for node in host.nodes:
            if node.ticked != tick:
                continue
            self.ticked.add(node.kind)
            last = self._walked.get(id(node))
            if last is None or tick - last >= WALK_EVERY:
                self._walked[id(node)] = tick
                hit = first_forbidden(node, f"{node.kind} '{node.name}'")
                if hit is not None:
                    self.hits.append(hit)


@pytest.fixture
def walker(monkeypatch: pytest.MonkeyPatch) -> _Walker:
    """Every tree host of the test ticks with the walker watching."""
    watching = _Walker()
    tick = TreeHost.tick

    def walked_tick(self: TreeHost, message):  # type: ignore[no-untyped-def]
        output = tick(self, message)
        watching.after_tick(self)
        return output

    monkeypatch.setattr(TreeHost, "tick", walked_tick)
    return watching


#: missions run shorter, still to their end: ``landing_lifelong`` repeats ``landing_circular``'s cycle 50 times
#: (≈ 10 min of CPU); three cycles tick the same nodes through the same phases, rests between cycles included
SHORTENED = {"landing_lifelong": {"cycles": "3"}}


@pytest.mark.slow
@pytest.mark.parametrize("path", SHIPPED + COVERAGE, ids=lambda p: p.stem)
def test_no_node_can_reach_the_simulator_or_the_referee(path: Path, walker: _Walker, tmp_path: Path) -> None:
    """Nothing a node holds leads to the simulator; every node ticks; (the same run's log) every metric is declared."""
    py_trees.blackboard.Blackboard.clear()
    result = run_mission(path, progress=False, log_path=tmp_path / "run.mcap", overrides=SHORTENED.get(path.stem))
    assert result.outcome in ("success", "time_limit"), result.message
    assert walker.hits == [], walker.hits[0]
    recorded = read_log(tmp_path / "run.mcap").metrics
    assert metrics.undeclared(m["name"] for m in recorded) == []  # marsupial.trees.metrics
    expected = _kinds(path) - NOT_TICKED.get(path.stem, set())
    assert expected <= walker.ticked, f"never ticked: {sorted(expected - walker.ticked)}"


def test_every_registered_node_is_ticked_by_some_mission_of_the_suite(capsys: pytest.CaptureFixture[str]) -> None:
    registry = Registry({})
    registered = set(registry.names("skill")) | set(registry.names("condition"))
    used = {path.stem: _kinds(path) - NOT_TICKED.get(path.stem, set()) for path in SHIPPED + COVERAGE}
    with capsys.disabled():
        print("\nnodes ticked, by mission:")
        for name, kinds in sorted(used.items()):
            print(f"  {name}: {', '.join(sorted(kinds))}")
    assert registered <= set().union(*used.values()), sorted(registered - set().union(*used.values()))


def test_the_walk_finds_a_world_object_held_by_a_node() -> None:
    from marsupial.trees.skill import Skill
    from marsupial.world import World

    class Hoarder(Skill):
        """Keeps a world handle in a closure (what the walk must find)."""

    with World(seed=1) as world:
        node = Hoarder("hoarder")
        node.later = [lambda: world]  # type: ignore[attr-defined]
        hit = first_forbidden(node, "hoarder")
    assert hit is not None and hit.startswith("hoarder.later[0].<closure world> is a marsupial.world.world.World")
