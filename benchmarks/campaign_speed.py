"""How much a campaign gains from parallel trials: docking encounters on N workers against one after another.

    python -m benchmarks.campaign_speed [--trials 100] [--workers 2] [--until S]
                                        [--out benchmarks/out/campaign_speed.json]

The trials are the first ``--trials`` of the randomized docking encounters
of ``benchmarks/uav_docking.py`` (its 5 UAV starts × 4 carrier speeds, seed
by seed: 100 trials are seeds 0–4 of all 20). The campaign runner
(``trees/campaign.py``, :func:`run_trials`) runs them twice: one after
another in this process (``workers=1``), then ``--workers`` at a time in
spawned processes. Reported: both wall times, their ratio (target: ≤ 0.55
with 2 workers on 2 cores) and whether every trial's result (outcome,
simulated time, ticks, metrics, message) is the same in both. No log is
kept. ``--until`` stops each encounter at that simulated time (default: the
mission's own 60 s limit).

Other processes slow a wall-clock benchmark down: run it on a quiet machine.
Prints a table and writes the figures as JSON; exits with 1 when a target is
missed.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

if not __package__:  # run as a file (python benchmarks/<name>.py): the benchmarks package from the repository
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from benchmarks.bench_common import machine_info, print_tables, print_targets, write_report
from benchmarks.uav_docking import ENCOUNTER, encounter_grid
from marsupial.trees.campaign import plan_trials, run_trials

DEFAULT_OUT = Path(__file__).resolve().parent / "out" / "campaign_speed.json"
TARGET_RATIO = 0.55  # parallel wall time / serial wall time, 2 workers on 2 cores (issue 26)
RESULT_KEYS = ("trial", "seed", "params", "outcome", "sim_time", "ticks", "metrics", "message")
TARGETS = {"ratio": f"wall time on the workers ≤ {TARGET_RATIO} × one after another",
           "identical": "every trial's result the same in both runs"}


def encounter_trials(count: int, until: float | None) -> list[Any]:
    """The first ``count`` trials of the randomized encounters (every start × speed of a seed, then the next)."""
    grid = encounter_grid(quick=False)
    per_seed = math.prod(len(values) for values in grid.values())
    return plan_trials(str(ENCOUNTER), math.ceil(count / per_seed), vary=grid, until=until)[:count]


def results(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """What each trial's run decided: everything but its wall and CPU seconds (and its log, none kept here)."""
    return [{key: record[key] for key in RESULT_KEYS} for record in records]


def measure(trials: int, workers: int, until: float | None) -> dict[str, Any]:
    """Wall seconds of the trials one after another and on ``workers``, and whether their results are identical."""
    plan = encounter_trials(trials, until)
    started = time.perf_counter()
    serial = run_trials(plan, workers=1, label="one after another")
    serial_s = time.perf_counter() - started
    started = time.perf_counter()
    parallel = run_trials(plan, workers=workers, label=f"{workers} workers")
    parallel_s = time.perf_counter() - started
    differing = [a["trial"] for a, b in zip(results(serial), results(parallel), strict=True) if a != b]
    return {
        "trials": len(plan), "workers": workers, "until": until,
        "serial_wall_s": serial_s, "parallel_wall_s": parallel_s, "ratio": parallel_s / serial_s,
        "identical": not differing, "differing_trials": differing,
        "sim_s": sum(r["sim_time"] for r in serial), "cpu_s_serial": sum(r["cpu_time"] for r in serial),
        "outcomes": [r["outcome"] for r in serial], "per_trial": results(serial),
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print the tables, write the JSON report; returns the report."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=100, help="encounters (default 100)")
    parser.add_argument("--workers", type=int, default=2, help="parallel trials of the second run (default 2)")
    parser.add_argument("--until", type=float, default=None, help="simulated-time limit of each encounter (s)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="JSON report path")
    args = parser.parse_args(argv)
    if args.trials < 1 or args.workers < 1:
        parser.error("--trials and --workers must be positive integers")
    if args.until is not None and not (math.isfinite(args.until) and args.until > 0):
        parser.error(f"--until must be a positive number of simulated seconds, got {args.until}")
    report: dict[str, Any] = {"machine": machine_info(workers=args.workers, date=time.strftime("%Y-%m-%d"))}
    report["campaign"] = run = measure(args.trials, args.workers, args.until)
    checks = {"ratio": (run["ratio"] <= TARGET_RATIO, f"{run['ratio']:.2f}"),
              "identical": (run["identical"], "yes" if run["identical"] else f"no: trials {run['differing_trials']}")}
    report["targets"] = {key: {"met": ok, "measured": text} for key, (ok, text) in checks.items()}
    print_tables([(
        f"docking-encounter campaign, {run['trials']} trials ({run['sim_s']:.0f} s simulated)",
        ("run", "wall s", "ratio"),
        [("one after another (1 process)", f"{run['serial_wall_s']:.1f}", "1.00"),
         (f"{run['workers']} workers (spawned processes)", f"{run['parallel_wall_s']:.1f}", f"{run['ratio']:.2f}")],
    )], {})  # the load average once, under the targets
    print_targets("campaign speed targets", TARGETS, checks, report["machine"])
    write_report(report, args.out)
    return report


if __name__ == "__main__":
    sys.exit(0 if all(t["met"] for t in main()["targets"].values()) else 1)
