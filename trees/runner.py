"""Run a mission: build its world and team, compile its tree, tick it in simulated time, record it.

:func:`run_mission` is what ``marsupial run`` calls. One tick of the loop, at
simulated time ``t`` (ticks every ``1 / run.tick_hz`` s):

1. robot poses are recorded every :data:`POSE_PERIOD` (battery levels once
   per simulated second);
2. the operator channel delivers the commands due by ``t``: ``abort`` ends
   the run (outcome ``aborted``), ``pause`` makes every robot safe and stops
   ticking the tree until ``resume``; other commands are latched for the
   ``operator`` conditions;
3. unless paused, the arbiter starts a new tick and the tree is ticked once;
   its status snapshot goes to the log;
4. the run ends when the root succeeds or fails, or at the time limit
   (``--until`` / ``run.until``: outcome ``time_limit``);
5. the world advances to the next tick.

Outcomes and exit codes: ``success`` 0; ``failure``, ``aborted``,
``time_limit``, ``error`` (an exception in a skill) 1; ``interrupted``
(SIGINT) 130; ``terminated`` (SIGTERM) 143. Bad input raises
:class:`~marsupial.trees.errors.MissionError` before any log is created.
The log is a valid MCAP however the run ends.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import math
import re
import signal
import sys
import threading
import time
import traceback
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any

import py_trees
from rich.console import Console

from marsupial.api.errors import UnknownNameError, WorldError
from marsupial.api.ticks import OperatorCommand
from marsupial.world import World
from marsupial.world.disturbances import apply_disturbances
from marsupial.world.kidnap import spread_pose
from marsupial.world.scoring import SCORES, Referee
from marsupial.world.team_link import TeamLinkConfig

from .bridge import WorldBridge
from .compiler import compile_mission
from .errors import MissionError, check_seed, one_of, suggest
from .isolation import TreeSide, open_tree_side
from .metrics import MetricSpec, declare
from .mission import Mission, load_mission
from .operator import CONTROL_COMMANDS, OperatorChannel
from .progress import ProgressLine, RobotStatus
from .recorder import Recorder, Terminated
from .sinks import Sink
from .summary import read_story, summary_table

#: outcome -> process exit code
EXIT_CODES = {"success": 0, "interrupted": 130, "terminated": 143}
METRIC_PERIOD = 1.0  # s of simulated time between battery samples
POSE_PERIOD = 0.2  # s of simulated time between recorded robot poses (5 Hz keeps the log's cost low)
RUNS_DIR = Path("runs")  # where runs log by default, relative to the current folder
#: the metrics recorded by the runner (batteries) and by the referee it attaches (marsupial.world.scoring)
declare(MetricSpec("battery_soc", "fraction", "battery state of charge"), owner=__name__)
declare(*(MetricSpec.of(score) for score in SCORES), owner="marsupial.world.scoring:Referee")


@dataclass
class RunResult:
    """How a run ended.

    Attributes:
        mission: mission name.
        outcome: success, failure, aborted, time_limit, error, interrupted or terminated.
        seed: the world seed used.
        sim_time: simulated time at the end (s).
        ticks: tree ticks done.
        wall_time: wall-clock duration of the loop (s; for speed reports only).
        metrics: last value of every metric (``name`` or ``name[labels]``).
        robots: final state of each robot (position m, battery state of charge).
        log_path: the MCAP file, if one was written.
        message: the error text for outcome ``error``.
    """

    mission: str
    outcome: str
    seed: int
    sim_time: float
    ticks: int
    wall_time: float
    metrics: dict[str, float] = field(default_factory=dict)
    robots: dict[str, dict[str, Any]] = field(default_factory=dict)
    log_path: Path | None = None
    message: str = ""

    @property
    def exit_code(self) -> int:
        """0 success, 130 SIGINT, 143 SIGTERM, else 1."""
        return EXIT_CODES.get(self.outcome, 1)

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.sim_time / self.wall_time if self.wall_time > 0 else float("inf")


# ------------------------------------------------------------------ world
def build_world(mission: Mission, seed: int, gui: bool = False) -> World:
    """The mission's world: scene, team robots (poses, sensors, options, storage), disturbances.

    Bad names or values raise :class:`MissionError` at the mission key that holds them.
    """
    spec = mission.spec
    try:
        sensing = spec.world.sensing
        link = TeamLinkConfig(**sensing.team_link.model_dump())
        world = World(scene=spec.world.scene, seed=seed, gui=gui, noise_scale=sensing.noise_scale, team_link=link)
    except WorldError as err:
        raise _located(mission, ("world", "scene"), err) from None
    try:
        _add_team(mission, world)
        _store_team(mission, world)
        if spec.world.disturbances.given():
            try:
                apply_disturbances(world, spec.world.disturbances)
            except WorldError as err:
                raise _located(mission, ("world", "disturbances", *err.at), err) from None
    except BaseException:
        world.close()
        raise
    return world


def _add_team(mission: Mission, world: World) -> None:
    """Add the mission's team robots to ``world`` at their poses, with their sensors and options."""
    for name, member in mission.spec.team.items():
        options = member.constructor_options()
        if member.pose_spread is not None:
            spread = member.pose_spread
            if member.pose is None or len(spread) != 3 or min(spread) < 0:
                raise mission.error_at(("team", name, "pose_spread"), f"cannot spread the start pose by {spread}",
                                       expected="[dx, dy, dyaw] >= 0 (m, m, rad) beside a pose")
            options["pose"] = list(spread_pose(member.pose, spread, world.rng_for(f"team/{name}/pose")))
        elif member.pose is not None:
            options["pose"] = member.pose
        try:
            world.add_robot(member.robot, name, **options)
        except (WorldError, TypeError, ValueError) as err:
            raise _located(mission, ("team", name), err) from None


