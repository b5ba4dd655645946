"""The metric registry: every metric a run records is declared once, with its unit, meaning and aggregation.

Whoever records a metric declares it: a node class lists its
:class:`MetricSpec` in ``metrics`` (read when the registry resolves the
node, :mod:`marsupial.trees.registry`); the runner declares the battery's
and the referee's (:data:`marsupial.world.scoring.SCORES`). The end-of-run
summary, the run and campaign reports and the table of ``docs/logs.md``
read the declarations from here::

    from marsupial.trees.metrics import MetricSpec

    class Hover(Skill["Hover.Params"]):
        metrics = (MetricSpec("hover_drift", "m", "horizontal distance from where the hover began", "max"),)

A metric's *aggregation* says how its samples in one run reduce to the one
value a summary shows, and how a plot draws them:

=============  ==========================================  =======================
aggregation    the value a summary shows                   drawn as
=============  ==========================================  =======================
``last``       the last sample (a level: state of charge)  lines, broken at gaps
``max``        the largest sample                          lines, broken at gaps
``min``        the smallest sample                         lines, broken at gaps
``mean_abs``   the mean of the samples' absolute values    lines, broken at gaps
``total``      the last sample of a running count          steps
``each``       every sample (one per occurrence)           markers
``count``      how many samples (one per occurrence)       markers
=============  ==========================================  =======================

Units are SI symbols (``s``, ``m``, ``rad``, ``1`` for a dimensionless
ratio), ``px``, ``fraction`` (0..1, shown as a percentage), ``count`` or
``flag`` (1 when it happened).
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, cast, get_args

__all__ = [
    "AGGREGATIONS",
    "EVENT_LIKE",
    "MetricSpec",
    "axis_label",
    "base_name",
    "catalogue",
    "declare",
    "declare_node",
    "declared",
    "format_value",
    "group_samples",
    "markdown_table",
    "owners",
    "reduce",
    "spec",
    "summarize",
    "undeclared",
]

Aggregation = Literal["last", "max", "min", "mean_abs", "total", "each", "count"]
AGGREGATIONS: tuple[str, ...] = get_args(Aggregation)
#: aggregations whose samples are occurrences (drawn as markers, never joined)
EVENT_LIKE = frozenset({"each", "count"})
#: modules whose import declares the metrics recorded outside nodes (the runner: battery and referee)
RECORDER_MODULES = ("marsupial.trees.runner",)


@dataclass(frozen=True)
class MetricSpec:
    """A metric's declaration: its ``name``, ``unit``, one-line ``meaning`` and ``aggregation`` (module docstring)."""

    name: str
    unit: str
    meaning: str
    aggregation: Aggregation = "last"

    def __post_init__(self) -> None:
        if not self.name or "[" in self.name:
            raise ValueError(f"metric name {self.name!r}: expected a non-empty name without '['")
        if self.aggregation not in AGGREGATIONS:
            raise ValueError(f"metric {self.name}: aggregation {self.aggregation!r}, expected one of {AGGREGATIONS}")
        if not self.unit or not self.meaning.strip() or "\n" in self.meaning:
            raise ValueError(f"metric {self.name}: expected a unit and a one-line meaning")

    @classmethod
    def of(cls, record: Mapping[str, str]) -> MetricSpec:
        """A declaration from plain data (``{"name", "unit", "meaning", "aggregation"}``, as the world keeps them)."""
        aggregation = cast(Aggregation, record.get("aggregation", "last"))  # checked by __post_init__
        return cls(record["name"], record["unit"], record["meaning"], aggregation)

    @property
    def event_like(self) -> bool:
        """Whether each sample is an occurrence of its own (drawn as a marker, never joined to the next)."""
        return self.aggregation in EVENT_LIKE


_DECLARED: dict[str, MetricSpec] = {}
_OWNERS: dict[str, list[str]] = {}
_loaded = False


def declare(*specs: MetricSpec, owner: str = "") -> tuple[MetricSpec, ...]:
    """Register ``specs`` (recorded by ``owner``, e.g. ``"marsupial.skills.navigation:Navigate"``); returns them.

    Declaring a name again with the same unit, meaning and aggregation is
    fine (two skills may record one metric); a different declaration raises
    :class:`ValueError` naming both owners.
    """
    for item in specs:
        known = _DECLARED.get(item.name)
        owners = _OWNERS.setdefault(item.name, [])
        if known is not None and known != item:
            raise ValueError(
                f"metric '{item.name}' declared by {owner or '?'} as {item} but by {', '.join(owners)} as {known}"
            )
        _DECLARED[item.name] = item
        if owner and owner not in owners:
            owners.append(owner)
    return specs


def declare_node(cls: type) -> None:
    """Register the metrics a node class lists in its ``metrics`` class attribute."""
    declare(*getattr(cls, "metrics", ()), owner=f"{cls.__module__}:{cls.__qualname__}")


def declared(name: str) -> MetricSpec | None:
    """The declaration of ``name`` if it is registered in this process (nothing is imported), else ``None``."""
    return _DECLARED.get(base_name(name))


def spec(name: str) -> MetricSpec | None:
    """The declaration of metric ``name`` (``name`` or ``name[labels]``), every installed node loaded if needed.

    ``None`` for a metric nobody declares.
    """
    found = declared(name)
    if found is None and not _loaded:
        _load_all()
        found = declared(name)
    return found


def undeclared(names: Iterable[str]) -> list[str]:
    """The metric names among ``names`` (plain or ``name[labels]``) that nobody declares, sorted, once each."""
    return sorted({base_name(name) for name in names if spec(name) is None})


