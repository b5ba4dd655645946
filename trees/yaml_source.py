"""YAML documents that remember where every key and list item was written.

:func:`load_yaml` parses a document into plain dicts/lists/scalars and a map
from key paths (tuples of keys and list indices) to 1-based (line, column), so
that any later error — a validation error, an unknown skill found by the
compiler — can name the exact place in the file.

Scalars follow YAML 1.2 where YAML 1.1 surprises: only ``true``/``false`` are
booleans (``yes``, ``no``, ``on``, ``off`` stay strings, so ``{operator: no}``
means the command "no"), and ``1e3`` and ``1.0e6`` are floats.

Hostile documents are refused with a located error, not a hang or a
traceback: at most :data:`MAX_VALUES` values after alias expansion (a
"billion laughs" document multiplies a few aliases into billions) and at most
:data:`MAX_DEPTH` levels of nesting.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import yaml

from .errors import KeyPathLike, MissionError

Position = tuple[int, int]

MAX_VALUES = 100_000  # values (scalars, mappings, lists) of one document after alias expansion
MAX_DEPTH = 64  # levels of nested mappings and lists

_BOOL_TAG = "tag:yaml.org,2002:bool"
_FLOAT_TAG = "tag:yaml.org,2002:float"
_MERGE_TAG = "tag:yaml.org,2002:merge"


class _TooDeep(Exception):
    """A node nested deeper than :data:`MAX_DEPTH` levels, found while composing; ``mark`` is where it starts."""

    def __init__(self, mark: yaml.Mark):
        super().__init__(mark)
        self.mark = mark


class _Loader(yaml.SafeLoader):
    """Safe loader with YAML 1.2 booleans and exponent floats without a dot (``1e3``), refusing to compose a
    node nested deeper than :data:`MAX_DEPTH` levels (the composer recurses once per level)."""

    yaml_implicit_resolvers = {
        first: [(tag, regexp) for tag, regexp in resolvers if tag != _BOOL_TAG]
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }
    _depth = -1  # nesting level of the node being composed (the document's root: 0)

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
        """Compose one node, raising :class:`_TooDeep` at the first node past :data:`MAX_DEPTH` levels."""
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise _TooDeep(self.peek_event().start_mark)  # type: ignore[no-untyped-call]
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


_Loader.add_implicit_resolver(_BOOL_TAG, re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF"))
# YAML 1.2 floats with an exponent: 1e3, 1.0e6, 2.5E-3 (YAML 1.1 wants a signed exponent after a dot)
_Loader.add_implicit_resolver(
    _FLOAT_TAG, re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"), list("-+.0123456789")
)


def _position(mark: yaml.Mark) -> Position:
    return mark.line + 1, mark.column + 1


@dataclass
class SourceDoc:
    """A parsed YAML document: ``data`` (plain Python values) and the position of every key path.

    ``file`` is the name shown in errors (a path or ``<string>``); ``text`` the
    original text; ``positions`` maps a key path to the 1-based (line, column)
    where its key (or list item) starts.
    """

    file: str
    text: str
    data: Any
    positions: dict[tuple[Any, ...], Position] = field(default_factory=dict)

    def locate(self, key_path: KeyPathLike) -> Position:
        """1-based (line, column) of ``key_path``, or of its nearest existing ancestor."""
        path = tuple(key_path)
        while path not in self.positions:
            path = path[:-1]
        return self.positions[path]

    def where(self, key_path: KeyPathLike) -> str:
        """``file:line:column`` of ``key_path`` (see :meth:`locate`)."""
        line, column = self.locate(key_path)
        return f"{self.file}:{line}:{column}"

    def error(
        self,
        key_path: KeyPathLike,
        message: str,
        expected: str | None = None,
        suggestion: str | None = None,
        note: str | None = None,
    ) -> MissionError:
        """A :class:`MissionError` located at ``key_path`` of this document (returned, not raised)."""
        line, column = self.locate(key_path)
        return MissionError(message, self.file, line, column, tuple(key_path), expected, suggestion, note)


def _parse_error(exc: yaml.YAMLError, file: str) -> MissionError:
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    problem = getattr(exc, "problem", None) or str(exc)
    context = getattr(exc, "context", None)
    message = f"malformed YAML: {problem}" + (f" ({context})" if context else "")
    if "\t" in problem or "'\\t'" in problem:
        message += "; indent with spaces, not tabs"
    line, column = _position(mark) if mark is not None else (None, None)
    return MissionError(message, file, line, column)


def _is_group_merge(key_node: yaml.Node, value_node: yaml.Node) -> bool:
    """Whether a mapping entry is ``<<: "${name}"`` (a merge of a parameter group), not YAML's ``<<: *anchor``."""
    return (
        key_node.tag == _MERGE_TAG and isinstance(value_node, yaml.ScalarNode)
        and "${" in str(value_node.value)
    )


