"""The end-of-run summary of ``marsupial run``: how the run ended, what each robot achieved, and its metrics.

Two tables, built from plain data — the run's :class:`~marsupial.trees.runner.RunResult`,
its time limit, and what its log holds (:func:`read_story`):

1. the run: outcome (with what it means), seed, simulated and wall time,
   the log, and per robot its milestones in order
   (:mod:`marsupial.trees.milestones`: "docked at 110.9 s (…), stored …")
   and where it ended (true position, world frame) with its battery;
2. the metrics: one row per metric and label set, the value its declared
   aggregation gives (:mod:`marsupial.trees.metrics`) with its unit, and its
   one-line meaning.

Without a log (``--no-log``) there are no milestones, and each metric
shows its last value.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rich.console import Group
from rich.table import Table
from rich.text import Text

from . import metrics
from .milestones import Milestone, story, tell
from .replay import LogError, read_topics

if TYPE_CHECKING:
    from .runner import RunResult

__all__ = ["OUTCOME_MEANINGS", "RunStory", "read_story", "summary_table"]

#: outcome -> what it means, shown beside it
OUTCOME_MEANINGS = {
    "success": "the mission's tree succeeded",
    "failure": "the mission's tree failed",
    "time_limit": "the time limit came before the tree finished",
    "aborted": "the operator aborted the run",
    "error": "a node raised an error (below)",
    "interrupted": "stopped by Ctrl-C",
    "terminated": "stopped by SIGTERM",
}


@dataclass
class RunStory:
    """What a run's log tells: milestones by robot, and every metric's samples ``{name: {labels: [(t, v)]}}``."""

    milestones: dict[str, list[Milestone]] = field(default_factory=dict)
    samples: dict[str, dict[str, list[tuple[float, float]]]] = field(default_factory=dict)


def read_story(log_path: str | Path | None) -> RunStory | None:
    """The milestones and metric samples of a run's log (``/events``, ``/metrics``); ``None`` without a readable log."""
    if log_path is None:
        return None
    try:
        topics = read_topics(log_path, ("/events", "/metrics"))
    except LogError:
        return None
    events = [{"t": m.t, **m.data} for m in topics["/events"]]
    rows = [{"t": m.t, **m.data} for m in topics["/metrics"]]
    return RunStory(story(events), metrics.group_samples(rows))


def _robot_text(name: str, state: dict[str, Any], told: list[Milestone] | None) -> Text:
    """A robot's cell: its milestones (or why there are none), then its final position and battery."""
    if told is None:
        text = Text("milestones: in the log (this run wrote none)", style="dim")
    elif told:
        text = Text(tell(told))
    else:
        text = Text("no milestones reported", style="dim")
    where = "ended at [" + ", ".join(f"{v:.2f}" for v in state["position"]) + "] m (true, world frame)"
    if state.get("battery") is not None:
        where += f", battery {100 * state['battery']:.1f} %"
    text.append("\n" + where, style="dim")
    return text


def _run_table(result: RunResult, until: float | None, run_story: RunStory | None) -> Table:
    table = Table(title=f"mission {result.mission}", show_header=False, title_justify="left")
    table.add_column("", style="bold")
    table.add_column("")
    style = "green" if result.outcome == "success" else "red"
    meaning = OUTCOME_MEANINGS.get(result.outcome, "")
    table.add_row("outcome", Text.assemble((result.outcome, style), f"  ({meaning})" if meaning else ""))
    table.add_row("seed", str(result.seed))
    limit = f" of the {until:g} s time limit" if until is not None else ""
    table.add_row("sim time", f"{result.sim_time:.2f} s{limit} ({result.ticks} ticks)")
    table.add_row("wall time", f"{result.wall_time:.2f} s ({result.real_time_factor:.1f}× real time)")
    if result.log_path is not None:
        table.add_row("log", Text(str(result.log_path)))
    for name, state in result.robots.items():
        told = None if run_story is None else run_story.milestones.get(name, [])
        table.add_row(Text(name), _robot_text(name, state, told))
    others = {} if run_story is None else run_story.milestones
    for name in sorted(set(others) - set(result.robots)):  # milestones of a robot the result does not list
        table.add_row(Text(name), Text(tell(others[name])))
    if result.message:
        table.add_row("error", Text(result.message.strip().splitlines()[-1], style="red"))
    return table


def _metric_rows(result: RunResult, run_story: RunStory | None) -> list[tuple[str, str, str, str]]:
    """(metric, labels, value, meaning) rows, sorted by metric then labels."""
    rows = []
    if run_story is not None:
        for name, lines in sorted(run_story.samples.items()):
            item = metrics.spec(name)
            for labels, samples in sorted(lines.items()):
                value = metrics.summarize(item, [v for _, v in samples])
                rows.append((name, labels, value, item.meaning if item else ""))
        return rows
    for key, last in sorted(result.metrics.items()):
        name, _, labels = key.partition("[")
        item = metrics.spec(name)
        if item is None:
            value = f"{last:.4g} (undeclared metric: unit unknown)"
        else:
            value = ("last " if item.aggregation != "last" else "") + metrics.format_value(last, item.unit)
        rows.append((name, labels.rstrip("]"), value, item.meaning if item else ""))
    return rows


def _metrics_table(rows: list[tuple[str, str, str, str]]) -> Table:
    table = Table(title="metrics", title_justify="left")
    for column in ("metric", "labels", "value", "meaning"):
        table.add_column(column)
    for name, labels, value, meaning in rows:
        table.add_row(Text(name), Text(labels), Text(value), Text(meaning, style="dim"))
    return table


def summary_table(result: RunResult, until: float | None, run_story: RunStory | None) -> Group:
    """The summary of a finished run: the run table and, if it recorded any, the metrics table.

    ``until``: the run's time limit (simulated s, None: none); ``run_story``: what its log tells
    (:func:`read_story`; None: no log).
    """
    rows = _metric_rows(result, run_story)
    parts: list[Table] = [_run_table(result, until, run_story)]
    if rows:
        parts.append(_metrics_table(rows))
    return Group(*parts)
