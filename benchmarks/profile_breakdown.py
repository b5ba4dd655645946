"""Where a mission's wall time goes: the engine's share, and the Python time by module.

Two runs of the mission, each logged as ``marsupial run`` logs it:

1. *timed*: every call of pybullet's ``stepSimulation`` (physics),
   ``getCameraImage`` (rendering) and ``rayTestBatch`` (ray casts) timed
   around the call: the engine's share of the run's wall time as it runs;
2. *profiled* (cProfile): every function's own time, grouped by module —
   marsupial's modules one by one, other packages by their top-level name,
   a C built-in's time (numpy's, the interpreter's) with the module that
   called it, pybullet's engine calls and its other calls (state queries,
   forces) in rows of their own. The profiler slows the Python part down,
   so this run's engine share is below the timed run's.

``benchmarks/runtime_overhead.py`` and ``benchmarks/world_speed.py`` report
this for the default mission, so a regression shows where it came from.
"""

from __future__ import annotations

import contextlib
import cProfile
import os
import pstats
import re
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pybullet

from marsupial.trees.runner import run_mission

ENGINE_CALLS = ("stepSimulation", "getCameraImage", "rayTestBatch")  # physics, rendering, ray casts
_PYBULLET_CALL = re.compile(r"^<built-in method pybullet\.(\w+)>$")
TOP_MODULES = 20  # rows of the Python table; the rest is summed in one
QUICK_UNTIL_S = 60.0  # simulated seconds of the default mission profiled by the benchmarks' --quick


