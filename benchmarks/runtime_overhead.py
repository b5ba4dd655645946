"""How much the runtime costs: tree ticks per second with the recorder on, and the recorder's share of a run.

    python benchmarks/runtime_overhead.py [--quick] [--out benchmarks/out/runtime_overhead.json]

Four measurements, pinned to one CPU core:

1. Ticks per wall second of 200-node trees of trivial skills (each runs
   20-35 ticks, i.e. 2-3.5 s at 10 Hz, then succeeds; every start and end
   is a recorded event),
   compiled from a mission by the real compiler, ticked as the runner does
   (the world's tick input, the tree host's tick, its output applied and
   recorded: events, ``/tree`` snapshot) with the
   simulated clock advanced by one tick period and no physics:
   ``mission-like`` = a parallel of 20 ``repeat`` loops over sequences of 8
   skills (61 behaviours ticked per tick), ``all-ticked`` = a parallel of
   199 skills that never finish (every node ticked every tick: a stress
   case). Each with the recorder on and off. Target: >= 2,000 ticks/s for the
   mission-like tree with the recorder on.
2. Recorder overhead of a real run: ``run_mission`` of a 60 s mission with a
   ``bebop2`` flying a square and a ``summit_xl`` driving one (cheap skills,
   no cameras: the recorder's worst case), with and without a log, and with
   the log plus the live Foxglove server (``--live``; no client connected,
   not paced). The share is the wall time spent inside the recorder's calls
   (every sink's writes included) over the run's wall time. Target: <= 10 %.
3. The default mission (``marsupial run`` without arguments, which now logs
   by default) with and without its log: real-time factors (not with --quick).
4. Where the default mission's time goes (``benchmarks/profile_breakdown.py``):
   the engine's share (pybullet's ``stepSimulation``, ``getCameraImage``,
   ``rayTestBatch``) of a timed run, and the Python time by module of a
   cProfile run; with ``--quick`` its first 60 simulated seconds.

Every figure is the best of several repetitions (other processes only slow
a wall-clock benchmark down). Prints a table and writes the figures as JSON.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, ClassVar

import py_trees
from py_trees.common import Status
from pydantic import Field
from rich.console import Console
from rich.table import Table

if not __package__:  # run as a file (python benchmarks/<name>.py): the benchmarks package from the repository
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from benchmarks.bench_common import print_tables
from benchmarks.profile_breakdown import QUICK_UNTIL_S, breakdown, breakdown_sections
from marsupial.trees.bridge import WorldBridge
from marsupial.trees.cli import DEFAULT_MISSION
from marsupial.trees.host import TreeHost
from marsupial.trees.live import LiveSink
from marsupial.trees.mission import parse_mission
from marsupial.trees.recorder import Recorder
from marsupial.trees.runner import run_mission
from marsupial.trees.skill import NodeParams, Skill
from marsupial.world import World

TARGET_TICKS_PER_S = 2000.0
TARGET_RECORDER_SHARE = 0.10
TICK_HZ = 10.0
DEFAULT_OUT = Path(__file__).resolve().parent / "out" / "runtime_overhead.json"


class Trivial(Skill):
    """Runs ``ticks`` ticks, then succeeds (``ticks: 0`` runs forever); commands nothing."""

    class Params(NodeParams):
        ticks: int = Field(20, ge=0)
        """Ticks before success (0: never)."""

    uses_robot: ClassVar[bool] = False

    def start(self) -> None:
        self._count = 0

    def step(self) -> Status:
        self._count += 1
        return Status.SUCCESS if self._count == self.params.ticks else Status.RUNNING


def pin_to_one_core() -> str:
    """Run on one CPU core (Linux); returns a description."""
    if hasattr(os, "sched_setaffinity"):
        core = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {core})
        return f"core {core}"
    return "not pinned (no sched_setaffinity)"


def tree_mission(shape: str) -> str:
    """Mission text of a 200-node tree of trivial skills (``mission-like`` or ``all-ticked``)."""
    if shape == "mission-like":
        skills = ", ".join(f"{{skill: trivial, params: {{ticks: {20 + 5 * (i % 4)}}}}}" for i in range(8))
        sequence = "{sequence: [" + skills + "]}"
        children = "\n".join(f"    - {{repeat: {sequence}}}" for _ in range(20))
    else:
        children = "\n".join("    - {skill: trivial, params: {ticks: 0}}" for _ in range(199))
    return (f"mission: bench_{shape}\nplugins: {{trivial: benchmarks.runtime_overhead:Trivial}}\n"
            f"tree:\n  parallel:\n{children}\n")


def ticks_per_second(shape: str, ticks: int, record: bool, repeats: int) -> dict[str, Any]:
    """Best ticks/s of the tree ``shape`` over ``repeats`` runs of ``ticks`` ticks."""
    best, nodes, size = math.inf, 0, 0
    for _ in range(repeats):
        py_trees.blackboard.Blackboard.clear()
        with World() as world, tempfile.TemporaryDirectory() as tmp:
            recorder = Recorder(Path(tmp) / "bench.mcap", {"mission": shape}) if record else None
            bridge, mission = WorldBridge(world, recorder), parse_mission(tree_mission(shape))
            host = TreeHost.for_mission(mission, bridge.setup(mission, 0))
            nodes = sum(1 for _ in host.root.iterate())
            steps = world.clock.steps_for(1.0 / TICK_HZ)
            start = time.perf_counter()
            for _ in range(ticks):
                bridge.apply(host.tick(bridge.tick_input()))
                world.clock.steps += steps  # simulated time moves on; no physics in this measurement
            if recorder is not None:
                recorder.close("benchmark")
                size = (Path(tmp) / "bench.mcap").stat().st_size
            best = min(best, time.perf_counter() - start)
    return {"shape": shape, "nodes": nodes, "recorder": record, "ticks": ticks,
            "ticks_per_s": ticks / best, "log_bytes": size}


RUN_MISSION = """\
mission: bench_square
team:
  uav: {robot: bebop2, pose: [0, 0, 0]}
  ugv: {robot: summit_xl, pose: [0, -3, 0]}
