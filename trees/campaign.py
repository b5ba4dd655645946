"""Campaigns: many independent seeded trials of a mission, in parallel, with a statistical summary.

Trial ``i`` of every parameter combination runs with seed ``base_seed + i``
(so combinations are compared on the same seeds). ``--vary k=v1,v2`` adds
one dimension of combinations per key (their cartesian product); ``--set``
values apply to every trial. Trials run in local processes (spawned, one
world each) or on Ray (``marsupial[ray]``); both call :func:`run_trial`, so
the same seeds give the same per-trial outcomes on either backend.

Output folder: ``trials.json`` (one record per trial: seed, parameters,
outcome, metrics …), ``trials.csv`` (the same, flat), ``summary.json``
(success rate with a Wilson 95 % interval and medians, overall and per
combination) and ``logs/`` (the MCAP log of every failing trial, or of all
with ``keep_logs="all"``). Failing trials are kept as they are, never retried.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import multiprocessing
import os
import statistics
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from .errors import MissionError, check_seed
from .mission import load_mission

BACKENDS = ("local", "ray")
KEEP_LOGS = ("failed", "all", "none")
WILSON_Z = 1.959963984540054  # two-sided 95 % normal quantile
MAX_SOCKET_PATH = 107 - 66  # AF_UNIX path limit minus what Ray appends (/session_<date>_<pid>/sockets/plasma_store)


@dataclass(frozen=True)
class Trial:
    """One trial to run: index, seed, mission (name or path), ``--set`` overrides, varied values, limits."""

    index: int
    seed: int
    mission: str
    overrides: dict[str, str] = field(default_factory=dict)
    varied: dict[str, str] = field(default_factory=dict)
    until: float | None = None
    log_dir: str | None = None
    keep_logs: str = "failed"


def run_trial(trial: Trial) -> dict[str, Any]:
    """Run one trial in this process and return its JSON-ready record (the same on every backend).

    ``cpu_time`` is this process's CPU seconds for the trial (a measurement of cost, never fed to the run).
    """
    from .runner import run_mission  # imported in the worker: the parent needs no pybullet

    cpu_started = time.process_time()
    log = None
    if trial.log_dir is not None and trial.keep_logs != "none":
        log = Path(trial.log_dir) / f"trial_{trial.index:04d}_seed_{trial.seed}.mcap"
    try:
        result = run_mission(
            trial.mission,
            seed=trial.seed,
            log_path=log,
            until=trial.until,
            progress=False,
            overrides={**trial.overrides, **trial.varied},
        )
    except MissionError as err:  # e.g. a world value only checked when the world is built
        return {**_record(trial, "error", 0.0, 0, 0.0, {}, str(err)), "cpu_time": time.process_time() - cpu_started,
                "log": None}
    if log is not None and result.outcome == "success" and trial.keep_logs == "failed":
        log.unlink(missing_ok=True)
        log = None
    message = result.message.strip().splitlines()[0] if result.message else ""
    record = _record(trial, result.outcome, result.sim_time, result.ticks, result.wall_time, result.metrics, message)
    return {**record, "cpu_time": time.process_time() - cpu_started, "log": str(log) if log is not None else None}


def _record(trial: Trial, outcome: str, sim_time: float, ticks: int, wall_time: float,
            metrics: dict[str, float], message: str) -> dict[str, Any]:
    return {
        "trial": trial.index,
        "seed": trial.seed,
        "params": dict(trial.varied),
        "outcome": outcome,
        "success": outcome == "success",
        "sim_time": sim_time,
        "ticks": ticks,
        "wall_time": wall_time,
        "metrics": metrics,
        "message": message,
    }


# ------------------------------------------------------------------ statistics
def wilson_interval(successes: int, n: int, z: float = WILSON_Z) -> tuple[float, float]:
    """Wilson score interval of a success proportion (95 % by default); ``(0, 1)`` when ``n`` is 0."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denominator = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    return max(0.0, centre - half), min(1.0, centre + half)


