"""The report's figures as inline SVG (matplotlib, no pyplot: safe in notebooks and without a display).

Every function returns one ``<svg ...>`` element as text. Text stays text
(``svg.fonttype: none``; matplotlib escapes it as XML), so names from a
mission are searchable and can never become markup; mathtext is off for every
label that comes from a mission (``parse_math=False``). Output is
deterministic (fixed hash salt, no date). Units: metres, simulated seconds.
"""

from __future__ import annotations

import functools
import io
import math
import re
import textwrap
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

import matplotlib
import numpy as np
from matplotlib.artist import Artist
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, Polygon
from matplotlib.ticker import MaxNLocator

from ..metrics import MetricSpec, axis_label, format_value

__all__ = ["GAP_FACTOR", "STATUS_COLOURS", "STATUS_LABELS", "histograms", "map_svg", "metric_svgs", "outcome_svg",
           "phases_svg", "timeline_svg"]

#: timeline state -> bar colour (IDLE draws nothing); guards that hold or not are drawn in neutral tones
STATUS_COLOURS = {"RUNNING": "#f0a500", "SUCCESS": "#2e9d4f", "FAILURE": "#d1343b", "HOLDS": "#8fb9d6",
                  "NOT_HOLDING": "#d5d9de"}
#: timeline state -> its legend text
STATUS_LABELS = {"RUNNING": "running", "SUCCESS": "success", "FAILURE": "failure", "HOLDS": "guard holds",
                 "NOT_HOLDING": "guard does not hold"}
GAP_FACTOR = 3.0  # a metric's line breaks where two samples are this many times the median interval apart
#: scene tags whose objects the map names
INTEREST_TAGS = frozenset({"object_of_interest", "target"})
_PHASE_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22",
                  "#7f7f7f", "#aec7e8", "#ffbb78", "#98df8a", "#c5b0d5", "#c49c94", "#f7b6d2", "#9edae5",
                  "#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173", "#3182bd")
_RC: dict[str, Any] = {"svg.fonttype": "none", "svg.hashsalt": "marsupial", "font.size": 9, "axes.titlesize": 10,
       "axes.spines.top": False, "axes.spines.right": False}
_ROBOT_COLOURS = ("#1f77b4", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22")
_SVG_SIZE = re.compile(r'<svg([^>]*?) width="[^"]*" height="[^"]*"')
_F = TypeVar("_F", bound=Callable[..., Any])


def _styled(function: _F) -> _F:
    """Build the figures of ``function`` under the report's matplotlib settings (not the user's)."""

    @functools.wraps(function)
    def styled(*args: Any, **kwargs: Any) -> Any:
        with matplotlib.rc_context(_RC):  # type: ignore[arg-type]  # (keys are checked by matplotlib)
            return function(*args, **kwargs)

    return styled  # type: ignore[return-value]


def _svg(fig: Figure, label: str) -> str:
    """The figure as one ``<svg>`` element scaled to its container, with an accessible ``label``."""
    buffer = io.StringIO()
    fig.savefig(buffer, format="svg", metadata={"Date": None}, bbox_inches="tight")
    text = buffer.getvalue()
    text = text[text.index("<svg"):]
    escaped = label.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")
    return _SVG_SIZE.sub(rf'<svg\1 role="img" aria-label="{escaped}" style="width:100%;height:auto"', text, count=1)


def _figure(width: float, height: float) -> Figure:
    return Figure(figsize=(width, height), layout="constrained")


def robot_colour(index: int) -> str:
    """The colour of the ``index``-th robot (same in every figure)."""
    return _ROBOT_COLOURS[index % len(_ROBOT_COLOURS)]


# ------------------------------------------------------------------ map
def _footprint(kind: str, primitive: Mapping[str, Any]) -> tuple[Any, list[float], list[float]]:
    """A scene primitive seen from above: a matplotlib patch and its x, y extent (m)."""
    p, size = primitive["pose"]["position"], primitive["size"]
    q = primitive["pose"]["orientation"]
    colour = primitive.get("color", {})
    face = (colour.get("r", 0.6), colour.get("g", 0.6), colour.get("b", 0.6), max(0.35, colour.get("a", 1.0)))
    if kind == "cubes":
        yaw = math.atan2(2 * (q["w"] * q["z"] + q["x"] * q["y"]), 1 - 2 * (q["y"] ** 2 + q["z"] ** 2))
        c, s = math.cos(yaw), math.sin(yaw)
        hx, hy = size["x"] / 2, size["y"] / 2
        corners = [(p["x"] + c * dx - s * dy, p["y"] + s * dx + c * dy) for dx, dy in
                   ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))]
        xs, ys = zip(*corners, strict=True)
        return Polygon(corners, closed=True, facecolor=face, edgecolor="#444", lw=0.5), list(xs), list(ys)
    r = size["x"] / 2
    return (Circle((p["x"], p["y"]), r, facecolor=face, edgecolor="#444", lw=0.5),
            [p["x"] - r, p["x"] + r], [p["y"] - r, p["y"] + r])


