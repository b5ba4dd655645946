"""Campaigns: many independent seeded trials of missions, in parallel, with a statistical summary.

Trial ``i`` of every parameter combination runs with seed ``base_seed + i``
(so combinations are compared on the same seeds). ``--vary k=v1,v2`` adds
one dimension of combinations per key (their cartesian product); ``--set``
values apply to every trial. Trials are numbered seed by seed (every
combination of the first seed, then of the next …), so a campaign re-run
with more trials keeps the numbers of those it had.

One runner, :func:`run_trials`, runs the trials of every campaign and of
every benchmark: one after another in this process (``workers=1``), in
local processes (spawned, one world each; all cores by default) or on Ray
(``marsupial[ray]``), with a progress bar and its ETA. Each trial is a
pure function of its mission, seed and overrides (:func:`run_trial`), and
the records are put in trial order whatever order they finish in, so every
backend and worker count gives the same per-trial results.
:func:`run_campaigns` runs several campaigns' trials in one pool.

Output folder: ``trials.json`` (one record per trial: seed, parameters,
outcome, metrics …), ``trials.csv`` (the same, flat), ``summary.json``
(success rate with a Wilson 95 % interval and medians, overall and per
combination), ``finished.jsonl`` (each trial's plan and record as it
finishes: what ``resume`` reads back) and ``logs/`` (the MCAP log of every
failing trial, or of all with ``keep_logs="all"``). Failing trials are kept
as they are, never retried.
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
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from .errors import MissionError, check_seed
from .mission import load_mission

BACKENDS = ("local", "ray")
KEEP_LOGS = ("failed", "all", "none")
JOURNAL = "finished.jsonl"  # a campaign folder's finished trials, one JSON line each: {"plan": …, "record": …}
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

    def plan(self) -> dict[str, Any]:
        """What decides this trial's run (JSON-ready): its number, mission, seed, overrides, varied values, limit."""
        return {"trial": self.index, "mission": self.mission, "seed": self.seed, "set": dict(self.overrides),
                "params": dict(self.varied), "until": self.until}