@contextlib.contextmanager
def engine_timers() -> Iterator[dict[str, list[float]]]:
    """Time every call of :data:`ENGINE_CALLS` while inside: name -> [wall seconds, calls]."""
    spent = {name: [0.0, 0] for name in ENGINE_CALLS}
    originals = {name: getattr(pybullet, name) for name in ENGINE_CALLS}

    def timed(name: str, call: Callable[..., Any]) -> Callable[..., Any]:
        def timed_call(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return call(*args, **kwargs)
            finally:
                spent[name][0] += time.perf_counter() - start
                spent[name][1] += 1
        return timed_call

    for name, call in originals.items():
        setattr(pybullet, name, timed(name, call))
    try:
        yield spent
    finally:
        for name, call in originals.items():
            setattr(pybullet, name, call)


def _run(mission: str, until: float | None) -> Any:
    with tempfile.TemporaryDirectory() as tmp:
        return run_mission(mission, log_path=Path(tmp) / "run.mcap", until=until, progress=False)


def timed_run(mission: str, until: float | None) -> dict[str, Any]:
    """Run ``mission`` (to ``until`` simulated s, ``None``: its end) with the engine calls timed: their wall seconds,
    calls and share of the run's wall time, and its real-time factor."""
    with engine_timers() as spent:
        result = _run(mission, until)
    engine_s = sum(seconds for seconds, _ in spent.values())
    return {"sim_s": result.sim_time, "wall_s": result.wall_time,
            "real_time_factor": result.sim_time / result.wall_time,
            "engine": {name: {"s": s, "calls": int(n)} for name, (s, n) in spent.items()},
            "engine_s": engine_s, "engine_share": engine_s / result.wall_time}


def _module_files() -> dict[str, str]:
    """Every loaded module's file (real path) -> its name."""
    found = {}
    for name, module in list(sys.modules.items()):
        path = getattr(module, "__file__", None)
        if path:
            found[os.path.realpath(path)] = name
    return found


def _group(filename: str, modules: dict[str, str]) -> str:
    """The row a Python function's time goes to: marsupial's module, or another package's top-level name."""
    name = modules.get(os.path.realpath(filename))
    if name is None:
        return "(frozen or generated code)"
    return name if name.startswith("marsupial.") else name.split(".")[0]


def profiled_run(mission: str, until: float | None) -> dict[str, Any]:
    """Run ``mission`` under cProfile: the profiled seconds, the engine calls' and pybullet's other calls' seconds,
    and the Python seconds by module (largest first, each with its share of the profiled time)."""
    profile = cProfile.Profile()
    profile.enable()
    try:
        result = _run(mission, until)
    finally:
        profile.disable()
    stats: dict[tuple[str, int, str], Any] = pstats.Stats(profile).stats  # function -> (calls, own s, callers …)
    modules = _module_files()
    engine = {name: {"s": 0.0, "calls": 0} for name in ENGINE_CALLS}
    pybullet_other, total = 0.0, 0.0
    by_module: dict[str, float] = {}
    for (filename, _, function), (_, calls, own, _, callers) in stats.items():
        total += own
        match = _PYBULLET_CALL.match(function) if filename == "~" else None
        if match and match[1] in engine:
            engine[match[1]]["s"] += own
            engine[match[1]]["calls"] += calls
        elif match:
            pybullet_other += own
        elif filename == "~":  # another built-in: its time goes to the modules that called it
            for (caller_file, _, _), (_, _, caller_own, _) in callers.items():
                key = _group(caller_file, modules) if caller_file != "~" else "(built-ins)"
                by_module[key] = by_module.get(key, 0.0) + caller_own
            if not callers:
                by_module["(built-ins)"] = by_module.get("(built-ins)", 0.0) + own
        else:
            key = _group(filename, modules)
            by_module[key] = by_module.get(key, 0.0) + own
    engine_s = sum(e["s"] for e in engine.values())
    ranked = sorted(by_module.items(), key=lambda item: -item[1])
    rows = [{"module": name, "s": s, "share": s / total} for name, s in ranked[:TOP_MODULES]]
    rest = sum(s for _, s in ranked[TOP_MODULES:])
    if rest:
        rows.append({"module": f"({len(ranked) - TOP_MODULES} other modules)", "s": rest, "share": rest / total})
    return {"sim_s": result.sim_time, "profiled_s": total, "engine": engine, "engine_s": engine_s,
            "engine_share": engine_s / total, "pybullet_other_s": pybullet_other,
            "python_s": sum(by_module.values()), "python_by_module": rows}


def breakdown(mission: str, until: float | None) -> dict[str, Any]:
    """The timed and the profiled run of ``mission`` (to ``until`` simulated s; ``None``: to its end)."""
    return {"mission": mission, "until": until, "timed": timed_run(mission, until),
            "profiled": profiled_run(mission, until)}


def breakdown_sections(report: dict[str, Any]) -> list[tuple[str, list[str], list[list[str]]]]:
    """The two tables of a :func:`breakdown`: the engine's calls (both runs), the Python time by module."""
    timed, profiled = report["timed"], report["profiled"]
    what = f"{report['mission']}, {timed['sim_s']:.0f} s simulated"
    rest = profiled["python_s"] + profiled["pybullet_other_s"]
    engine_rows = [
        [name, f"{timed['engine'][name]['calls']:,}", f"{timed['engine'][name]['s']:.2f}",
         f"{timed['engine'][name]['s'] / timed['wall_s']:.1%}", f"{profiled['engine'][name]['s']:.2f}",
         f"{profiled['engine'][name]['s'] / profiled['profiled_s']:.1%}"]
        for name in ENGINE_CALLS
    ]
    engine_rows += [
        ["engine (the three)", "", f"{timed['engine_s']:.2f}", f"{timed['engine_share']:.1%}",
         f"{profiled['engine_s']:.2f}", f"{profiled['engine_share']:.1%}"],
        ["the rest: Python, other pybullet calls", "", f"{timed['wall_s'] - timed['engine_s']:.2f}",
         f"{1 - timed['engine_share']:.1%}", f"{rest:.2f}", f"{rest / profiled['profiled_s']:.1%}"],
        ["  of which other pybullet calls", "", "", "", f"{profiled['pybullet_other_s']:.2f}",
         f"{profiled['pybullet_other_s'] / profiled['profiled_s']:.1%}"],
        ["the whole run", "", f"{timed['wall_s']:.2f}", f"RTF {timed['real_time_factor']:.2f}×",
         f"{profiled['profiled_s']:.2f}", "100 %"],
    ]
    python_rows = [[row["module"], f"{row['s']:.2f}", f"{row['share']:.1%}"] for row in profiled["python_by_module"]]
    return [
        (f"Where the time goes: {what} (wall s; profiled: under cProfile)",
         ["part", "calls", "timed s", "share", "profiled s", "share"], engine_rows),
        (f"Python time by module, {what} (own time with the built-ins it calls, under cProfile)",
         ["module", "s", "share of the profiled run"], python_rows),
    ]
