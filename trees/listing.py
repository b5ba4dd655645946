"""What ``marsupial missions`` and ``marsupial skills`` print: readable tables, no reStructuredText markup.

- ``marsupial missions``: each shipped mission, its team and the first
  sentence of its description, whole (abbreviations such as "Fig. 5" or
  "et al." do not end it);
- ``marsupial skills``: a compact index, one line per skill and condition
  (name, kind, the robots it acts on, the first line of its docstring);
- ``marsupial skills NAME``: the detail of one node: its docstring,
  parameters (type, default, description), blackboard keys, resources,
  sensors and the metrics it records (:mod:`marsupial.trees.metrics`).

Docstrings are written for Sphinx; :func:`plain` turns their markup
(``` ``code`` ```, ``:class:`~a.B```, ``*emphasis*``) into plain text.
"""

from __future__ import annotations

import inspect
import re
from collections.abc import Iterable
from typing import Any

from rich.console import Group
from rich.table import Table
from rich.text import Text

__all__ = ["first_sentence", "index_table", "missions_table", "node_detail", "plain"]

_ROLE = re.compile(r":[\w:.-]+:`([^`<]*?)\s*(?:<[^>]*>)?`")  # :class:`~a.b.C`, :ref:`text <target>`
_LITERAL = re.compile(r"``(.+?)``")
_BACKTICKS = re.compile(r"`([^`]+)`_?")
_STRONG = re.compile(r"\*\*(\S(?:.*?\S)?)\*\*")
_EMPHASIS = re.compile(r"(?<![\w*])\*(\S(?:[^*]*?\S)?)\*(?![\w*])")
#: words that end with a period without ending a sentence
ABBREVIATIONS = frozenset({"al", "fig", "figs", "eq", "eqs", "e.g", "i.e", "cf", "vs", "etc", "no", "sec", "approx",
                           "ref", "refs", "resp", "st", "dr", "prof", "ch"})
_SENTENCE_END = re.compile(r"([.!?])\s+(?=[A-Z\"'(])")


def _role_text(match: re.Match[str]) -> str:
    target = match.group(1)
    return target.lstrip("~").rpartition(".")[2] if target.startswith("~") else target.lstrip("!")


def plain(text: str) -> str:
    """``text`` without reStructuredText inline markup: roles, literals, emphasis, ``::`` (a colon left)."""
    text = _ROLE.sub(_role_text, text)
    text = _LITERAL.sub(r"\1", text)
    text = _BACKTICKS.sub(r"\1", text)
    text = _STRONG.sub(r"\1", text)
    text = _EMPHASIS.sub(r"\1", text)
    return re.sub(r"(\S)::(\s|$)", r"\1:\2", text)


def first_sentence(text: str) -> str:
    """The first sentence of ``text`` (whitespace joined), whole: "Fig. 5", "et al." or an initial do not end it."""
    words = " ".join(text.split())
    for match in _SENTENCE_END.finditer(words):
        before = words[: match.start()].rpartition(" ")[2].lstrip("(")
        if match.group(1) == "." and (before.lower() in ABBREVIATIONS or re.fullmatch(r"[A-Z]", before)):
            continue  # "et al.", "Fig.", an initial
        return words[: match.end(1)]
    return words


def missions_table(missions: Iterable[tuple[str, str, str]]) -> Table:
    """``(name, team text, description)`` rows as the ``marsupial missions`` table (first sentences)."""
    table = Table(title="missions (marsupial run NAME)", title_justify="left")
    for column in ("mission", "robots", "description"):
        table.add_column(column)
    for name, robots, description in missions:
        table.add_row(Text(name, "bold"), Text(robots), Text(plain(first_sentence(description))))
    return table


def _robots(cls: Any) -> str:
    """The robots a node acts on: its capabilities, ``any robot`` or ``no robot``."""
    if not cls.uses_robot:
        return "no robot"
    return ", ".join(c.__name__ for c in cls.robot_kinds or ()) or "any robot"


def index_table(rows: Iterable[tuple[str, str, Any, str]]) -> Table:
    """``(kind, name, class or error text, provider text)`` rows as the compact ``marsupial skills`` index.

    A node that failed to load shows its error in red instead of its summary.
    """
    table = Table(title="skills and conditions (marsupial skills NAME for one in detail)", title_justify="left")
    for column in ("name", "kind", "robots", "what it does"):
        table.add_column(column)
    for kind, name, cls, provider in rows:
        where = f" [{provider}]" if provider else ""
        if isinstance(cls, str):
            table.add_row(Text(name, "bold"), kind, "", Text(f"cannot load{where}: {cls}", style="red"))
            continue
        table.add_row(Text(name, "bold"), kind, Text(_robots(cls)), Text(plain(cls.summary()) + where))
    return table


def _type_text(annotation: Any) -> str:
    """``float``, ``tuple[float, float, float]``, ``Literal['hover', 'motors_off']``."""
    if getattr(annotation, "__origin__", None) is None and isinstance(annotation, type):
        return annotation.__name__
    return re.sub(r"\b[\w.]+\.(\w+)", r"\1", str(annotation).replace("typing.", ""))


def _parameters(cls: Any) -> Table | None:
    fields = cls.Params.model_fields
    if not fields:
        return None
    table = Table(title="parameters", title_justify="left")
    for column in ("parameter", "type", "default", "description"):
        table.add_column(column)
    for name, info in fields.items():
        default = "(required)" if info.is_required() else repr(info.default)
        table.add_row(Text(name, "bold"), Text(_type_text(info.annotation)), Text(default),
                      Text(" ".join(plain(info.description or "").split())))
    return table


def _facts(name: str, cls: Any) -> Table:
    """Robots, blackboard keys, resources, sensors and metrics of node class ``cls`` (called ``name``)."""
    facts = Table(show_header=False, box=None, padding=(0, 1))
    facts.add_column(style="bold")
    facts.add_column()
    facts.add_row("robots", Text(_robots(cls)))
    if getattr(cls, "primary", None):
        facts.add_row("guard form", Text(f"{{{name}: VALUE}} sets {cls.primary}"))
    for label, values in (("reads", cls.reads), ("writes", cls.writes), ("sensors", cls.sensors)):
        if values:
            facts.add_row(label, Text(", ".join(values)))
    if cls.claims is None:
        facts.add_row("commands", Text("every resource of its robot"))
    elif cls.claims:
        facts.add_row("commands", Text(", ".join(cls.claims)))
    for item in cls.metrics:
        facts.add_row("metric", Text(f"{item.name} ({item.unit}, {item.aggregation}): {item.meaning}"))
    return facts


def node_detail(kind: str, name: str, provider: str, cls: Any) -> Group:
    """``marsupial skills NAME``: title, docstring (plain text), facts and parameters of one node class."""
    doc = plain(inspect.cleandoc(cls.__doc__ or "(no docstring)"))
    parts: list[Any] = [Text.assemble(f"{kind} ", (name, "bold"), f"  from {provider}"), Text(doc), _facts(name, cls)]
    parameters = _parameters(cls)
    if parameters is not None:
        parts.append(parameters)
    return Group(*parts)
