"""What every benchmark script shares: best-of timing, campaigns, machine facts, rich tables, the JSON report.

The scripts run as ``python -m benchmarks.<name>`` or ``python benchmarks/<name>.py``
(:data:`RUN_AS_FILE` lets the package import itself then). Wall-clock timing
lives here and in the scripts only, never in tests.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from marsupial.trees.campaign import CampaignSpec, run_campaigns

#: one printed table: title, column headers, rows of cell texts
Section = tuple[str, Sequence[str], Sequence[Sequence[str]]]


def best_seconds(fn: Callable[[], Any], repeats: int) -> float:
    """Shortest wall time (s) of ``repeats`` calls of ``fn``: the least disturbed by other processes."""
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def command_line(script: str, argv: Sequence[str] | None) -> str:
    """The command that ran ``script`` (``argv``: its arguments, default ``sys.argv[1:]``), as a results page quotes it.

    A folder of this machine (an absolute path, or the value of ``--runs``) is written as the option's name in
    capitals (``--runs RUNS``): a page names no folder of the machine it was made on.
    """
    args = list(sys.argv[1:] if argv is None else argv)
    shown: list[str] = []
    for i, arg in enumerate(args):
        option = args[i - 1] if i > 0 and args[i - 1].startswith("--") else None
        if option is not None and (option == "--runs" or os.path.isabs(arg)):
            arg = option.lstrip("-").replace("-", "_").upper()
        elif arg.startswith("--") and "=" in arg and os.path.isabs(arg.split("=", 1)[1]):
            name = arg.split("=", 1)[0]
            arg = f"{name}={name.lstrip('-').replace('-', '_').upper()}"
        shown.append(arg)
    return " ".join([f"python benchmarks/{script}", *shown])


def campaign_arguments(description: str, quick_help: str, out: Path, report: Path) -> argparse.ArgumentParser:
    """The options of a benchmark that runs missions through the campaign runner and writes a Markdown report."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help=quick_help)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                        help="parallel trials (default: every core, here %(default)s)")
    parser.add_argument("--runs", type=Path, default=None,
                        help="folder for the campaigns and their logs (default: a temporary one); the trials already "
                             "finished there with the same plan are read back instead of run again")
    parser.add_argument("--out", type=Path, default=out,
                        help=f"JSON output (default {out.relative_to(out.parents[2])})")
    parser.add_argument("--report", type=Path, default=report, help="Markdown report (PNGs go to its img/ folder)")
    return parser


def campaign_spec(mission: str, trials: int, out: Path, overrides: Mapping[str, Any] | None = None,
                  vary: Mapping[str, Sequence[Any]] | None = None, base_seed: int = 0,
                  until: float | None = None) -> CampaignSpec:
    """A benchmark's campaign: every log kept (the figures are computed from them), values given as text."""
    return CampaignSpec(mission, trials, out, base_seed, {k: str(v) for k, v in (overrides or {}).items()},
                        {k: [str(x) for x in v] for k, v in (vary or {}).items()}, until, keep_logs="all")


def campaigns(specs: Sequence[CampaignSpec], workers: int | None) -> list[dict[str, Any]]:
    """Run the trials of ``specs`` in one pool of ``workers`` processes (``trees/campaign.py``); their summaries.

    Each campaign's records go to ``out/trials.json`` (each with its CPU
    seconds, ``cpu_time``) and its summary to ``out/summary.json``. The trials
    already finished in ``out`` with the same plan (mission, seed, ``--set``
    overrides, varied values, time limit) are read back instead of run: a
    benchmark interrupted or re-run with ``--runs DIR`` resumes where it
    stopped, and one re-run with more trials runs only the new ones (after a
    code change, use a new folder).
    """
    return run_campaigns(specs, workers=workers, resume=True)


def campaign(mission: str, trials: int, out: Path, overrides: Mapping[str, Any] | None = None,
             vary: Mapping[str, Sequence[Any]] | None = None, base_seed: int = 0, until: float | None = None,
             workers: int | None = None) -> dict[str, Any]:
    """One campaign through :func:`campaigns`; its summary."""
    return campaigns([campaign_spec(mission, trials, out, overrides, vary, base_seed, until)], workers)[0]


def machine_info(**extra: Any) -> dict[str, Any]:
    """Python, platform, CPU count and load average (other processes slow every figure down), plus ``extra``."""
    info: dict[str, Any] = {"python": platform.python_version(), "platform": platform.platform(),
                            "cpus": os.cpu_count()}
    info.update(extra)
    if hasattr(os, "getloadavg"):
        info["load_average_1_5_15min"] = [round(x, 2) for x in os.getloadavg()]
    return info


def print_tables(sections: Sequence[Section], machine: dict[str, Any]) -> None:
    """Print each section as a rich table, then the machine's load average."""
    console = Console()
    for title, header, rows in sections:
        table = Table(title=title)
        for column in header:
            table.add_column(column)
        for row in rows:
            table.add_row(*row)
        console.print(table)
    if "load_average_1_5_15min" in machine:
        print(f"machine load average (1, 5, 15 min): {machine['load_average_1_5_15min']}")


def print_targets(title: str, labels: Mapping[str, str], checks: Mapping[str, tuple[bool, str]],
                  machine: dict[str, Any]) -> None:
    """Print a benchmark's targets: each one's label (``labels`` by key), what was measured and whether it was met."""
    rows = [(labels[k], measured, "yes" if ok else "NO") for k, (ok, measured) in checks.items()]
    print_tables([(title, ("target", "measured", "met"), rows)], machine)


def targets_lines(labels: Mapping[str, str], checks: Mapping[str, tuple[bool, str]]) -> list[str]:
    """A results page's "Targets" section: a Markdown table of each target's label, what was measured, met."""
    return ["## Targets", "", "| target | measured | met |", "|---|---|---|",
            *(f"| {labels[k]} | {text} | {'yes' if ok else '**no**'} |" for k, (ok, text) in checks.items())]


def conclude(title: str, labels: Mapping[str, str], checks: Mapping[str, tuple[bool, str]], results: dict[str, Any],
             report: Path, out: Path) -> dict[str, Any]:
    """A benchmark's ending: its targets into ``results`` and printed, the Markdown ``report`` named, the JSON
    written to ``out``; returns ``results``."""
    results["targets"] = {k: {"met": ok, "measured": m} for k, (ok, m) in checks.items()}
    print_targets(title, labels, checks, results["machine"])
    print(f"report: {report}")
    write_report(results, out)
    return results


def write_report(report: dict[str, Any], out: Path) -> None:
    """Write ``report`` as indented JSON to ``out`` (folders made as needed) and say where."""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=2, default=float))  # numpy scalars as numbers
    print(f"\nwrote {out}")
