"""Subtrees: reusable trees with named parameters, inlined into a mission; ``${name}`` substitution, ``<<`` merges.

A subtree file (``missions/subtrees/<name>.yaml``, or any file given by path)::

    subtree: dock_uav
    description: bring the UAV back onto the carrier
    params: {uav: uav, carrier: carrier, approach_height: 1.5, target: ~}   # ~: required
    tree:
      sequence:
        - {skill: rendezvous, robot: "${uav}", params: {height: "${approach_height}"}}
        - {skill: land, robot: "${uav}", params: {on: "${carrier}"}}

A mission uses it with ``{subtree: dock_uav, params: {approach_height: 2.0}}``.
``${name}`` is replaced by the parameter's value — keeping its type when the
whole string is the reference, formatted into the text otherwise (``$$`` is a
literal ``$``). Inside a subtree, names are the subtree's parameters, then the
mission's ``params``. Include cycles are an error naming the cycle and the
include line.

Settings groups: ``<<: "${group}"`` in a mapping merges the mapping that
parameter holds (keys written beside it win), so a group of settings is passed
at once (``params: {<<: "${tracker}", platform: ugv}``). A subtree parameter
whose default is a non-empty mapping is a group: an include's mapping for it
updates the default key by key, and unknown keys are errors.

Subtree files are read only from inside the mission's folder and the
package's ``missions/`` folder, or from the folders listed in the
environment variable ``MARSUPIAL_SUBTREE_PATH`` (separated like ``PATH``):
a mission cannot make the loader read ``../../../etc/passwd``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from .errors import KeyPathLike, MissionError, one_of, suggest
from .mission import KeyPath, Mission, Node, SubtreeNode, display_path, mission_dir, validate_source
from .yaml_source import SourceDoc, load_yaml

_REFERENCE = re.compile(r"\$\$|\$\{([^}]*)\}")


@dataclass
class Resolved:
    """Data with its ``${name}`` references replaced.

    ``notes`` says, per key path of a string that held references, where the
    values were set (to annotate a later validation error there); ``unknown``
    holds an error per unknown reference (its string is left as written).
    """

    data: Any
    notes: dict[tuple[Any, ...], str] = field(default_factory=dict)
    unknown: list[MissionError] = field(default_factory=list)


def resolve_references(
    data: Any,
    scope: Mapping[str, Any],
    source: SourceDoc,
    key_path: KeyPathLike = (),
    origins: Mapping[str, str] | None = None,
    note: str | None = None,
) -> Resolved:
    """Replace every ``${name}`` in the strings of ``data`` (at ``key_path`` of ``source``) from ``scope``.

    A string that is exactly one reference takes the value with its type
    (``"${height}"`` -> ``1.5``); inside a longer string the value is
    formatted; ``$$`` is a literal ``$``. ``origins`` tells where each name's
    value was set (``"set at file:line:column"``, ``"set by --set …"``).
    """
    result = Resolved(None)

    def resolve(value: Any, path: tuple[Any, ...]) -> Any:
        if isinstance(value, dict):
            resolved = {k: resolve(v, path + (k,)) for k, v in value.items() if k != MERGE_KEY}
            if MERGE_KEY not in value:
                return resolved
            group = resolve(value[MERGE_KEY], path + (MERGE_KEY,))
            return merge_group(group, value[MERGE_KEY], resolved, path, source, result, note)
        if isinstance(value, list):
            return [resolve(v, path + (i,)) for i, v in enumerate(value)]
        if not isinstance(value, str) or "$" not in value:
            return value
        names = [m.group(1).strip() for m in _REFERENCE.finditer(value) if m.group(1) is not None]
        for name in names:
            if name not in scope:
                result.unknown.append(source.error(
                    path, f"unknown parameter reference '${{{name}}}'",
                    expected=f"a parameter ({one_of(scope)})", suggestion=suggest(name, scope), note=note,
                ))
                return value
        set_at = [f"'${{{n}}}' {origins[n]}" for n in dict.fromkeys(names) if origins and n in origins]
        if set_at:
            result.notes[path] = "; ".join(set_at)
        whole = _REFERENCE.fullmatch(value)
        if whole and whole.group(1) is not None:
            return scope[names[0]]
        return _REFERENCE.sub(lambda m: "$" if m.group(1) is None else str(scope[m.group(1).strip()]), value)

    result.data = resolve(data, tuple(key_path))
    return result


MERGE_KEY = "<<"


def merge_group(
    group: Any, written: Any, explicit: dict[str, Any], path: tuple[Any, ...], source: SourceDoc, result: Resolved,
    note: str | None,
) -> dict[str, Any]:
    """``explicit`` (a mapping at ``path``) over the settings ``group`` that its ``<<: "${name}"`` key merges.

    Keys written beside ``<<`` win. A merged key is located at the ``<<`` key (its position is recorded in
    ``source``) and annotated with the group's origin; a group that is not a mapping is an error there.
    """
    at = path + (MERGE_KEY,)
    if isinstance(group, str) and group == written and "${" in written:  # an unknown name, already reported
        return explicit
    if not isinstance(written, str) or _REFERENCE.fullmatch(written) is None or not isinstance(group, Mapping):
        shown = f"'{written}' is {group!r}" if isinstance(written, str) else f"got {written!r}"
        result.unknown.append(source.error(
            at, f"'<<' merges a mapping of settings, {shown}",
            expected="'<<: \"${name}\"' naming a parameter whose value is a mapping", note=note,
        ))
        return explicit
    origin = result.notes.get(at)
    for key in group:
        source.positions.setdefault(path + (key,), source.locate(at))
        if key not in explicit and origin:
            result.notes[path + (key,)] = origin
    return {**group, **explicit}


class SubtreeSpec(BaseModel):
    """A subtree file: its name, declared parameters (``~``: required) and its tree (validated after substitution)."""

    model_config = ConfigDict(extra="forbid")
    subtree: str = Field(description="Subtree name.")
    description: str = Field("", description="What the subtree does.")
    params: dict[str, Any] = Field(default_factory=dict, description="Declared parameters and defaults (~: required).")
    tree: Any = Field(description="The subtree's root node.")


@dataclass(frozen=True)
class _SubtreeFile:
    """A parsed subtree file."""

    path: Path
    source: SourceDoc
    spec: SubtreeSpec


def package_subtree_dir() -> Path:
    """Folder of the subtrees shipped with the package (``missions/subtrees/``)."""
    return mission_dir() / "subtrees"


def known_subtrees(dirs: list[Path] | None = None) -> list[str]:
    """Names of the subtrees in ``dirs`` (default: the package's)."""
    return sorted({p.stem for d in dirs or [package_subtree_dir()] for p in d.glob("*.yaml")})


def find_subtree(ref: str, search_dirs: list[Path], base_dir: Path | None) -> Path | None:
    """File of subtree ``ref``: a path (relative to ``base_dir``) if it has a suffix or a ``/``, else
    ``<dir>/<ref>.yaml`` in the first of ``search_dirs`` that has it; ``None`` if there is none."""
    path = Path(ref)
    if path.suffix in (".yaml", ".yml") or len(path.parts) > 1:
        full = path if path.is_absolute() or base_dir is None else base_dir / path
        return full if full.is_file() else None
    return next((d / f"{ref}.yaml" for d in search_dirs if (d / f"{ref}.yaml").is_file()), None)


SEARCH_PATH_VARIABLE = "MARSUPIAL_SUBTREE_PATH"


def allowed_roots(mission_file: Path | None) -> list[Path]:
    """Folders subtree files may come from.

    The mission's folder, the package's missions, ``$MARSUPIAL_SUBTREE_PATH``.
    """
    base = mission_file.resolve().parent if mission_file is not None else Path.cwd().resolve()
    extra = [Path(p).resolve() for p in os.environ.get(SEARCH_PATH_VARIABLE, "").split(os.pathsep) if p]
    return [base, mission_dir().resolve(), *extra]


@dataclass(frozen=True)
class _Include:
    """One link of the include chain: subtree name, its resolved file, where it was included."""

    name: str
    file: Path
    at: str


class _Expander:
    """Inlines the subtree nodes of one mission, caching parsed subtree files."""

    def __init__(self, mission: Mission):
        self.mission = mission
        self.files: dict[Path, _SubtreeFile] = {}

    def expand(self, node: Node, chain: tuple[_Include, ...]) -> Node:
        if isinstance(node, SubtreeNode):
            return self.inline(node, chain)
        node.map_children(lambda child, _: self.expand(child, chain))
        return node

    def search_dirs(self, including: Path | None, is_mission: bool) -> list[Path]:
        """Where subtrees by name are looked for: next to the including file, then in the package."""
        local = []
        if including is not None:
            local = [including.parent / "subtrees"] if is_mission else [including.parent]
        dirs = local + [package_subtree_dir()]
        return [d for i, d in enumerate(dirs) if d.is_dir() and d.resolve() not in {x.resolve() for x in dirs[:i]}]

    def inline(self, node: SubtreeNode, chain: tuple[_Include, ...]) -> Node:
        where = node.key_path
        source = where.source or self.mission.source
        including = chain[-1].file if chain else self.mission.path
        dirs = self.search_dirs(including, not chain)
        ref_at = where + ("subtree",)
        file = find_subtree(node.subtree, dirs, including.parent if including is not None else None)
        if file is None:
            known = known_subtrees(dirs)
            raise self.mission.error_at(
                ref_at, f"subtree '{node.subtree}' not found",
                expected=f"a subtree name ({one_of(known)}) or a path to a subtree .yaml file",
                suggestion=suggest(node.subtree, known),
            )
        file = file.resolve()
        roots = allowed_roots(self.mission.path)
        if not any(root == file.parent or root in file.parents for root in roots):
            raise self.mission.error_at(
                ref_at,
                f"subtree '{node.subtree}' is outside the mission's folder",
                expected=f"a subtree inside {roots[0]} or the package's missions "
                f"(or add its folder to ${SEARCH_PATH_VARIABLE})",
            )
        link = _Include(node.subtree, file, source.where(ref_at))
        if any(c.file == file for c in chain):
            cycle = " -> ".join([c.name for c in chain[[c.file for c in chain].index(file) :]] + [node.subtree])
            raise self.mission.error_at(
                ref_at, f"subtree include cycle: {cycle}", expected="subtrees that do not include themselves"
            )
        note = f"in subtree '{node.subtree}' included at {link.at}" + (f"; {where.note}" if where.note else "")
        sub = self.load(file, note)
        arguments = self.arguments(node, sub)
        scope = {**self.mission.spec.params, **arguments}
        origins = {**self.mission.param_origins(), **self.origins(node, sub, arguments)}
        resolved = resolve_references(sub.source.data["tree"], scope, sub.source, ("tree",), origins, note)
        root = validate_source(Node, resolved.data, sub.source, ("tree",), resolved.unknown, resolved.notes, note)
        self.mission.references.update({(sub.source.file, note, p): n for p, n in resolved.notes.items()})
        root.set_key_path(KeyPath(("tree",), sub.source, note))
        root.name = node.name or root.name or sub.spec.subtree
        return self.expand(root, chain + (link,))

    def arguments(self, node: SubtreeNode, sub: _SubtreeFile) -> dict[str, Any]:
        """The subtree's parameter values: its defaults updated with the node's ``params``."""
        declared = sub.spec.params
        for name in node.params:
            if name not in declared:
                raise self.mission.error_at(
                    node.key_path + ("params", name),
                    f"unknown parameter '{name}' of subtree '{node.subtree}'",
                    expected=f"a declared parameter ({one_of(declared)})",
                    suggestion=suggest(name, declared),
                )
        values = {name: self.settings(node, (name,), declared[name], value) for name, value in node.params.items()}
        values = {**declared, **values}
        missing = [name for name, value in values.items() if value is None and declared[name] is None]
        if missing:
            where = ", ".join(f"{name} at {sub.source.where(('params', name))}" for name in missing)
            raise self.mission.error_at(
                node.key_path + ("params",),
                f"subtree '{node.subtree}' needs parameter{'s' if len(missing) > 1 else ''} {', '.join(missing)}",
                expected=f"params with {', '.join(missing)} (declared required: {where})",
            )
        return values

    def settings(self, node: SubtreeNode, rel: tuple[Any, ...], default: Any, value: Any) -> Any:
        """``value`` given for a subtree parameter (at ``params`` + ``rel`` of the include) over its ``default``.

        A default that is a non-empty mapping is a settings group: a mapping given for it updates it key
        by key (recursively), and its keys must be the default's.
        """
        if not isinstance(default, Mapping) or not default or value is None:
            return value
        at = node.key_path + ("params", *rel)
        group = ".".join(map(str, rel))
        if not isinstance(value, Mapping):
            raise self.mission.error_at(
                at,
                f"'{group}' of subtree '{node.subtree}' is a settings group, got {value!r}",
                expected=f"a mapping with some of {', '.join(default)}",
            )
        for key in value:
            if key not in default:
                raise self.mission.error_at(
                    at + (key,),
                    f"unknown setting '{key}' in group '{group}' of subtree '{node.subtree}'",
                    expected=f"a setting of the group ({one_of(default)})",
                    suggestion=suggest(key, default),
                )
        return {**default, **{k: self.settings(node, rel + (k,), default[k], v) for k, v in value.items()}}

    def origins(self, node: SubtreeNode, sub: _SubtreeFile, arguments: Mapping[str, Any]) -> dict[str, str]:
        """Where each subtree parameter got its value: the include's ``params``, else the declared default."""
        include = node.key_path.source or self.mission.source
        return {
            name: f"set at {include.where(node.key_path + ('params', name))}"
            if name in node.params
            else f"set at {sub.source.where(('params', name))}"
            for name in arguments
        }

    def load(self, file: Path, note: str | None) -> _SubtreeFile:
        """Parse and check subtree file ``file`` (cached)."""
        if file not in self.files:
            try:
                text = file.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                raise MissionError(f"cannot read subtree file: {exc}", display_path(file), note=note) from None
            source = load_yaml(text, display_path(file))
            if not isinstance(source.data, dict):
                raise source.error(
                    (), "a subtree file must be a mapping", expected="keys subtree, params, tree", note=note
                )
            spec = validate_source(SubtreeSpec, source.data, source, note=note)
            self.files[file] = _SubtreeFile(file, source, spec)
        return self.files[file]


def expand_subtrees(mission: Mission) -> Mission:
    """Inline every ``subtree:`` node of ``mission.spec.tree`` (in place; returns ``mission``).

    Inlined nodes keep key paths into their subtree file. Unknown subtrees,
    undeclared or missing parameters, unknown ``${name}`` references and
    include cycles raise a :class:`MissionError` at the include.
    """
    expander = _Expander(mission)
    mission.spec.tree = expander.expand(mission.spec.tree, ())
    mission.subtree_texts = {subtree_key(path, mission.path): sub.source.text for path, sub in expander.files.items()}
    return mission


def subtree_key(file: Path, mission_file: Path | None) -> str:
    """Where a subtree file sits for a copy of the mission (a run log): relative to the mission's folder.

    Files of the package's missions (``missions/subtrees/x.yaml``) become
    ``subtrees/x.yaml``, which the copy's own ``subtrees/`` folder serves
    first; files from ``$MARSUPIAL_SUBTREE_PATH`` keep their name under
    ``subtrees/``.
    """
    for root in allowed_roots(mission_file):
        if root in file.parents:
            return file.relative_to(root).as_posix()
    return f"subtrees/{file.name}"


def write_mission_copy(folder: Path, mission_name: str, text: str, subtree_texts: Mapping[str, str]) -> Path:
    """Write a mission and its subtree files (:func:`subtree_key` layout) under ``folder``; returns the mission file.

    Keys that would leave ``folder`` (absolute, or with ``..``) are refused with a :class:`MissionError`.
    """
    folder.mkdir(parents=True, exist_ok=True)
    mission_file = folder / f"{Path(mission_name).name or 'mission'}.yaml"
    mission_file.write_text(text)
    for key, body in subtree_texts.items():
        relative = Path(key)
        if relative.is_absolute() or ".." in relative.parts:
            raise MissionError(
                f"subtree file '{key}' of the log would be written outside the copy", expected="a relative path"
            )
        target = folder / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(body)
    return mission_file