def summarize(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Success count and rate with its Wilson 95 % interval, outcome counts, medians of times and metrics."""
    n = len(records)
    successes = sum(1 for r in records if r["success"])
    low, high = wilson_interval(successes, n)
    outcomes: dict[str, int] = {}
    for r in records:
        outcomes[r["outcome"]] = outcomes.get(r["outcome"], 0) + 1
    names = sorted({name for r in records for name in r["metrics"]})
    return {
        "trials": n,
        "successes": successes,
        "success_rate": successes / n if n else None,
        "success_rate_ci95": [low, high],
        "outcomes": outcomes,
        "median_sim_time": statistics.median(r["sim_time"] for r in records) if n else None,
        "median_metrics": {
            name: statistics.median(r["metrics"][name] for r in records if name in r["metrics"]) for name in names
        },
    }


# ------------------------------------------------------------------ planning
def parse_assignments(items: Iterable[str], what: str) -> dict[str, str]:
    """``["k=v", ...]`` -> ``{k: v}``; a malformed item raises :class:`MissionError`."""
    parsed: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise MissionError(f"{what} '{item}' is not key=value", expected="key=value, e.g. world.seed=3")
        parsed[key.strip()] = value
    return parsed


def plan_trials(
    mission: str,
    trials: int,
    base_seed: int = 0,
    overrides: Mapping[str, str] | None = None,
    vary: Mapping[str, Sequence[str]] | None = None,
    until: float | None = None,
    log_dir: Path | None = None,
    keep_logs: str = "failed",
) -> list[Trial]:
    """The trials of a campaign: every combination of ``vary`` values × seeds ``base_seed + i``.

    Each combination is validated by loading and compiling the mission with
    its overrides (a :class:`MissionError` before anything runs).
    """
    from .compiler import compile_mission

    check_seed(base_seed, "--seed")
    if trials < 1:
        raise MissionError(f"--trials {trials}: a campaign needs at least one trial", expected="an integer >= 1")
    if keep_logs not in KEEP_LOGS:
        raise MissionError(f"unknown log policy '{keep_logs}'", expected=f"one of {', '.join(KEEP_LOGS)}")
    overrides = dict(overrides or {})
    keys = list(vary or {})
    grid = itertools.product(*(list((vary or {})[k]) for k in keys))
    combos = [dict(zip(keys, values, strict=True)) for values in grid]
    for combo in combos:
        compile_mission(load_mission(mission, {**overrides, **combo}))
    plan: list[Trial] = []
    for combo in combos:
        for i in range(trials):
            plan.append(
                Trial(len(plan), base_seed + i, mission, overrides, combo, until,
                      str(log_dir) if log_dir is not None else None, keep_logs)
            )
    return plan


# ------------------------------------------------------------------ backends
def _run_local(trials: Sequence[Trial], workers: int, done: Callable[[dict[str, Any]], None]) -> list[dict[str, Any]]:
    context = multiprocessing.get_context("spawn")
    records = []
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        futures = [pool.submit(run_trial, t) for t in trials]
        for future in as_completed(futures):
            records.append(future.result())
            done(records[-1])
    return records


def ray_temp_dir(out: Path) -> Path:
    """Ray's session folder inside the campaign folder; MissionError if the path is too long for Ray's sockets."""
    temp = (out / "ray").resolve()
    if len(str(temp)) > MAX_SOCKET_PATH:
        raise MissionError(
            f"--out {out}: Ray's socket paths under '{temp}' would exceed the operating system's limit",
            expected=f"an output folder whose absolute path is at most {MAX_SOCKET_PATH - 4} characters (or --address)",
        )
    return temp


def _run_ray(
    trials: Sequence[Trial], workers: int, address: str | None, out: Path, done: Callable[[dict[str, Any]], None]
) -> list[dict[str, Any]]:
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")  # no token written under ~/.ray
    try:
        import ray
    except ImportError:
        raise MissionError(
            "--backend ray needs Ray", expected="the extra installed: pip install 'marsupial[ray]'"
        ) from None
    if address:
        ray.init(address=address, log_to_driver=False)
    else:
        temp = ray_temp_dir(out)
        temp.mkdir(parents=True, exist_ok=True)
        ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False, _temp_dir=str(temp))
    try:
        remote = ray.remote(num_cpus=1)(run_trial)
        pending = [remote.remote(t) for t in trials]
        records = []
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            records.append(ray.get(ready[0]))
            done(records[-1])
    finally:
        ray.shutdown()
    return records


# ------------------------------------------------------------------ campaign
def run_campaign(
    mission: str,
    trials: int,
    out: str | Path,
    base_seed: int = 0,
    overrides: Mapping[str, str] | None = None,
    vary: Mapping[str, Sequence[str]] | None = None,
    workers: int | None = None,
    backend: str = "local",
    address: str | None = None,
    until: float | None = None,
    keep_logs: str = "failed",
    console: Console | None = None,
) -> dict[str, Any]:
    """Run a campaign and write ``trials.json``, ``trials.csv`` and ``summary.json`` in ``out``.

    Returns the summary. Bad input (mission, overrides, backend) raises
    :class:`MissionError` before any trial runs.
    """
    if backend not in BACKENDS:
        raise MissionError(f"unknown backend '{backend}'", expected=f"one of {', '.join(BACKENDS)}")
    out = Path(out)
    workers = max(1, workers or os.cpu_count() or 1)
    if backend == "ray" and not address:
        ray_temp_dir(out)
    plan = plan_trials(mission, trials, base_seed, overrides, vary, until, out / "logs", keep_logs)
    out.mkdir(parents=True, exist_ok=True)
    if keep_logs != "none":
        (out / "logs").mkdir(exist_ok=True)
    console = console or Console()
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=console, disable=not console.is_terminal) as bar:
        task = bar.add_task(f"{mission} ({backend})", total=len(plan))
        failures = 0

        def done(record: dict[str, Any]) -> None:
            nonlocal failures
            failures += 0 if record["success"] else 1
            bar.update(task, advance=1, description=f"{mission} ({backend}, {failures} failed)")

        records = _run_local(plan, workers, done) if backend == "local" else _run_ray(plan, workers, address, out, done)
    records.sort(key=lambda r: r["trial"])
    summary = {
        "mission": mission,
        "backend": backend,
        "workers": workers,
        "base_seed": base_seed,
        "set": dict(overrides or {}),
        "vary": {k: list(v) for k, v in (vary or {}).items()},
        "until": until,
        **summarize(records),
        "groups": [
            {"params": combo, **summarize([r for r in records if r["params"] == combo])}
            for combo in _unique(r["params"] for r in records)
        ] if vary else [],
    }
    (out / "trials.json").write_text(json.dumps(records, indent=2))
    _write_csv(out / "trials.csv", records)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary


def _unique(items: Iterable[dict[str, str]]) -> list[dict[str, str]]:
    seen: list[dict[str, str]] = []
    for item in items:
        if item not in seen:
            seen.append(item)
    return seen


def _write_csv(path: Path, records: Sequence[Mapping[str, Any]]) -> None:
    params = sorted({k for r in records for k in r["params"]})
    metrics = sorted({k for r in records for k in r["metrics"]})
    base = ["trial", "seed", "outcome", "success", "sim_time", "ticks", "wall_time", "message", "log"]
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(base[:2] + [f"param:{p}" for p in params] + base[2:] + [f"metric:{m}" for m in metrics])
        for r in records:
            writer.writerow(
                [r["trial"], r["seed"]]
                + [r["params"].get(p, "") for p in params]
                + [r[k] if r[k] is not None else "" for k in base[2:]]
                + [r["metrics"].get(m, "") for m in metrics]
            )