def _check_keys(loader: _Loader, node: yaml.MappingNode, path: tuple[Any, ...], doc: SourceDoc) -> None:
    """Raise :class:`MissionError` at a key given twice in the mapping ``node`` (before YAML merges are resolved).

    A ``<<: "${group}"`` entry gets a plain string key: it merges a parameter group later (trees/subtrees.py).
    """
    seen: dict[Any, yaml.Node] = {}
    for key_node, value_node in node.value:
        if _is_group_merge(key_node, value_node):
            key_node.tag = "tag:yaml.org,2002:str"  # <<: "${group}" merges a parameter later (trees/subtrees.py)
        if not isinstance(key_node, yaml.ScalarNode):
            continue
        key = "<<" if key_node.tag == _MERGE_TAG else loader.construct_object(key_node)
        if key in seen and (key != "<<" or key_node.tag == seen[key].tag == "tag:yaml.org,2002:str"):
            first_line = seen[key].start_mark.line + 1
            line, column = _position(key_node.start_mark)
            raise MissionError(
                f"duplicate key '{key}' (first defined on line {first_line})",
                doc.file,
                line,
                column,
                path + (key,),
                expected="each key once per mapping",
            )
        seen[key] = key_node


def _too_large(what: str, doc: SourceDoc, mark: yaml.Mark, path: tuple[Any, ...] = ()) -> MissionError:
    """The error for a document that is too large (``what``), at ``mark``: where the limit was passed."""
    line, column = _position(mark)
    return MissionError(
        f"document too large: {what}",
        doc.file,
        line,
        column,
        path,
        expected=f"at most {MAX_VALUES:,} values and {MAX_DEPTH} levels (a mission needs far fewer)",
    )


def _build(loader: _Loader, node: yaml.Node, path: tuple[Any, ...], doc: SourceDoc, budget: list[int]) -> Any:
    """Plain value of ``node``, recording positions under ``path``; duplicate keys are errors.

    ``budget`` holds the number of values still allowed (:data:`MAX_VALUES`, shared by the whole document).
    """
    budget[0] -= 1
    if budget[0] < 0:
        raise _too_large(f"more than {MAX_VALUES:,} values after alias expansion", doc, node.start_mark, path)
    if len(path) > MAX_DEPTH:  # an alias expanded below a deep node
        raise _too_large(f"nested deeper than {MAX_DEPTH} levels", doc, node.start_mark, path)
    if isinstance(node, yaml.MappingNode):
        _check_keys(loader, node, path, doc)
        loader.flatten_mapping(node)  # resolve YAML merge keys (<<: *anchor)
        result: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            if isinstance(key, (list, dict)):
                line, column = _position(key_node.start_mark)
                raise MissionError("a mapping key must be a scalar", doc.file, line, column, path, expected="a name")
            doc.positions[path + (key,)] = _position(key_node.start_mark)
            result[key] = _build(loader, value_node, path + (key,), doc, budget)
        return result
    if isinstance(node, yaml.SequenceNode):
        items = []
        for index, item in enumerate(node.value):
            doc.positions[path + (index,)] = _position(item.start_mark)
            items.append(_build(loader, item, path + (index,), doc, budget))
        return items
    return loader.construct_object(node, deep=True)


def load_yaml(text: str, file: str = "<string>") -> SourceDoc:
    """Parse one YAML document with positions; malformed YAML -> :class:`MissionError` at the parser's position."""
    doc = SourceDoc(file=str(file), text=text, data=None, positions={(): (1, 1)})
    loader = _Loader(text)
    try:
        root = loader.get_single_node()
        if root is not None:
            doc.positions[()] = _position(root.start_mark)
            doc.data = _build(loader, root, (), doc, [MAX_VALUES])
    except yaml.YAMLError as exc:
        raise _parse_error(exc, doc.file) from None
    except _TooDeep as exc:
        raise _too_large(f"nested deeper than {MAX_DEPTH} levels", doc, exc.mark) from None
    finally:
        loader.dispose()
    return doc


def parse_scalar(text: str) -> Any:
    """A value written on a command line (``3.5``, ``true``, ``[1, 2]``, ``hello``) parsed as YAML."""
    try:
        return load_yaml(text, "<value>").data
    except MissionError:
        return text
