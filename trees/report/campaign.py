"""The report of a campaign folder (``marsupial campaign --out DIR``): statistics and every trial's report.

Reads ``summary.json`` and ``trials.json``; shows the success rate with its
Wilson 95 % interval (overall and per ``--vary`` combination), the outcome
breakdown, histograms of simulated times and of each metric's last value over
the trials (titled with its meaning and unit from the metric registry), and a
table of trials linking to each kept log's run report (written to
``reports/`` next to the campaign page).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from .. import metrics
from ..campaign import summarize, wilson_interval
from ..replay import LogError
from . import plots

__all__ = ["campaign_context", "write_campaign_report"]


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise LogError(f"{path.parent}: not a campaign folder (no {path.name}; "
                       "expected the --out of marsupial campaign)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise LogError(f"{path}: unreadable campaign file ({err})") from None


def _trial_log(folder: Path, record: dict[str, Any]) -> Path | None:
    """The trial's kept log: its recorded path, or the file of that name in ``<folder>/logs`` (folder moved)."""
    if not record.get("log"):
        return None
    recorded = Path(record["log"])
    for candidate in (recorded, folder / "logs" / recorded.name):
        if candidate.is_file():
            return candidate
    return None


def campaign_context(folder: Path, page: Path, reports: dict[int, Path]) -> dict[str, Any]:
    """Everything the campaign template shows; ``reports``: trial index -> its run report (linked from ``page``)."""
    summary = _read_json(folder / "summary.json")
    records = _read_json(folder / "trials.json")
    if not isinstance(records, list) or not isinstance(summary, dict):
        raise LogError(f"{folder}: summary.json / trials.json do not hold a marsupial campaign")
    overall = summarize(records)
    low, high = wilson_interval(overall["successes"], overall["trials"])
    groups = []
    for group in summary.get("groups") or []:
        members = [r for r in records if r.get("params") == group["params"]]
        stats = summarize(members)
        groups.append({"params": ", ".join(f"{k}={v}" for k, v in group["params"].items()),
                       **stats, "ci": wilson_interval(stats["successes"], stats["trials"])})
    metric_names = sorted({name for r in records for name in r.get("metrics", {})})
    values = {"simulated time (s)": [r["sim_time"] for r in records]}
    values.update({name: [r["metrics"][name] for r in records if name in r["metrics"]] for name in metric_names})
    base = page.parent
    trials = []
    for r in records:
        report = reports.get(r["trial"])
        trials.append({**r, "params_text": ", ".join(f"{k}={v}" for k, v in r.get("params", {}).items()),
                       "report": os.path.relpath(report, base) if report is not None else None})
    return {
        "title": f"{summary.get('mission', '?')} — marsupial campaign report",
        "mission": summary.get("mission", "?"),
        "summary": summary,
        "overall": overall,
        "ci": (low, high),
        "groups": groups,
        "outcome_svg": plots.outcome_svg(overall["outcomes"]) if records else None,
        "histograms": plots.histograms(values, {name: metrics.spec(name) for name in metric_names}),
        "trials": trials,
        "folder": folder.name,  # not the whole path: pages get published
    }


def write_campaign_report(folder: Path, page: Path) -> Path:
    """Write every kept trial log's report to ``<page dir>/reports/`` and the campaign page ``page``."""
    from . import render, render_run

    records = _read_json(folder / "trials.json")
    page.parent.mkdir(parents=True, exist_ok=True)
    reports: dict[int, Path] = {}
    for record in records if isinstance(records, list) else []:
        log = _trial_log(folder, record)
        if log is None:
            continue
        target = page.parent / "reports" / f"{log.stem}.html"
        target.parent.mkdir(exist_ok=True)
        back = {"← campaign report": os.path.relpath(page, target.parent)}
        target.write_text(render_run(log, links=back), encoding="utf-8")
        reports[record["trial"]] = target
    page.write_text(render("campaign.html.j2", campaign_context(folder, page, reports)), encoding="utf-8")
    return page
