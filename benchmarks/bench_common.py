"""What every benchmark script shares: best-of timing, machine facts, rich tables, the JSON report.

The scripts run as ``python benchmarks/<name>.py``, so this module is found
next to them. Wall-clock timing lives here and in the scripts only, never in tests.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import platform
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from marsupial.trees.campaign import run_campaign, summarize

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
    parser.add_argument("--out", type=Path, default=out,
                        help=f"JSON output (default {out.relative_to(out.parents[2])})")
    parser.add_argument("--report", type=Path, default=report, help="Markdown report (PNGs go to its img/ folder)")
    return parser


def campaign(mission: str, trials: int, out: Path, overrides: Mapping[str, str] | None = None,
             vary: Mapping[str, Sequence[str]] | None = None, base_seed: int = 0, until: float | None = None,
             workers: int = 1) -> dict[str, Any]:
    """Run a campaign into ``out`` with every log kept, ``workers`` seeds at a time, reading back those already run.

    Each seed is a campaign of its own (``out/seed_<s>``), read back when that folder already holds the
    same plan: mission, seed, ``--set`` overrides, varied values and time
    limit. A benchmark interrupted or re-run with ``--runs DIR`` resumes where
    it stopped, and one re-run with more trials runs only the new seeds
    (after a code change, use a new folder). The merged records are written
    to ``out/trials.json`` (each with its CPU seconds, ``cpu_time``) and the
    summary of them all to ``out/summary.json``, which is returned.
    """
    overrides = {k: str(v) for k, v in (overrides or {}).items()}
    vary = {k: [str(x) for x in v] for k, v in (vary or {}).items()}
    seeds = list(range(base_seed, base_seed + trials))
    jobs = [(mission, out / f"seed_{seed}", overrides, vary, seed, until, 1 if len(seeds) > 1 else workers)
            for seed in seeds]
    if workers > 1 and len(seeds) > 1:  # one process per seed (each seed's runs then in its own process)
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            list(pool.map(_campaign_of_one_seed, *zip(*jobs, strict=True)))
    else:
        for job in jobs:
            _campaign_of_one_seed(*job)
    records = []
    for seed in seeds:
        records += json.loads((out / f"seed_{seed}" / "trials.json").read_text())
    for index, record in enumerate(records):
        record["trial"] = index
    summary = {"mission": mission, "base_seed": base_seed, "set": overrides, "vary": vary, "until": until,
               **summarize(records)}
    out.mkdir(parents=True, exist_ok=True)
    (out / "trials.json").write_text(json.dumps(records, indent=2))
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary


def _campaign_of_one_seed(mission: str, out: Path, overrides: dict[str, str], vary: dict[str, list[str]], seed: int,
                          until: float | None, workers: int) -> dict[str, Any]:
    """One trial per combination of ``vary`` at ``seed`` into ``out``, or its summary read back (same plan).

    A campaign with another time limit counts as the same plan when none of
    its trials was stopped by a limit and each ended before ``until``: the
    runs are deterministic, so they are the runs ``until`` would give.
    """
    combos = math.prod(len(v) for v in vary.values()) if vary else 1
    done = out / "summary.json"
    if done.exists() and (out / "trials.json").exists():
        old = json.loads(done.read_text())
        if (old.get("mission"), old.get("base_seed"), old.get("set"), old.get("vary"), old.get("trials")) \
                == (mission, seed, overrides, vary, combos):
            records = json.loads((out / "trials.json").read_text())
            ended = all(r["outcome"] != "time_limit" and (until is None or r["sim_time"] < until) for r in records)
            if old.get("until") == until or ended:
                print(f"reusing {out} ({old['trials']} trials)")
                return old
    return run_campaign(mission, 1, out, base_seed=seed, overrides=overrides, vary=vary or None,
                        workers=workers, until=until, keep_logs="all")


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