def _store_team(mission: Mission, world: World) -> None:
    """Put the team robots that start ``stored_on`` a carrier into its storage."""
    for name, member in mission.spec.team.items():
        if member.stored_on is None:
            continue
        carrier = world.robot(member.stored_on)
        store = getattr(carrier, "store", None)
        if store is None:
            raise mission.error_at(
                ("team", name, "stored_on"),
                f"'{member.stored_on}' (a {carrier.kind}) cannot carry robots",
                expected="a carrier robot with a storage (e.g. mobile_manipulator)",
            )
        try:
            store(world.robot(name))
        except (WorldError, ValueError) as err:
            raise _located(mission, ("team", name, "stored_on"), err) from None


def _located(mission: Mission, key_path: tuple[Any, ...], err: Exception) -> MissionError:
    if isinstance(err, UnknownNameError):
        return mission.error_at(
            key_path, f"unknown {err.kind} '{err.name}'", one_of(err.known), suggest(err.name, err.known)
        )
    return mission.error_at(key_path, str(err))


# ------------------------------------------------------------------ signals
@contextlib.contextmanager
def _signals_end_the_run(recorder: Recorder | None) -> Iterator[None]:
    """SIGINT -> KeyboardInterrupt, SIGTERM -> Terminated, the log closed first (main thread only)."""
    if recorder is not None:
        recorder.install_signal_handlers()  # restored when the recorder closes
        yield
        return
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_signal(signum: int, frame: FrameType | None) -> None:
        raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()

    saved = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for signum, handler in saved.items():
            signal.signal(signum, handler)


# ------------------------------------------------------------------ progress
def battery_of(robot: Any) -> float | None:
    """State of charge (0..1) of a robot's battery, ``None`` if it has none."""
    battery = getattr(robot, "battery", None)
    return None if battery is None else float(battery.soc)


def robot_statuses(world: World, active: Mapping[str, Sequence[str]]) -> list[RobotStatus]:
    """Each robot's running skills (names, from the tree side) and battery, for the progress line."""
    return [RobotStatus(n, tuple(active.get(n, ())), battery_of(r)) for n, r in world.robots.items()]