def _plot_paths(ax: Any, paths: Mapping[str, Mapping[str, np.ndarray]]) -> tuple[list[float], list[float]]:
    """Draw each robot's true path (start, end marked) and estimated path on ``ax``; the x, y values drawn (m)."""
    xs: list[float] = []
    ys: list[float] = []
    for index, (robot, tracks) in enumerate(paths.items()):
        colour = robot_colour(index)
        truth, estimate = tracks.get("truth"), tracks.get("estimate")
        if truth is not None and len(truth):
            ax.plot(truth[:, 0], truth[:, 1], color=colour, lw=1.6, label=f"{robot} true")
            ax.plot(*truth[0, :2], "o", color=colour, ms=5)
            ax.plot(*truth[-1, :2], "s", color=colour, ms=5)
            xs += list(truth[:, 0])
            ys += list(truth[:, 1])
        if estimate is not None and len(estimate):
            ax.plot(estimate[:, 0], estimate[:, 1], color=colour, lw=1.1, ls="--", label=f"{robot} estimate")
            xs += list(estimate[:, 0])
            ys += list(estimate[:, 1])
    return xs, ys


def _tags(entity: Mapping[str, Any]) -> set[str]:
    """The tags of a ``/scene`` entity (its ``tags`` metadata, comma-separated)."""
    return {tag for item in entity.get("metadata", []) if item.get("key") == "tags" for tag in item["value"].split(",")}


def _plot_scene(
    ax: Any, scene: Mapping[str, Any] | None, extent: tuple[list[float], list[float]] | None
) -> tuple[Mapping[str, Any] | None, list[tuple[str, float, float]]]:
    """Draw the scene's objects from above on ``ax``: (the floor entity, not drawn; the objects of interest).

    The objects of interest (tagged :data:`INTEREST_TAGS`) are ``(name, x, y)`` (m, centre of their footprint).
    With ``extent`` (x and y lists, m), the objects' footprints are added to it: the objects set the view.
    """
    floor = None
    interesting = []
    for entity in (scene or {}).get("entities", []):
        if entity.get("id") == "floor":
            floor = entity
            continue
        xs: list[float] = []
        ys: list[float] = []
        for kind in ("cubes", "cylinders", "spheres"):
            for primitive in entity.get(kind, []):
                patch, px, py = _footprint(kind, primitive)
                ax.add_patch(patch)
                xs += px
                ys += py
        if extent is not None:
            extent[0].extend(xs)
            extent[1].extend(ys)
        if xs and _tags(entity) & INTEREST_TAGS:
            interesting.append((str(entity.get("id", "?")), (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2))
    return floor, interesting


def _label_objects(ax: Any, objects: Sequence[tuple[str, float, float]]) -> None:
    """Name each object of interest on the map: a red ring and its name in a box beside it."""
    for name, x, y in objects:
        ax.plot(x, y, "o", ms=13, mfc="none", mec="#c0392b", mew=1.6, zorder=6)
        ax.annotate(name, xy=(x, y), xytext=(10, 10), textcoords="offset points", fontsize=8, color="#c0392b",
                    fontweight="bold", zorder=7, parse_math=False,
                    bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "#c0392b", "alpha": 0.9})


