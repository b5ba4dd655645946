"""Every ```yaml, ```python and ```toml snippet of docs/*.md and README.md is compiled or run.

Conventions (an HTML comment on the line before the fence, invisible when rendered):

- ```yaml with a top-level ``mission:`` key: a whole mission, loaded and compiled (subtrees from the
  package, or from files given on the same page);
- ``<!-- file: PATH -->``: a file at ``PATH`` (``missions/…``), written to a scratch folder where the
  page's missions are compiled (a mission file is compiled there too); a file that the package ships
  must equal the shipped one;
- ``<!-- fragment: node -->``: one tree node, compiled as the ``tree:`` of a mission with the team
  :data:`FRAGMENT_TEAM` (``carrier``, a mobile manipulator with the Bebop 2 ``uav``; ``ugv`` and ``drone``,
  a Summit XL with an AR.Drone 2);
- ``<!-- fragment: keys -->``: top-level mission keys (``world:``, ``team:`` …), loaded in a mission whose
  tree is ``{idle: true}`` and its world built (scene, robots, options, sensors, disturbances checked);
- ``<!-- fragment: scene -->``: a scene file, built in a world;
- ```python: compiled; with ``<!-- run -->`` executed too (and the ``test_*`` functions it defines
  called), the page's run snippets in one namespace (classes of one snippet are seen by the next);
- ```toml: parsed. The modules its ``marsupial.skills`` / ``marsupial.conditions`` entry points name
  (``my_pkg.orbit``) import as the page's namespace, and the page's missions get those entry points
  as ``plugins:`` pins, so a page's skill and condition classes are the ones its missions use.

A ```yaml snippet without a mission key or a comment fails the test: say what it is.
"""

from __future__ import annotations

import json
import re
import sys
import textwrap
import types
from pathlib import Path

import pytest

import marsupial.missions
from marsupial.trees.compiler import compile_mission
from marsupial.trees.mission import parse_mission
from marsupial.trees.runner import build_world
from marsupial.trees.skill import MissionNode
from marsupial.trees.yaml_source import load_yaml
from marsupial.world import World
from marsupial.world import scene as scene_module

tomllib = pytest.importorskip("tomllib")  # Python >= 3.11

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]
PACKAGE_MISSIONS = Path(marsupial.missions.__file__).resolve().parent
FRAGMENT_TEAM = {
    "carrier": {"robot": "mobile_manipulator", "pose": [0, 0, 0]},
    "uav": {"robot": "bebop2", "stored_on": "carrier"},
    "ugv": {"robot": "summit_xl", "pose": [5, 0, 0]},
    "drone": {"robot": "ardrone2", "stored_on": "ugv"},
}
SIMULATING_PAGES = {"world.md"}  # its run snippets step worlds for seconds: in the full tier only
_FENCE = re.compile(r"^(?:<!-- (?P<mark>[^>]*?) -->\n)?```(?P<lang>yaml|python|toml)\n(?P<body>.*?)^```$", re.M | re.S)


def snippets(page: Path) -> list[tuple[int, str, str, str]]:
    """(line, language, mark, text) of each checked snippet of ``page``, in page order."""
    text = page.read_text()
    found = [
        (text.count("\n", 0, m.start("body")), m["lang"], (m["mark"] or "").strip(), m["body"])
        for m in _FENCE.finditer(text)
    ]
    fences = len(re.findall(r"```(?:yaml|python|toml)\b", text))
    assert fences == len(found), f"{_ids(page)}: {fences - len(found)} snippet(s) not at the start of a line"
    return found