@dataclass(frozen=True)
class CampaignSpec:
    """One campaign of :func:`run_campaigns`: mission (name or path), trials per combination, output folder,
    seed of trial 0, ``--set`` overrides, ``--vary`` values, time limit (simulated s) and which logs to keep."""

    mission: str
    trials: int
    out: Path
    base_seed: int = 0
    overrides: dict[str, str] = field(default_factory=dict)
    vary: dict[str, list[str]] = field(default_factory=dict)
    until: float | None = None
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
    """The trials of a campaign: seeds ``base_seed + i`` × every combination of ``vary`` values, seed by seed.

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
    for i in range(trials):
        for combo in combos:
            plan.append(
                Trial(len(plan), base_seed + i, mission, overrides, combo, until,
                      str(log_dir) if log_dir is not None else None, keep_logs)
            )
    return plan


# ------------------------------------------------------------------ runner
#: called with each trial's position in the list that :func:`run_trials` runs, and its record, as it finishes
OnRecord = Callable[[int, dict[str, Any]], None]


def worker_count(workers: int | None) -> int:
    """``workers``, or every core of this machine when ``None``."""
    return max(1, workers or os.cpu_count() or 1)


def _run_serial(trials: Sequence[Trial], done: OnRecord) -> None:
    for position, trial in enumerate(trials):
        done(position, run_trial(trial))


def _run_local(trials: Sequence[Trial], workers: int, done: OnRecord) -> None:
    pool = ProcessPoolExecutor(max_workers=min(workers, len(trials)), mp_context=multiprocessing.get_context("spawn"))
    try:
        futures = {pool.submit(run_trial, trial): position for position, trial in enumerate(trials)}
        for future in as_completed(futures):
            done(futures[future], future.result())
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)  # an interrupted campaign starts no further trial
        raise
    pool.shutdown()


def ray_temp_dir(out: Path) -> Path:
    """Ray's session folder inside the campaign folder; MissionError if the path is too long for Ray's sockets."""
    temp = (out / "ray").resolve()
    if len(str(temp)) > MAX_SOCKET_PATH:
        raise MissionError(
            f"--out {out}: Ray's socket paths under '{temp}' would exceed the operating system's limit",
            expected=f"an output folder whose absolute path is at most {MAX_SOCKET_PATH - 4} characters (or --address)",
        )
    return temp


def _run_ray(trials: Sequence[Trial], workers: int, address: str | None, temp: Path, done: OnRecord) -> None:
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
        temp.mkdir(parents=True, exist_ok=True)
        ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False, _temp_dir=str(temp))
    try:
        remote = ray.remote(num_cpus=1)(run_trial)
        positions = {remote.remote(trial): position for position, trial in enumerate(trials)}
        pending = list(positions)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            done(positions[ready[0]], ray.get(ready[0]))
    finally:
        ray.shutdown()


def run_trials(
    trials: Sequence[Trial],
    workers: int | None = None,
    backend: str = "local",
    address: str | None = None,
    ray_dir: Path | None = None,
    console: Console | None = None,
    label: str = "trials",
    on_record: OnRecord | None = None,
) -> list[dict[str, Any]]:
    """Run ``trials``, ``workers`` at a time (every core by default); their records in the order of ``trials``.

    ``workers=1`` (or a single trial) runs them one after another in this
    process, more in spawned local processes; ``backend="ray"`` runs them on the Ray cluster at
    ``address``, or on a local Ray whose session files go to ``ray_dir``. A
    progress bar with the trials done, the failures and the ETA shows when
    ``console`` is a terminal. ``on_record(position, record)`` is called as
    each trial finishes (in completion order); the list returned does not
    depend on that order.
    """
    if backend not in BACKENDS:
        raise MissionError(f"unknown backend '{backend}'", expected=f"one of {', '.join(BACKENDS)}")
    workers = worker_count(workers)
    records: list[dict[str, Any] | None] = [None] * len(trials)
    console = console or Console()
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
               TextColumn("ETA"), TimeRemainingColumn())
    with Progress(*columns, console=console, disable=not console.is_terminal) as bar:
        task = bar.add_task(f"{label} ({backend})", total=len(trials))
        failures = 0

        def done(position: int, record: dict[str, Any]) -> None:
            nonlocal failures
            records[position] = record
            failures += 0 if record["success"] else 1
            if on_record is not None:
                on_record(position, record)
            bar.update(task, advance=1, description=f"{label} ({backend}, {failures} failed)")

        if backend == "ray" and trials:
            _run_ray(trials, workers, address, ray_dir or Path("ray").resolve(), done)
        elif workers == 1 or len(trials) < 2:
            _run_serial(trials, done)
        else:
            _run_local(trials, workers, done)
    return [record for record in records if record is not None]


# ------------------------------------------------------------------ resuming
def _finished(journal: Path) -> dict[int, dict[str, Any]]:
    """The ``finished.jsonl`` entries of a campaign folder by trial number (the last one of each; a line cut off
    by an interruption is skipped)."""
    entries: dict[int, dict[str, Any]] = {}
    if not journal.is_file():
        return entries
    for line in journal.read_text().splitlines():
        try:
            entry = json.loads(line)
            entries[int(entry["plan"]["trial"])] = entry
        except (ValueError, KeyError, TypeError):
            continue
    return entries


def _reusable(trial: Trial, entry: Mapping[str, Any] | None) -> bool:
    """Whether a finished trial's ``entry`` is the run ``trial`` would give, with the log ``trial`` keeps.

    The same number, mission, seed, overrides and varied values; the same
    time limit, or a run that ended on its own before the new limit (runs
    are deterministic, so it is the run that limit gives).
    """
    if entry is None:
        return False
    old, new, record = entry["plan"], trial.plan(), entry["record"]
    if any(old.get(key) != new[key] for key in ("trial", "mission", "seed", "set", "params")):
        return False
    ended = record["outcome"] != "time_limit" and (trial.until is None or record["sim_time"] < trial.until)
    if old.get("until") != trial.until and not ended:
        return False
    needs_log = trial.keep_logs == "all" or (trial.keep_logs == "failed" and not record["success"])
    return not needs_log or (record.get("log") is not None and Path(record["log"]).is_file())


# ------------------------------------------------------------------ campaigns
def run_campaigns(
    specs: Sequence[CampaignSpec],
    workers: int | None = None,
    backend: str = "local",
    address: str | None = None,
    resume: bool = False,
    console: Console | None = None,
) -> list[dict[str, Any]]:
    """Run the trials of several campaigns in one pool; write each one's files in its ``out``; their summaries.

    With ``resume``, a trial already finished in its folder (``finished.jsonl``)
    with the same plan (:func:`_reusable`) is read back instead of run: an
    interrupted campaign continues, and one re-run with more trials runs only
    the new ones. Bad input (mission, overrides, backend, two campaigns in one
    folder) raises :class:`MissionError` before any trial runs.
    """
    if backend not in BACKENDS:
        raise MissionError(f"unknown backend '{backend}'", expected=f"one of {', '.join(BACKENDS)}")
    if not specs:
        return []
    folders = [Path(spec.out).resolve() for spec in specs]
    if len(set(folders)) != len(folders):
        raise MissionError("two campaigns of one run write to the same folder", expected="a folder per campaign")
    ray_dir = ray_temp_dir(Path(specs[0].out)) if backend == "ray" and not address else None
    plans = [plan_trials(s.mission, s.trials, s.base_seed, s.overrides, s.vary, s.until, Path(s.out) / "logs",
                         s.keep_logs) for s in specs]
    console = console or Console()
    records: list[list[dict[str, Any] | None]] = []
    for spec, plan in zip(specs, plans, strict=True):
        out = Path(spec.out)
        out.mkdir(parents=True, exist_ok=True)
        if spec.keep_logs != "none":
            (out / "logs").mkdir(exist_ok=True)
        finished = _finished(out / JOURNAL) if resume else {}
        kept = {t.index: finished[t.index] for t in plan if _reusable(t, finished.get(t.index))}
        (out / JOURNAL).write_text("".join(json.dumps(entry) + "\n" for entry in kept.values()))
        records.append([kept[t.index]["record"] if t.index in kept else None for t in plan])
        if kept:
            console.print(f"{out}: {len(kept)} of {len(plan)} trials read back (finished before, same plan)")
    resumed = [sum(record is not None for record in of_one) for of_one in records]
    todo = [(c, t) for c, plan in enumerate(plans) for t in plan if records[c][t.index] is None]

    def finished_one(position: int, record: dict[str, Any]) -> None:
        c, trial = todo[position]
        records[c][trial.index] = record
        with open(Path(specs[c].out) / JOURNAL, "a") as journal:
            journal.write(json.dumps({"plan": trial.plan(), "record": record}) + "\n")

    label = specs[0].mission if len(specs) == 1 else f"{len(specs)} campaigns"
    run_trials([t for _, t in todo], workers, backend, address, ray_dir, console, label, finished_one)
    return [_write_campaign(spec, [r for r in rs if r is not None], backend, worker_count(workers), n)
            for spec, rs, n in zip(specs, records, resumed, strict=True)]


def _write_campaign(spec: CampaignSpec, records: list[dict[str, Any]], backend: str, workers: int,
                    resumed: int) -> dict[str, Any]:
    """Write a finished campaign's ``trials.json``, ``trials.csv`` and ``summary.json``; returns the summary."""
    summary = {
        "mission": spec.mission,
        "backend": backend,
        "workers": workers,
        "base_seed": spec.base_seed,
        "set": dict(spec.overrides),
        "vary": {k: list(v) for k, v in spec.vary.items()},
        "until": spec.until,
        "resumed_trials": resumed,
        **summarize(records),
        "groups": [
            {"params": combo, **summarize([r for r in records if r["params"] == combo])}
            for combo in _unique(r["params"] for r in records)
        ] if spec.vary else [],
    }
    out = Path(spec.out)
    (out / "trials.json").write_text(json.dumps(records, indent=2))
    _write_csv(out / "trials.csv", records)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary


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
    resume: bool = False,
) -> dict[str, Any]:
    """Run one campaign (:func:`run_campaigns`) and write ``trials.json``, ``trials.csv`` and ``summary.json`` in
    ``out``; returns the summary."""
    spec = CampaignSpec(mission, trials, Path(out), base_seed, dict(overrides or {}),
                        {k: list(v) for k, v in (vary or {}).items()}, until, keep_logs)
    return run_campaigns([spec], workers, backend, address, resume, console)[0]


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