@_styled
def map_svg(scene: Mapping[str, Any] | None, paths: Mapping[str, Mapping[str, np.ndarray]]) -> str:
    """Top-down map (x-y, world frame, m): scene objects, and each robot's true and estimated path.

    ``paths``: robot -> ``{"truth": (N, 3), "estimate": (M, 3)}`` (either may be missing).
    The view is a square around the paths and the objects of interest (named on the map) with a
    margin of 25 % (at least 3 m), or around the scene objects (not the floor) when there are no paths.
    """
    fig = _figure(7.0, 6.0)
    ax = fig.add_subplot()
    xs, ys = _plot_paths(ax, paths)
    has_paths = bool(xs)
    floor, interesting = _plot_scene(ax, scene, None if has_paths else (xs, ys))
    _label_objects(ax, interesting)
    xs += [x for _, x, _ in interesting]
    ys += [y for _, _, y in interesting]
    if not xs:
        xs, ys = [-1.0, 1.0], [-1.0, 1.0]
    span = max(max(xs) - min(xs), max(ys) - min(ys), 1.0)
    half = span / 2 + (max(0.25 * span, 3.0) if has_paths else 0.08 * span)
    cx, cy = (max(xs) + min(xs)) / 2, (max(ys) + min(ys)) / 2
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cy - half, cy + half)
    if floor is not None:
        ax.set_facecolor("#f4f4f0")
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x (m, world)")
    ax.set_ylabel("y (m, world)")
    ax.grid(True, lw=0.3, alpha=0.5)
    if paths:
        legend = ax.legend(loc="best", fontsize=8, framealpha=0.8)
        for text in legend.get_texts():
            text.set_parse_math(False)
    ax.set_title("true path (solid; ● start, ■ end) and onboard estimate (dashed)")
    return _svg(fig, "top-down map of the scene with every robot's true and estimated path")


# ------------------------------------------------------------------ tree timeline
@_styled
def timeline_svg(
    rows: Sequence[Mapping[str, Any]],
    end: float,
    preemptions: Sequence[Mapping[str, Any]] = (),
    operator: Sequence[Mapping[str, Any]] = (),
    outcome: str | None = None,
) -> str:
    """The behaviour-tree timeline: one row per node, bars coloured by state over simulated time.

    ``rows``: ``{"name", "depth", "intervals": [(start s, end s, state)]}`` in tree order (states:
    :data:`STATUS_COLOURS`; guards that do not hold are neutral, never FAILURE); a state reached at the
    run's last tick (``start == end``) is a marker on the end line, labelled with ``outcome``;
    ``preemptions``: ``{"t", "row"}`` (row index, or None: marked across the chart);
    ``operator``: ``{"t", "command"}`` drawn as dashed vertical lines.
    In the SVG, row ``i``'s bars of a state are the group ``timeline-row<i>-<state>`` (lower case) and its
    label ``timeline-label<i>``.
    """
    height = 0.9 + 0.21 * max(len(rows), 1)
    fig = _figure(9.5, height)
    ax = fig.add_subplot()
    indent = 9.0  # pt per tree level
    column = 6.0 + max((4.7 * len(str(n["name"])) + indent * int(n["depth"]) for n in rows), default=0.0)  # pt
    shown = set()
    for row, node in enumerate(rows):
        for state, colour in STATUS_COLOURS.items():
            spans = [(a, b) for a, b, s in node["intervals"] if s == state]
            bars = [(a, max(b - a, end * 1e-3)) for a, b in spans if a < end - 1e-9]
            if bars:
                ax.broken_barh(bars, (row - 0.38, 0.76), facecolors=colour, gid=f"timeline-row{row}-{state.lower()}")
            if len(bars) < len(spans):  # reached at the last tick: drawn on the end line
                ax.plot(end, row, marker="D", ms=6, color=colour, mec="black", mew=0.6, clip_on=False, zorder=6,
                        gid=f"timeline-row{row}-{state.lower()}-final")
            shown.update([state] if spans else [])
        ax.annotate(str(node["name"]), xy=(0, row), xycoords=("axes fraction", "data"), ha="left", va="center",
                    xytext=(-column + indent * int(node["depth"]), 0), textcoords="offset points", fontsize=8,
                    annotation_clip=False, parse_math=False, gid=f"timeline-label{row}")
    for mark in preemptions:
        if mark.get("row") is not None:
            ax.plot(mark["t"], mark["row"], marker="v", color="black", ms=7, zorder=5)
        else:
            ax.axvline(mark["t"], color="black", lw=0.8, ls=":")
    for command in operator:
        ax.axvline(command["t"], color="#555", lw=0.8, ls="--")
        ax.text(command["t"], -0.9, str(command["command"]), fontsize=7, rotation=90, va="bottom", ha="right",
                parse_math=False, color="#333")
    ax.axvline(end, color="black", lw=1.0)
    if outcome is not None:
        ax.text(end, -0.55, f"end: {outcome}", fontsize=8, ha="right", va="bottom", fontweight="bold",
                parse_math=False, gid="timeline-outcome")
    ax.set_xlim(0, max(end, 1e-3))
    ax.set_ylim(len(rows) - 0.5, -1.0 if operator or outcome is not None else -0.5)
    ax.set_yticks([])
    ax.set_xlabel("simulated time (s)")
    ax.grid(True, axis="x", lw=0.3, alpha=0.6)
    handles: list[Artist] = [Patch(color=c, label=STATUS_LABELS[s]) for s, c in STATUS_COLOURS.items() if s in shown]
    handles.append(Line2D([], [], marker="D", color="#888", mec="black", ls="", label="state at the end"))
    handles.append(Line2D([], [], marker="v", color="black", ls="", label="preempted"))
    if operator:
        handles.append(Line2D([], [], color="#555", ls="--", label="operator command"))
    ax.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=min(len(handles), 5), fontsize=8,
              frameon=False, borderaxespad=3.5 if operator else 0.5)  # above the operator commands' names
    return _svg(fig, "behaviour-tree timeline: one row per node, coloured by state over simulated time")