# ------------------------------------------------------------------ running
def default_log_path(mission_name: str, folder: str | Path = RUNS_DIR) -> Path:
    """``<folder>/<mission>-<UTC time>.mcap`` (``-2``, ``-3`` … appended if that file exists).

    The wall clock names the file and nothing else: the run itself only ever
    sees simulated time.
    """
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    stem = f"{re.sub(r'[^A-Za-z0-9_.-]+', '_', mission_name).strip('.') or 'mission'}-{stamp}"
    path, n = Path(folder) / f"{stem}.mcap", 1
    while path.exists():
        n += 1
        path = Path(folder) / f"{stem}-{n}.mcap"
    return path


def _metadata(mission: Mission, seed: int, until: float | None) -> dict[str, Any]:
    return {
        "mission": mission.text,
        "mission_name": mission.name,
        "mission_path": str(mission.path) if mission.path is not None else "",
        "seed": seed,
        "overrides": json.dumps(mission.overrides),
        "until": json.dumps(until),
        "subtrees": json.dumps(mission.subtree_texts),  # with the mission text, enough to re-run from the log alone
    }


def run_mission(
    mission: Mission | str | Path,
    seed: int | None = None,
    log_path: str | Path | None = None,
    until: float | None = None,
    gui: bool = False,
    progress: bool = True,
    operator_stdin: bool = False,
    overrides: Mapping[str, str] | None = None,
    record_images: bool = False,
    operator: OperatorChannel | None = None,
    console: Console | None = None,
    pace: float | None = None,
    sinks: Sequence[Sink] = (),
    isolate: bool = False,
    record_inputs: bool = False,
) -> RunResult:
    """Run ``mission`` (a :class:`Mission`, or a name/path loaded with ``overrides``) to its end.

    Args:
        seed: world seed (default: the mission's ``world.seed``).
        log_path: MCAP file to write (none: no log).
        until: time limit in simulated seconds (default: the mission's ``run.until``).
        gui: open the pybullet GUI and pace the run to real time.
        progress: show the live progress line (TTY only) and print the summary table.
        operator_stdin: read operator commands from stdin (one per line: ``command [reason]``)
            and pace the run to real time so that they can be typed.
        record_images: record camera frames that skills log (``Recorder.log_image``).
        operator: the operator channel to use (default: one with the mission's timeline);
            its :meth:`~OperatorChannel.say` is the Python API for live commands.
        console: where progress and the summary go (default: stdout).
        pace: simulated seconds per wall-clock second to hold the run to (``1.0``: real time); default:
            as fast as possible, or real time with ``gui`` or ``operator_stdin``.
        sinks: more outputs for the recorder's messages besides ``log_path`` (e.g. a live
            :class:`~marsupial.trees.live.LiveSink`), closed at the end of the run.
        isolate: run the tree and its skills in a process of their own, exchanging the same messages with
            the world's process in lockstep (:mod:`marsupial.trees.isolation`).
        record_inputs: log every message the tree received and the commands it answered with (``/replay``),
            for ``marsupial replay LOG --against MISSION`` (:mod:`marsupial.trees.exchange_log`).

    Raises :class:`MissionError` for bad input, before the log file is created.
    """
    if not isinstance(mission, Mission):
        mission = load_mission(mission, overrides)
    spec = mission.spec
    seed = spec.world.seed if seed is None else check_seed(seed)
    _check_limits(until, pace)
    if pace is None and (gui or operator_stdin):
        pace = 1.0  # a person watches or types
    until = spec.run.until if until is None else float(until)
    channel = operator if operator is not None else OperatorChannel((e.at, e.say, e.why) for e in spec.operator)
    console = console or Console()

    py_trees.blackboard.Blackboard.clear()
    compile_mission(mission)  # bad input fails here, before world and log exist
    world = build_world(mission, seed, gui)
    if operator_stdin:
        channel.read_from(sys.stdin)

    log = Path(log_path) if log_path is not None else None
    recorder = _open_recorder(mission, seed, until, log, sinks, record_images, world)
    bridge = WorldBridge(world, recorder, record_inputs)
    world.add_actor(Referee(world, bridge.scores))  # truth-based scores, world side: no node can read them
    display = ProgressLine(console, progress)
    outcome, message, ticks = "failure", "", _TickCount()
    started = time.perf_counter()
    host: TreeSide | None = None
    try:
        with recorder if recorder is not None else contextlib.nullcontext(), _signals_end_the_run(recorder):
            host = open_tree_side(mission, bridge.setup(mission, seed), record_images, isolate)
            outcome = _loop(mission, host, bridge, channel, until, pace, display, started, ticks)
            bridge.apply(host.stop())  # skills still running leave their robots safe
            _event(recorder, world.now, "run_end", outcome=outcome, sim_time=world.now, ticks=ticks.n)
    except KeyboardInterrupt:
        outcome = "interrupted"
    except Terminated:
        outcome = "terminated"
    except Exception as err:  # a skill raised: the log records it (Recorder.__exit__) and the run fails
        outcome, message = "error", f"{type(err).__name__}: {err}\n{traceback.format_exc()}"
    finally:
        display.stop()
        if host is not None:
            host.close()
    result = RunResult(
        mission=mission.name,
        outcome=outcome,
        seed=seed,
        sim_time=world.now,
        ticks=ticks.n,
        wall_time=time.perf_counter() - started,
        metrics=dict(bridge.metrics),
        robots={n: {"position": r.pose()[0].tolist(), "battery": battery_of(r)} for n, r in world.robots.items()},
        log_path=log,
        message=message,
    )
    world.close()
    if progress:
        console.print(summary_table(result, until, read_story(log)))
    return result


