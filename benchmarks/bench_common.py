"""What every benchmark script shares: best-of timing, machine facts, rich tables, the JSON report.

The scripts run as ``python benchmarks/<name>.py``, so this module is found
next to them. Wall-clock timing lives here and in the scripts only, never in tests.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from marsupial.trees.campaign import run_campaign
from rich.console import Console
from rich.table import Table

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


def campaign_arguments(description: str, quick_help: str, out: Path, report: Path) -> argparse.ArgumentParser:
    """The options of a benchmark that runs missions through the campaign runner and writes a Markdown report."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help=quick_help)
    parser.add_argument("--workers", type=int, default=2, help="parallel runs (default 2)")
    parser.add_argument("--runs", type=Path, default=None,
                        help="folder for the campaigns and their logs (default: a temporary one); a campaign already "
                             "finished there with the same plan is read back instead of run again")
    parser.add_argument("--out", type=Path, default=out, help=f"JSON output (default {out.relative_to(out.parents[2])})")
    parser.add_argument("--report", type=Path, default=report, help="Markdown report (PNGs go to its img/ folder)")
    return parser


def campaign(mission: str, trials: int, out: Path, overrides: Mapping[str, str] | None = None,
             vary: Mapping[str, Sequence[str]] | None = None, base_seed: int = 0, until: float | None = None,
             workers: int = 1) -> dict[str, Any]:
    """Run a campaign into ``out`` with every log kept, or read it back if ``out`` already holds the same plan.

    The same plan: mission, seeds, ``--set`` overrides, varied values, time
    limit and trial count all equal (a benchmark interrupted or re-run with
    ``--runs DIR`` resumes where it stopped; after a code change, use a new
    folder). Returns the campaign summary; each trial's record in
    ``trials.json`` has its CPU seconds (``cpu_time``).
    """
    overrides = {k: str(v) for k, v in (overrides or {}).items()}
    vary = {k: [str(x) for x in v] for k, v in (vary or {}).items()}
    combos = math.prod(len(v) for v in vary.values()) if vary else 1
    done = out / "summary.json"
    if done.exists() and (out / "trials.json").exists():
        old = json.loads(done.read_text())
        if (old.get("mission"), old.get("base_seed"), old.get("set"), old.get("vary"), old.get("until"), old.get("trials")) \
                == (mission, base_seed, overrides, vary, until, trials * combos):
            print(f"reusing {out} ({old['trials']} trials)")
            return old
    return run_campaign(mission, trials, out, base_seed=base_seed, overrides=overrides, vary=vary or None,
                        workers=workers, until=until, keep_logs="all")


def machine_info(**extra: Any) -> dict[str, Any]:
    """Python, platform, CPU count and load average (other processes slow every figure down), plus ``extra``."""
    info: dict[str, Any] = {"python": platform.python_version(), "platform": platform.platform(), "cpus": os.cpu_count()}
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


def write_report(report: dict[str, Any], out: Path) -> None:
    """Write ``report`` as indented JSON to ``out`` (folders made as needed) and say where."""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=2, default=float))  # numpy scalars as numbers
    print(f"\nwrote {out}")