@_styled
def phases_svg(rows: Sequence[Mapping[str, Any]], end: float) -> str:
    """The phases skills went through (docking phases, landing states): ``{"name", "intervals": [(a, b, phase)]}``.

    One row per node; each phase a bar in its own colour (the same in every row, named in the legend),
    labelled with its name where the label fits.
    """
    phases = list(dict.fromkeys(phase for node in rows for _, _, phase in node["intervals"]))
    colour = {phase: _PHASE_COLOURS[i % len(_PHASE_COLOURS)] for i, phase in enumerate(phases)}
    legend_rows = math.ceil(len(phases) / 5)
    fig = _figure(9.5, 0.8 + 0.32 * len(rows) + 0.22 * legend_rows)
    ax = fig.add_subplot()
    points_per_s = 560.0 / max(end, 1e-3)  # about the axes' width in pt over the run
    for row, node in enumerate(rows):
        for a, b, phase in node["intervals"]:
            ax.broken_barh([(a, max(b - a, end * 4e-3))], (row - 0.4, 0.8), facecolors=colour[phase],
                           alpha=0.85, edgecolor="white")
            if (b - a) * points_per_s > 4.3 * len(phase) + 6:
                ax.text(a + (b - a) / 2, row, phase, ha="center", va="center", fontsize=7, color="white",
                        clip_on=True, parse_math=False)
    ax.set_yticks(range(len(rows)), [str(node["name"]) for node in rows])
    for label in ax.get_yticklabels():
        label.set_parse_math(False)
    ax.set_xlim(0, max(end, 1e-3))
    ax.set_ylim(len(rows) - 0.5, -0.5)
    ax.set_xlabel("simulated time (s)")
    ax.grid(True, axis="x", lw=0.3, alpha=0.6)
    legend = ax.legend(handles=[Patch(color=colour[p], label=p) for p in phases], loc="lower center",
                       bbox_to_anchor=(0.5, 1.0), ncol=min(len(phases), 5), fontsize=7, frameon=False, title="phase",
                       title_fontsize=8)
    for text in legend.get_texts():
        text.set_parse_math(False)
    return _svg(fig, "phases reported by the skills over simulated time")


