"""Loading a mission: by name or path, overrides, ``${name}`` references, validation, subtrees, robot checks.
"""

from __future__ import annotations

import copy
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path
from typing import Any

from pydantic import (
    ValidationError,
)

from ..errors import KeyPathLike, MissionError, one_of, suggest
from ..yaml_source import SourceDoc, load_yaml
from .nodes import Guard, KeyPath, Node, NodeBase, PriorityEntry
from .overrides import apply_overrides
from .spec import MissionSpec
from .validation import errors_from_validation, validate_source

# ----------------------------------------------------------------------- missions


@dataclass
class Mission:
    """A loaded, validated mission: its spec, original text, file and source positions.

    ``spec.tree`` has its subtrees inlined and every node knows its ``key_path``;
    ``overrides`` are the ``--set`` values applied (as given); ``references``
    records where the values of ``${name}`` references were set, so that a
    later error at such a place (a wrong skill parameter) says it.
    """

    spec: MissionSpec
    text: str
    path: Path | None
    source: SourceDoc
    overrides: dict[str, str] = field(default_factory=dict)
    # (file, include note, key path) -> note
    references: dict[tuple[Any, ...], str] = field(default_factory=dict, repr=False)
    #: texts of the subtree files inlined, by their path relative to the mission's folder (see :func:`subtree_key`)
    subtree_texts: dict[str, str] = field(default_factory=dict, repr=False)

    @property
    def name(self) -> str:
        """The mission's name (its ``mission:`` key)."""
        return self.spec.mission

    def _place(
        self, where: KeyPathLike | NodeBase | Guard | PriorityEntry
    ) -> tuple[SourceDoc, tuple[Any, ...], str | None]:
        """(source document, key path, include note) of a key path or node."""
        key_path = getattr(where, "key_path", where)
        return getattr(key_path, "source", None) or self.source, tuple(key_path), getattr(key_path, "note", None)

    def reference_notes(self, source: SourceDoc, note: str | None) -> dict[tuple[Any, ...], str]:
        """Key path -> where its ``${name}`` values were set, for the strings of ``source`` reached via ``note``."""
        return {path: text for (file, via, path), text in self.references.items() if (file, via) == (source.file, note)}

    def error_at(
        self,
        where: KeyPathLike | NodeBase | Guard | PriorityEntry,
        message: str,
        expected: str | None = None,
        suggestion: str | None = None,
    ) -> MissionError:
        """A :class:`MissionError` at a key path (or node/guard) of the mission or of the subtree file it came from.

        Returns the error; the caller raises it. ``node.key_path + ("params", "speed")`` points inside a node.
        """
        source, key_path, note = self._place(where)
        key_path = _as_written(source.data, key_path)
        lines = [text for path, text in self.reference_notes(source, note).items() if key_path[: len(path)] == path]
        lines += [note] if note else []
        return source.error(key_path, message, expected, suggestion, "; ".join(lines) or None)

    def validation_error(self, exc: ValidationError, where: KeyPathLike | NodeBase, model: Any = None) -> MissionError:
        """A :class:`MissionError` for ``exc``, raised validating the value at ``where`` (e.g. a node's
        ``params`` against a skill's ``Params`` model given as ``model``)."""
        source, key_path, note = self._place(where)
        data = source.data
        for item in key_path:
            data = data[item] if isinstance(data, (dict, list)) and _has(data, item) else None
        notes = self.reference_notes(source, note)
        return errors_from_validation(exc, source, key_path, model, data, notes, note)

    def param_origins(self) -> dict[str, str]:
        """Where each mission parameter got its value: ``"set at file:line:column"`` or ``"set by --set …"``."""
        return _param_origins(self.source, self.spec.params, self.overrides)

    def nodes(self) -> Iterator[Node]:
        """Every node of the tree, depth first."""
        return self.spec.tree.walk()


def _param_origins(source: SourceDoc, params: Mapping[str, Any], overrides: Mapping[str, str]) -> dict[str, str]:
    set_by = {  # a whole parameter (name=…) or a key of a settings group (group.key=…)
        key.removeprefix("params.").split(".")[0]: f"set by --set {key}={value}" for key, value in overrides.items()
    }
    return {name: set_by.get(name) or f"set at {source.where(('params', name))}" for name in params}