def catalogue(shipped_only: bool = False) -> dict[str, MetricSpec]:
    """Every declared metric by name (sorted), every installed node loaded first.

    ``shipped_only``: only those recorded by marsupial itself (the table of ``docs/logs.md``).
    """
    _load_all()
    names = sorted(_DECLARED)
    if shipped_only:
        names = [n for n in names if any(o.startswith("marsupial.") for o in _OWNERS.get(n, ()))]
    return {name: _DECLARED[name] for name in names}


def owners(name: str) -> tuple[str, ...]:
    """Who declared metric ``name`` (``module:Class`` of nodes, or a module)."""
    return tuple(_OWNERS.get(base_name(name), ()))


def _load_all() -> None:
    """Import every installed skill and condition (and the recorder modules) so that their declarations register.

    A plug-in that fails to import or declares a metric inconsistently is left out here
    (``marsupial skills NAME`` and compiling a mission that uses it report it).
    """
    global _loaded
    from .registry import GROUPS, import_target, installed

    for module in RECORDER_MODULES:
        importlib.import_module(module)
    for kind in GROUPS:
        for providers in installed(kind).values():
            for provider in providers:
                try:
                    declare_node(import_target(provider.target))
                except Exception:  # a broken plug-in must not stop a report or a summary
                    continue
    _loaded = True


# ------------------------------------------------------------------ values
def base_name(key: str) -> str:
    """``"part_a_M[uav,x]"`` -> ``"part_a_M"`` (a metric key of a run's result, or a plain name)."""
    return key.partition("[")[0]


def reduce(aggregation: str, values: Sequence[float]) -> float:
    """The one value ``values`` (one run's samples, in time order) reduce to; NaN when there are none.

    ``each`` reduces to the last occurrence (a summary lists them all, :func:`summarize`).
    """
    finite = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    if aggregation == "count":
        return float(len(values))
    if not finite:
        return math.nan
    if aggregation == "max":
        return max(finite)
    if aggregation == "min":
        return min(finite)
    if aggregation == "mean_abs":
        return sum(abs(v) for v in finite) / len(finite)
    return finite[-1]  # last, total, each


def format_value(value: float, unit: str) -> str:
    """``value`` with its unit: ``"7.1 s"``, ``"97.4 %"`` (fraction), ``"3"`` (count, flag, dimensionless ``1``)."""
    if value is None or not math.isfinite(value):
        return "n/a"
    if unit == "fraction":
        return f"{100 * value:.1f} %"
    if unit in ("count", "flag"):
        return f"{value:.0f}" if float(value).is_integer() else f"{value:.4g}"
    return f"{value:.4g}" if unit == "1" else f"{value:.4g} {unit}"


_QUALIFIERS = {"max": "max ", "min": "min ", "mean_abs": "mean |·| ", "total": "", "last": "", "count": ""}
MAX_LISTED = 6  # occurrences of an ``each`` metric listed in a summary before "…"


def summarize(item: MetricSpec | None, values: Sequence[float]) -> str:
    """One run's samples of a metric as summary text: ``"max 0.31 m"``, ``"5.5 s, 7.1 s"``, ``"2 times"``.

    An undeclared metric (``item`` None) shows its last value, unit unknown.
    """
    if item is None:
        return f"{reduce('last', values):.4g} (undeclared metric: unit unknown)"
    if item.aggregation == "each":
        shown = [format_value(v, item.unit) for v in values[:MAX_LISTED]]
        return ", ".join(shown) + (f", … ({len(values)} in all)" if len(values) > MAX_LISTED else "")
    if item.aggregation == "count":
        return f"{len(values)} time{'s' if len(values) != 1 else ''}"
    return _QUALIFIERS[item.aggregation] + format_value(reduce(item.aggregation, values), item.unit)


def axis_label(item: MetricSpec | None, name: str) -> str:
    """A plot's value-axis label: ``"docking_time (s)"``, ``"battery_soc (fraction 0–1)"``."""
    if item is None:
        return f"{name} (unit not declared)"
    unit = {"fraction": "fraction 0–1", "1": "dimensionless"}.get(item.unit, item.unit)
    return f"{name} ({unit})"


def group_samples(rows: Iterable[Mapping[str, Any]]) -> dict[str, dict[str, list[tuple[float, float]]]]:
    """Metric messages (``{"t", "name", "value", "labels"}``) as ``{name: {label text: [(t s, value)]}}``.

    The label text is ``"robot=uav, axis=x"`` (sorted keys); null values become NaN.
    """
    grouped: dict[str, dict[str, list[tuple[float, float]]]] = {}
    for m in rows:
        labels = ", ".join(f"{k}={v}" for k, v in sorted(m["labels"].items()))
        value = math.nan if m["value"] is None else float(m["value"])
        grouped.setdefault(m["name"], {}).setdefault(labels, []).append((float(m["t"]), value))
    return grouped


def markdown_table(specs: Mapping[str, MetricSpec] | None = None) -> str:
    """The metric table of ``docs/logs.md``: name, unit, aggregation, meaning, recorded by (shipped metrics)."""
    specs = catalogue(shipped_only=True) if specs is None else specs
    lines = ["| metric | unit | aggregation | meaning | recorded by |", "|---|---|---|---|---|"]
    for name, item in specs.items():
        by = ", ".join(sorted(f"`{o.rpartition(':')[2] if ':' in o else o.rpartition('.')[2]}`" for o in owners(name)))
        lines.append(f"| `{name}` | {item.unit} | {item.aggregation} | {item.meaning} | {by} |")
    return "\n".join(lines) + "\n"