# ------------------------------------------------------------------ metrics
def _segments(t: np.ndarray, values: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """A sampled series cut where two samples are more than :data:`GAP_FACTOR` × the median interval apart."""
    if len(t) < 3:  # no interval to compare with
        return [(t, values)]
    steps = np.diff(t)
    cuts = np.flatnonzero(steps > GAP_FACTOR * max(float(np.median(steps)), 1e-9)) + 1
    return list(zip(np.split(t, cuts), np.split(values, cuts), strict=True))


def _draw_series(ax: Any, spec: MetricSpec | None, t: np.ndarray, values: np.ndarray, end: float, colour: str,
                 label: str, gid: str) -> None:
    """One label set of a metric: markers (occurrences), steps (running counts) or lines broken at gaps."""
    if spec is not None and spec.event_like:
        ax.plot(t, values, ls="", marker="o", ms=6, color=colour, label=label, gid=gid, clip_on=False)
        if len(t) <= 8:
            for x, y in zip(t, values, strict=True):
                ax.annotate(format_value(float(y), spec.unit), (x, y), xytext=(5, 5), textcoords="offset points",
                            fontsize=7, color=colour)
        return
    if spec is not None and spec.aggregation == "total":
        ax.step(np.append(t, max(end, t[-1])), np.append(values, values[-1]), where="post", lw=1.2, color=colour,
                label=label, gid=gid)
        return
    for index, (ts, vs) in enumerate(_segments(t, values)):
        style = {"lw": 1.2} if len(ts) > 1 else {"ls": "", "marker": "o", "ms": 4}
        ax.plot(ts, vs, color=colour, label=label if index == 0 else None, gid=f"{gid}-{index}", **style)


@_styled
def metric_svgs(
    series: Mapping[str, Mapping[str, tuple[np.ndarray, np.ndarray]]],
    end: float,
    specs: Mapping[str, MetricSpec | None],
) -> list[tuple[str, str]]:
    """One small plot per metric: ``{name: {labels text: (t s, values)}}`` -> ``[(name, svg)]``.

    The title is the metric's meaning and the value axis names its unit (``specs``, the registry's
    declarations; None: undeclared). Occurrences are markers, running counts steps, and sampled values lines
    that break where nothing was measured. In the SVG, label set ``i`` of metric ``name`` is the group
    ``metric-<name>-<i>`` (a sampled one's segments ``metric-<name>-<i>-<k>``).
    """
    out = []
    for name, lines in series.items():
        spec = specs.get(name)
        fig = _figure(4.6, 2.8)
        ax = fig.add_subplot()
        for index, (labels, (t, values)) in enumerate(lines.items()):
            _draw_series(ax, spec, t, values, end, robot_colour(index), labels or name, f"metric-{name}-{index}")
        ax.set_title("\n".join(textwrap.wrap(spec.meaning if spec else f"{name} (not declared)", 60)),
                     parse_math=False, fontsize=9)
        ax.set_xlabel("simulated time (s)")
        ax.set_ylabel(axis_label(spec, name), parse_math=False)
        ax.set_xlim(0, max(end, 1e-3))
        ax.grid(True, lw=0.3, alpha=0.5)
        if len(lines) > 1 or next(iter(lines), ""):
            legend = ax.legend(fontsize=7, framealpha=0.8)
            for text in legend.get_texts():
                text.set_parse_math(False)
        out.append((name, _svg(fig, f"metric {name} over simulated time")))
    return out


# ------------------------------------------------------------------ campaigns
@_styled
def outcome_svg(outcomes: Mapping[str, int]) -> str:
    """Bar chart of trial outcomes (counts)."""
    fig = _figure(5.0, 2.6)
    ax = fig.add_subplot()
    names = list(outcomes)
    colours = [STATUS_COLOURS["SUCCESS"] if n == "success" else STATUS_COLOURS["FAILURE"] for n in names]
    ax.bar(range(len(names)), [outcomes[n] for n in names], color=colours)
    ax.set_xticks(range(len(names)), names)
    for label in ax.get_xticklabels():
        label.set_parse_math(False)
    ax.set_ylabel("trials")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_title("outcomes")
    return _svg(fig, "bar chart of trial outcomes")


@_styled
def histograms(
    values: Mapping[str, Sequence[float]], specs: Mapping[str, MetricSpec | None] | None = None
) -> list[tuple[str, str]]:
    """One histogram per quantity (``{name: values}``, non-finite values left out) -> ``[(name, svg)]``.

    ``specs``: a metric's declaration by name (its meaning under the title, its unit on the axis).
    """
    out = []
    for name, data in values.items():
        finite = [float(v) for v in data if v is not None and math.isfinite(float(v))]
        if not finite:
            continue
        spec = (specs or {}).get(name)
        fig = _figure(4.6, 2.8)
        ax = fig.add_subplot()
        ax.hist(finite, bins=min(20, max(5, len(finite) // 2)), color="#4a7ab5", edgecolor="white")
        title = [f"{name} (n={len(finite)})"] + (textwrap.wrap(spec.meaning, 60) if spec is not None else [])
        ax.set_title("\n".join(title), parse_math=False, fontsize=9)
        if spec is not None:
            ax.set_xlabel(axis_label(spec, name.partition("[")[0]), parse_math=False)
        ax.set_ylabel("trials")
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        out.append((name, _svg(fig, f"histogram of {name} over the trials")))
    return out
