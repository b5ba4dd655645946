"""What running the tree in a process of its own costs: the default mission with and without ``--isolate``.

    python benchmarks/isolation.py [--mission usar_docking] [--until S] [--out benchmarks/out/isolation.json]

Runs the mission once in-process and once isolated (the tree and its skills
in a child process, the same tick messages pickled over a pipe in lockstep),
both with their logs, and compares what they recorded: the events (every
field but wall-clock ones) and the outcome must be the same. Prints the wall
times, the real-time factors and their ratio (target: isolated ≤ 1.25 × the
in-process wall time), and writes them as JSON. Wall-clock figures only
grow with other load on the machine: run it on a quiet one.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from marsupial.trees.cli import DEFAULT_MISSION
from marsupial.trees.replay import compare_events, read_log
from marsupial.trees.runner import run_mission


def measure(mission: str, until: float | None, folder: Path) -> dict[str, Any]:
    """Run ``mission`` in-process and isolated; wall times, RTFs, outcomes and the first event that differs."""
    runs = {}
    for isolate in (False, True):
        log = folder / f"{'isolated' if isolate else 'in_process'}.mcap"
        result = run_mission(mission, log_path=log, until=until, progress=False, isolate=isolate)
        runs[isolate] = (result, read_log(log))
    (local, local_log), (isolated, isolated_log) = runs[False], runs[True]
    differences = compare_events(local_log, isolated_log)
    return {
        "mission": mission,
        "sim_time_s": local.sim_time,
        "outcome": {"in_process": local.outcome, "isolated": isolated.outcome},
        "wall_s": {"in_process": local.wall_time, "isolated": isolated.wall_time},
        "rtf": {"in_process": local.real_time_factor, "isolated": isolated.real_time_factor},
        "ratio": isolated.wall_time / local.wall_time,
        "events_identical": not differences,
        "first_difference": differences[0] if differences else None,
    }


def main() -> None:
    """Measure, print the table, write the JSON (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mission", default=DEFAULT_MISSION)
    parser.add_argument("--until", type=float, help="time limit (sim s; default: the mission's)")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/out/isolation.json"))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        figures = measure(args.mission, args.until, Path(tmp))
    table = Table(title=f"{figures['mission']}: in-process vs --isolate ({figures['sim_time_s']:.1f} s simulated)")
    for column in ("run", "outcome", "wall time (s)", "real-time factor"):
        table.add_column(column)
    for key, name in (("in_process", "in-process"), ("isolated", "--isolate")):
        table.add_row(name, figures["outcome"][key], f"{figures['wall_s'][key]:.1f}", f"{figures['rtf'][key]:.1f}x")
    Console().print(table)
    print(f"isolated / in-process wall time: {figures['ratio']:.2f} (target <= 1.25); "
          f"events identical: {figures['events_identical']}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(figures, indent=2) + "\n")


if __name__ == "__main__":
    main()