def _ids(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


def _run_python(page: Path, module: types.ModuleType, line: int, body: str, mark: str) -> None:
    """Compile a python snippet; a ``run`` one is executed, and the ``test_*`` functions it defines are called."""
    code = compile(body, f"{_ids(page)}:{line}", "exec")
    if mark == "run":
        before = set(module.__dict__)
        exec(code, module.__dict__)
        for name in sorted(set(module.__dict__) - before):
            if name.startswith("test_") and callable(module.__dict__[name]):
                module.__dict__[name]()


def _entry_points(tomls: list[str]) -> dict[str, str]:
    """Entry-point name -> ``package.module:Class`` of the marsupial groups of the page's toml snippets."""
    found = {}
    for text in tomls:
        groups = tomllib.loads(text).get("project", {}).get("entry-points", {})
        for group in ("marsupial.skills", "marsupial.conditions"):
            found.update(groups.get(group, {}))
    return found


def _serve(module: types.ModuleType, targets: dict[str, str], monkeypatch: pytest.MonkeyPatch) -> None:
    """Make the modules that the entry points name (``my_pkg.orbit``) import as the page's namespace."""
    for target in targets.values():
        parts = target.partition(":")[0].split(".")
        for depth in range(1, len(parts) + 1):
            monkeypatch.setitem(sys.modules, ".".join(parts[:depth]), module)


def _mission(body: str, pins: dict[str, str], prefix: str = "", indent: str = "") -> str:
    """Mission text: ``prefix``, then ``body`` indented by ``indent``, then the pins of the page's plug-ins."""
    text = prefix + textwrap.indent(body, indent)
    if pins and "plugins" not in load_yaml(text).data:
        text += "plugins: " + json.dumps(pins) + "\n"
    return text


def _write_file(page: Path, line: int, relative: str, body: str, scratch: Path) -> None:
    """Write a ``<!-- file: … -->`` snippet into ``scratch``; a file the package ships must be shown as shipped."""
    shipped = PACKAGE_MISSIONS.parent / relative
    if shipped.is_file():
        assert shipped.read_text() == body, f"{_ids(page)}:{line}: differs from the shipped {relative}"
    target = scratch / relative
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(body)


def _check_yaml(page: Path, line: int, body: str, mark: str, scratch: Path, pins: dict[str, str]) -> None:
    where = f"{_ids(page)}, snippet at line {line}"
    if mark.startswith("file:"):
        target = scratch / mark.removeprefix("file:").strip()
        if "mission" in (load_yaml(body).data or {}):
            compile_mission(parse_mission(_mission(body, pins), where, path=target))
        return
    data = load_yaml(body).data
    if mark == "fragment: node":
        prefix = f"mission: fragment\nteam: {json.dumps(FRAGMENT_TEAM)}\ntree:\n"
        text = _mission(body, pins, prefix, "  ")
        compile_mission(parse_mission(text, where, path=scratch / "missions" / "fragment.yaml"))
    elif mark == "fragment: scene":
        name = data["name"]
        (scratch / f"{name}.yaml").write_text(body)
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(scene_module, "SCENE_DIR", scratch)
            World(scene=name).close()
    elif mark == "fragment: keys":
        text = _mission(body, pins, "mission: fragment\ntree: {idle: true}\n")
        loaded = parse_mission(text, where)
        build_world(loaded, loaded.spec.world.seed).close()
    else:
        assert isinstance(data, dict) and "mission" in data, (
            f"{where}: a yaml snippet that is not a mission needs a mark"
        )
        compile_mission(parse_mission(_mission(body, pins), where, path=scratch / "missions" / "snippet.yaml"))


@pytest.mark.parametrize(
    "page", [pytest.param(p, marks=pytest.mark.slow) if p.name in SIMULATING_PAGES else p for p in PAGES], ids=_ids
)
def test_every_snippet_compiles_or_runs(page, tmp_path, monkeypatch):
    found = snippets(page)
    module = types.ModuleType(f"marsupial_docs_{page.stem.lower()}")
    monkeypatch.setitem(sys.modules, module.__name__, module)
    monkeypatch.chdir(tmp_path)
    pins = _entry_points([body for _, lang, _, body in found if lang == "toml"])
    _serve(module, pins, monkeypatch)
    for line, lang, mark, body in found:
        if lang == "python":
            _run_python(page, module, line, body, mark)
    for name, target in pins.items():
        cls = getattr(module, target.rpartition(":")[2], None)
        assert isinstance(cls, type) and issubclass(cls, MissionNode), f"{_ids(page)}: no class for entry point {name}"
    for line, lang, mark, body in found:
        if lang == "yaml" and mark.startswith("file:"):
            _write_file(page, line, mark.removeprefix("file:").strip(), body, tmp_path)
    for line, lang, mark, body in found:
        if lang == "yaml":
            _check_yaml(page, line, body, mark, tmp_path, pins)


def test_the_conventions_are_recognised():
    page = textwrap.dedent("""\
        <!-- fragment: node -->
        ```yaml
        {idle: true}
        ```
        ```python
        x = 1
        ```
    """)
    assert [(lang, mark) for m in _FENCE.finditer(page) for lang, mark in [(m["lang"], m["mark"])]] == [
        ("yaml", "fragment: node"),
        ("python", None),
    ]
    assert sum(len(snippets(p)) for p in PAGES) > 40