def _as_written(data: Any, key_path: tuple[Any, ...]) -> tuple[Any, ...]:
    """``key_path`` without the index 0 of a single mapping written where a list of them is allowed
    (``occlusion: {…}`` for ``occlusion: [{…}]``), so that it points at the key as written."""
    written: list[Any] = []
    for item in key_path:
        if item == 0 and isinstance(item, int) and isinstance(data, dict) and 0 not in data:
            continue
        written.append(item)
        data = data[item] if isinstance(data, (dict, list)) and _has(data, item) else None
    return tuple(written)


def _has(container: dict[str, Any] | list[Any], item: Any) -> bool:
    if isinstance(container, dict):
        return item in container
    return isinstance(item, int) and -len(container) <= item < len(container)


def display_path(path: Path) -> str:
    """``path`` as shown in errors: relative to the working directory when it is below it."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def mission_dir() -> Path:
    """Folder of the missions shipped with the package (``missions/``)."""
    return Path(str(files("marsupial.missions")))


def known_missions() -> list[str]:
    """Names of the missions shipped with the package."""
    return sorted(p.stem for p in mission_dir().glob("*.yaml"))


def find_mission(name_or_path: str | Path) -> Path:
    """Path of a mission given by package name (``landing``) or by file path."""
    path = Path(name_or_path)
    looks_like_path = isinstance(name_or_path, Path) or path.suffix in (".yaml", ".yml") or len(path.parts) > 1
    if not looks_like_path:
        shipped = mission_dir() / f"{name_or_path}.yaml"
        if shipped.is_file():
            return shipped
    if path.is_file():
        return path
    known = known_missions()
    what = f"mission file '{path}' not found" if looks_like_path else f"unknown mission '{name_or_path}'"
    names = f"a mission name ({one_of(known)}) or " if known else ""
    raise MissionError(what, expected=f"{names}a path to a mission .yaml file", suggestion=suggest(path.stem, known))


# ---------------------------------------------------------------------- loading


def parse_mission(
    text: str, file: str = "<string>", overrides: Mapping[str, str] | None = None, path: Path | None = None
) -> Mission:
    """Validate mission ``text`` (shown as ``file`` in errors; ``path`` locates relative subtrees)."""
    from ..subtrees import (  # subtrees build on these models
        expand_subtrees,
        resolve_references,
    )

    source = load_yaml(text, file)
    if not isinstance(source.data, dict):
        raise source.error((), "a mission must be a mapping", expected="keys mission, world, team, params, tree …")
    data = copy.deepcopy(source.data)
    overridden = apply_overrides(data, overrides or {}, source.file)
    notes = {path: f"value set by {shown}" for path, shown in overridden.items()}
    unknown: list[MissionError] = []
    params = data.get("params", {})
    if "tree" in data and isinstance(params, dict):
        origins = _param_origins(source, params, overrides or {})
        resolved = resolve_references(data["tree"], params, source, ("tree",), origins)
        data["tree"], unknown = resolved.data, resolved.unknown
        notes.update(resolved.notes)
    spec = validate_source(MissionSpec, data, source, (), unknown, notes)
    spec.tree.set_key_path(KeyPath(("tree",), source))
    mission = Mission(spec, text, path, source, dict(overrides or {}))
    mission.references.update({(source.file, None, p): n for p, n in notes.items()})
    expand_subtrees(mission)
    _check_robots(mission)
    return mission


def load_mission(name_or_path: str | Path, overrides: Mapping[str, str] | None = None) -> Mission:
    """Load a mission by name (package ``marsupial.missions``) or path, apply overrides, validate, inline subtrees."""
    path = find_mission(name_or_path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MissionError(f"cannot read mission file: {exc}", str(path)) from None
    return parse_mission(text, display_path(path) if path.is_absolute() else str(path), overrides, path)


def _robot_refs(node: NodeBase) -> Iterator[tuple[KeyPath, str]]:
    """(key path of the ``robot`` key, robot name) of a node and its guards."""
    holders: list[Any] = [node, *node.guards()]
    for holder in holders:
        robot = getattr(holder, "robot", None)
        if robot is not None:
            yield holder.key_path + ("robot",), robot


def _check_robots(mission: Mission) -> None:
    team = mission.spec.team
    for node in mission.nodes():
        for key_path, robot in _robot_refs(node):
            if robot not in team:
                raise mission.error_at(
                    key_path,
                    f"unknown robot '{robot}'",
                    expected=f"a team member ({one_of(team)})",
                    suggestion=suggest(robot, team),
                )