def _event(recorder: Recorder | None, t: float, kind: str, **fields: Any) -> None:
    """Record a runner event at sim time ``t`` (s) when the run has a recorder."""
    if recorder is not None:
        recorder.log_event(t, kind, **fields)


def _positive_finite(value: object) -> bool:
    """Whether ``value`` is a real number (not a bool) in (0, inf)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and 0 < value < math.inf


def _check_limits(until: float | None, pace: float | None) -> None:
    """Raise :class:`MissionError` unless the time limit (sim s) and the pace (sim s per s) are ``None`` or > 0."""
    if until is not None and not _positive_finite(until):
        raise MissionError(f"until {until!r} is not a time limit", expected="a finite number of simulated seconds > 0")
    if pace is not None and not _positive_finite(pace):
        raise MissionError(
            f"speed {pace!r} is not a pace", expected="a finite number of simulated seconds per second > 0"
        )


def _open_recorder(
    mission: Mission,
    seed: int,
    until: float | None,
    log: Path | None,
    sinks: Sequence[Sink],
    record_images: bool,
    world: World,
) -> Recorder | None:
    """The run's recorder writing to ``log`` and ``sinks`` (its folder created), ``None`` with neither."""
    if log is not None:
        log.parent.mkdir(parents=True, exist_ok=True)
    if log is None and not sinks:
        return None
    recorder = Recorder(log, _metadata(mission, seed, until), record_images=record_images, sinks=sinks)
    recorder.time_source = lambda: world.now  # the log ends at the time the run reached, however it ends
    return recorder


@dataclass
class _TickCount:
    """Tree ticks done so far (kept outside the loop, so a run that ends by an exception reports them too)."""

    n: int = 0


def _estimated_pose(robot: Any) -> tuple[Any, Any]:
    """A robot's onboard estimate as ``(position, quaternion)`` for the log."""
    estimate = robot.estimator.estimate()
    return estimate.position, estimate.orientation