run: {tick_hz: 10}
tree:
  parallel:
    - repeat:
        sequence:
          - {skill: goto, robot: uav, params: {target: [4, 0, 1.5], speed: 2.0}}
          - {skill: goto, robot: uav, params: {target: [4, 4, 1.5], speed: 2.0}}
          - {skill: goto, robot: uav, params: {target: [0, 4, 1.5], speed: 2.0}}
          - {skill: goto, robot: uav, params: {target: [0, 0, 1.5], speed: 2.0}}
    - repeat:
        sequence:
          - {skill: drive_to, robot: ugv, params: {target: [4, -3], speed: 1.0}}
          - {skill: drive_to, robot: ugv, params: {target: [4, -7], speed: 1.0}}
          - {skill: drive_to, robot: ugv, params: {target: [0, -7], speed: 1.0}}
          - {skill: drive_to, robot: ugv, params: {target: [0, -3], speed: 1.0}}
"""


@contextlib.contextmanager
def time_in_recorder() -> Iterator[list[float]]:
    """Accumulate the wall time spent inside :class:`Recorder` (construction, every log call, close)."""
    spent = [0.0]
    names = ("__init__", "close", "log_event", "log_metric", "log_text", "log_robot_poses", "log_tree", "log_scene",
             "log_image")
    originals = {name: getattr(Recorder, name) for name in names}

    def timed(method: Callable[..., Any]) -> Callable[..., Any]:
        def call(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return method(*args, **kwargs)
            finally:
                spent[0] += time.perf_counter() - start
        return call

    for name, method in originals.items():
        setattr(Recorder, name, timed(method))
    try:
        yield spent
    finally:
        for name, method in originals.items():
            setattr(Recorder, name, method)


def recorder_share(mission: str, seconds: float | None, repeats: int, live: bool = True) -> dict[str, Any]:
    """Wall time of a ``seconds``-long run of ``mission`` (a name or path; ``None``: to its end) without a log,
    with one, and with one and the live server (``live``); the share of it spent recording.

    The share is measured directly (time inside the recorder / the run's
    wall time, median of the repetitions), which other processes disturb far
    less than the difference of two wall times; both are reported.
    """
    variants = ("none", "log", "log+live") if live else ("none", "log")
    with tempfile.TemporaryDirectory() as tmp:
        walls = dict.fromkeys(variants, math.inf)
        shares: dict[str, list[float]] = {v: [] for v in variants[1:]}
        size = 0
        for _ in range(repeats):
            for variant in variants:
                log = Path(tmp) / "run.mcap" if variant != "none" else None
                sinks = [LiveSink(port=0)] if variant == "log+live" else []
                with time_in_recorder() as spent:
                    result = run_mission(mission, log_path=log, until=seconds, progress=False, sinks=sinks)
                walls[variant] = min(walls[variant], result.wall_time)
                if log is not None:
                    shares[variant].append(spent[0] / result.wall_time)
                    size = log.stat().st_size
    out = {"sim_seconds": result.sim_time, "wall_without_log_s": walls["none"], "wall_with_log_s": walls["log"],
           "real_time_factor_without_log": result.sim_time / walls["none"],
           "real_time_factor_with_log": result.sim_time / walls["log"],
           "recorder_share": statistics.median(shares["log"]),
           "recorder_share_from_wall_times": (walls["log"] - walls["none"]) / walls["log"], "log_bytes": size}
    if live:
        out.update(wall_with_log_and_live_s=walls["log+live"],
                   recorder_share_with_live=statistics.median(shares["log+live"]))
    return out


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print the table, write the JSON report; returns the report."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="fewer ticks, a shorter run, 60 s of the default mission profiled")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="JSON report path")
    args = parser.parse_args(argv)
    report: dict[str, Any] = {
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "cpu": pin_to_one_core(), "py_trees": _version("py_trees"), "quick": args.quick},
        "targets": {"ticks_per_s": TARGET_TICKS_PER_S, "recorder_share": TARGET_RECORDER_SHARE},
    }
    ticks, repeats = (500, 2) if args.quick else (3000, 5)
    report["ticks"] = [
        ticks_per_second(shape, ticks, record, repeats)
        for shape in ("mission-like", "all-ticked")
        for record in (True, False)
    ]
    with tempfile.TemporaryDirectory() as tmp:
        square = Path(tmp) / "square.yaml"
        square.write_text(RUN_MISSION)
        report["run"] = recorder_share(str(square), 20.0 if args.quick else 60.0, repeats)
    if not args.quick:
        report["default_mission"] = {"mission": DEFAULT_MISSION,
                                     **recorder_share(DEFAULT_MISSION, None, 2, live=False)}
    report["profile"] = breakdown(DEFAULT_MISSION, QUICK_UNTIL_S if args.quick else None)

    table = Table(title="marsupial runtime overhead (one core)", title_justify="left")
    for column in ("measurement", "value", "target"):
        table.add_column(column)
    for row in report["ticks"]:
        target = f">= {TARGET_TICKS_PER_S:,.0f}" if row["recorder"] and row["shape"] == "mission-like" else ""
        table.add_row(f"{row['shape']} tree, {row['nodes']} nodes, recorder {'on' if row['recorder'] else 'off'}",
                      f"{row['ticks_per_s']:,.0f} ticks/s", target)
    run = report["run"]
    table.add_row(f"{run['sim_seconds']:.0f} s UAV + UGV run, no log", f"{run['wall_without_log_s']:.3f} s wall", "")
    table.add_row(f"{run['sim_seconds']:.0f} s UAV + UGV run, with log", f"{run['wall_with_log_s']:.3f} s wall "
                  f"(RTF {run['real_time_factor_with_log']:.0f}x, {run['log_bytes'] / 1e3:.0f} kB)", "")
    table.add_row("recorder share of the run's wall time (time inside the recorder)",
                  f"{run['recorder_share']:.1%}", f"<= {TARGET_RECORDER_SHARE:.0%}")
    table.add_row("  same, from the two best wall times (noisy)", f"{run['recorder_share_from_wall_times']:.1%}", "")
    table.add_row("recorder share with the log and the live Foxglove server (--live, no client)",
                  f"{run['recorder_share_with_live']:.1%}", f"<= {TARGET_RECORDER_SHARE:.0%}")
    default = report.get("default_mission")
    if default is not None:
        table.add_row(f"default mission {default['mission']}: RTF without / with its log (now the default)",
                      f"{default['real_time_factor_without_log']:.2f}x / {default['real_time_factor_with_log']:.2f}x "
                      f"(recorder share {default['recorder_share']:.1%})", "")
    Console().print(table)
    print_tables(breakdown_sections(report["profile"]), {})
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2))
    print(f"written {args.out}")
    return report


def _version(name: str) -> str:
    from importlib.metadata import version

    return version(name)


if __name__ == "__main__":
    main()