def _loop(
    mission: Mission,
    host: TreeSide,
    bridge: WorldBridge,
    channel: OperatorChannel,
    until: float | None,
    pace: float | None,
    display: ProgressLine,
    started: float,
    ticks: _TickCount,
) -> str:
    """Tick until the root finishes, the time limit or an abort; returns the outcome (``ticks`` counts the ticks).

    ``pace`` (sim s per wall s) holds the loop back to the wall clock (GUI,
    live operator or live view: a person watches or types); the simulation
    itself never reads the clock.
    """
    world, recorder = bridge.world, bridge.recorder
    period = 1.0 / mission.spec.run.tick_hz
    _event(recorder, world.now, "run_start", mission=mission.name, seed=world.seed,
           tick_hz=mission.spec.run.tick_hz, until=until)
    if recorder is not None:
        recorder.log_scene(world)
    next_metric = next_pose = 0.0
    paused = False
    while True:
        now = world.now
        next_pose = _log_poses(recorder, world, now, next_pose)
        next_metric = _log_batteries(bridge, world, now, next_metric)
        said = channel.poll(now)
        for command in said:
            _note_command(recorder, host, command, now)
        if any(c.say == "abort" for c in said):
            return "aborted"
        pausing = _paused(recorder, said, paused, now)
        if not pausing:
            output = host.tick(bridge.tick_input(said))
            bridge.apply(output)
            ticks.n += 1
            if output.status in ("SUCCESS", "FAILURE"):
                return "success" if output.status == "SUCCESS" else "failure"
        elif not paused:
            bridge.apply(host.pause(bridge.tick_input(said, "pause")))  # every robot left safe in a tick of its own
        paused = pausing
        if until is not None and now + 1e-9 >= until:
            return "time_limit"
        world.step(period)
        wall = _hold_pace(world, pace, started)
        if display.due():
            display.show(world.now, until, wall, paused, robot_statuses(world, host.active))


def _paused(recorder: Recorder | None, said: list[OperatorCommand], paused: bool, now: float) -> bool:
    """Whether the run is paused after the operator's commands ``said`` at ``now`` (s); state changes logged."""
    for command in said:
        if command.say == "pause" and not paused:
            paused = True
            _event(recorder, now, "state_change", state="paused")
        elif command.say == "resume" and paused:
            paused = False
            _event(recorder, now, "state_change", state="running")
    return paused


def _log_poses(recorder: Any, world: World, now: float, due: float) -> float:
    """Log every robot's true and estimated pose if the pose period is ``due`` at ``now`` (s); the next due time.

    ``recorder`` is the run's (a :class:`Recorder` or ``None``).
    """
    if recorder is None or now + 1e-9 < due:
        return due
    recorder.log_robot_poses(
        now,
        {n: r.pose() for n, r in world.robots.items()},
        {n: _estimated_pose(r) for n, r in world.robots.items()},
    )
    return due + POSE_PERIOD


def _log_batteries(bridge: WorldBridge, world: World, now: float, due: float) -> float:
    """Record each battery's state of charge if the metric period is ``due`` at ``now`` (s); the next due time."""
    if now + 1e-9 < due:
        return due
    for name, robot in world.robots.items():
        soc = battery_of(robot)
        if soc is not None:
            bridge.scores.metric("battery_soc", soc, robot=name)
    return due + METRIC_PERIOD


def _note_command(recorder: Recorder | None, host: TreeSide, command: OperatorCommand, now: float) -> None:
    """Record an operator command, with a log warning when neither the runner nor a node listens to it."""
    _event(recorder, now, "operator", command=command.say, source=command.source, why=command.why)
    if command.say not in CONTROL_COMMANDS and command.say not in host.listens and recorder is not None:
        recorder.log_text(now, "warning", f"no node listens to operator command '{command.say}'")


def _hold_pace(world: World, pace: float | None, started: float) -> float:
    """Sleep until the wall clock is at ``pace`` (sim s per s) behind the world; the wall time (s) before the sleep."""
    wall = time.perf_counter() - started
    if pace is not None and world.now > wall * pace:
        time.sleep(world.now / pace - wall)
    return wall
