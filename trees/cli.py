"""The ``marsupial`` command: run, draw, export, list, validate, replay, report, verify and campaign missions.

Exit codes: 0 success; 1 mission failure (or a verification mismatch);
2 bad input (mission errors, unknown names, missing files — printed as one
``file:line:column: ...`` message, no traceback); 130 after SIGINT and 143
after SIGTERM (the log is closed cleanly first).
"""

from __future__ import annotations

import contextlib
import json
import shlex
import shutil
import sys
import tempfile
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import click
from rich.console import Console
from rich.table import Table
from rich.text import Text

import marsupial

from .errors import MissionError

#: mission run by ``marsupial run`` without a MISSION argument
DEFAULT_MISSION = "usar_docking"

_err = Console(stderr=True)


@contextlib.contextmanager
def bad_input() -> Iterator[None]:
    """Print mission/world/log errors as one message on stderr and exit with code 2."""
    from marsupial.api.errors import WorldError

    from .replay import LogError

    try:
        yield
    except (MissionError, WorldError, LogError) as err:
        # literal text
        _err.print(Text.assemble(("error:", "bold red"), " ", str(err)), highlight=False, soft_wrap=True)
        raise SystemExit(2) from None


def marsupial_metadata(run_log: Any, log: str) -> dict[str, str]:
    """The marsupial metadata of a read log; a :class:`LogError` (exit 2) for an MCAP file marsupial did not write."""
    from .replay import LogError

    if "mission" not in run_log.metadata:
        raise LogError(f"{log}: no marsupial metadata (mission, seed): not a marsupial run log")
    return dict(run_log.metadata)


def _assignments(items: tuple[str, ...], what: str) -> dict[str, str]:
    from .campaign import parse_assignments

    return parse_assignments(items, what)


def _write_text(text: str, output: str | None) -> None:
    if output is None:
        click.echo(text, nl=not text.endswith("\n"))
    else:
        Path(output).write_text(text)


def _compiled(mission_ref: str, sets: tuple[str, ...]) -> Any:
    from .compiler import compile_mission
    from .mission import load_mission

    return compile_mission(load_mission(mission_ref, _assignments(sets, "--set")))


def _seed(ctx: click.Context, param: click.Parameter, value: str | int | None) -> int | None:
    """Check a seed option: an integer ≥ 0 (numpy's seed sequences take no negative numbers); exit 2 otherwise."""
    if value is None or (isinstance(value, int) and not isinstance(value, bool) and value >= 0):
        return value
    try:
        number = int(str(value).strip(), 10)
    except ValueError:
        raise click.BadParameter(f"{value!r} is not a seed; expected an integer ≥ 0") from None
    if number < 0:
        raise click.BadParameter(f"{number} is not a seed; expected an integer ≥ 0")
    return number


def _positive_time(ctx: click.Context, param: click.Parameter, value: float | None) -> float | None:
    """Check a time limit option: a finite number of simulated seconds > 0."""
    if value is not None and not (value > 0 and value < float("inf")):
        raise click.BadParameter(f"{value} is not a time limit; expected a finite number of simulated seconds > 0")
    return value


def _positive_speed(ctx: click.Context, param: click.Parameter, value: float | None) -> float | None:
    """Check --speed: a finite factor > 0 of real time."""
    if value is not None and not (value > 0 and value < float("inf")):
        raise click.BadParameter(f"{value} is not a speed; expected a finite factor of real time > 0 (e.g. 1, 4)")
    return value


_set_option = click.option(
    "--set",
    "sets",
    multiple=True,
    metavar="KEY=VALUE",
    help="Override a mission value (params.X, world.seed, run.until …).",
)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(marsupial.__version__, prog_name="marsupial")
def cli() -> None:
    """Behaviour-tree missions for marsupial robot teams."""
    warnings.showwarning = _show_warning


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    """Print a Python warning (e.g. a plug-in's name collision) as one ``warning: …`` line on stderr."""
    _err.print(Text.assemble(("warning:", "bold yellow"), " ", str(message)), highlight=False, soft_wrap=True)


@cli.command()
@click.argument("mission", required=False, default=DEFAULT_MISSION)
@click.option(
    "--seed", callback=_seed, metavar="SEED", help="World seed, an integer ≥ 0 (default: the mission's world.seed)."
)
@click.option(
    "--log",
    "log_path",
    type=click.Path(dir_okay=False),
    help="Write the run to this MCAP file (default: runs/<mission>-<UTC time>.mcap).",
)
@click.option("--no-log", is_flag=True, help="Write no log file.")
@click.option("--until", type=float, callback=_positive_time, help="Time limit in simulated seconds (> 0).")
@click.option("--gui", is_flag=True, help="Open the pybullet GUI (paced to real time).")
@_set_option
@click.option(
    "--operator", is_flag=True, help="Read operator commands from stdin ('command [reason]' per line); real-time pace."
)
@click.option("--record-images", is_flag=True, help="Record camera frames that skills log.")
@click.option(
    "--record-inputs", is_flag=True,
    help="Log every message the skills receive (images compressed) for 'marsupial replay LOG --against MISSION'.",
)
@click.option(
    "--isolate", is_flag=True,
    help="Run the tree and its skills in a process of their own, exchanging messages with the world in lockstep.",
)
@click.option("--quiet", "-q", is_flag=True, help="No progress line and no summary table.")
@click.option("--live", is_flag=True, help="Serve the run to Foxglove over WebSocket while it runs (real-time pace).")
@click.option("--host", help="Address the live server binds to (default: 127.0.0.1, this machine only).")
@click.option(
    "--port", type=click.IntRange(0, 65535), help="Port of the live server (default: 8765; 0: any free port)."
)
@click.option(
    "--speed",
    type=float,
    callback=_positive_speed,
    help="Pace the run to X times real time (default: 1 with --live/--gui/--operator, else at full speed).",
)
def run(
    mission: str,
    seed: int | None,
    log_path: str | None,
    no_log: bool,
    until: float | None,
    gui: bool,
    sets: tuple[str, ...],
    operator: bool,
    record_images: bool,
    record_inputs: bool,
    isolate: bool,
    quiet: bool,
    live: bool,
    host: str | None,
    port: int | None,
    speed: float | None,
) -> None:
    """Run MISSION (a name or a .yaml path; default: usar_docking, the USAR docking mission).

    The run is logged to runs/<mission>-<UTC time>.mcap unless --log FILE or
    --no-log; the path and the `marsupial report` command for it are printed
    at the end.
    """
    from .live import DEFAULT_HOST, DEFAULT_PORT
    from .mission import load_mission
    from .runner import default_log_path, run_mission

    if no_log and log_path is not None:
        raise click.UsageError("--log and --no-log exclude each other")
    if not live and (host is not None or port is not None):
        raise click.UsageError("--host and --port set up the live server: add --live")
    sinks = []
    try:
        with bad_input():
            loaded = load_mission(mission, _assignments(sets, "--set"))
            log = None if no_log else Path(log_path) if log_path is not None else default_log_path(loaded.name)
            if live:
                sinks.append(_live_sink(host or DEFAULT_HOST, DEFAULT_PORT if port is None else port))
            result = run_mission(
                loaded,
                seed=seed,
                log_path=log,
                until=until,
                gui=gui,
                progress=not quiet,
                operator_stdin=operator,
                record_images=record_images,
                pace=speed if speed is not None else 1.0 if live else None,
                sinks=sinks,
                isolate=isolate,
                record_inputs=record_inputs,
            )
    except KeyboardInterrupt:  # before the run loop took over the signal
        sys.exit(130)
    finally:
        for sink in sinks:
            sink.close()
    if result.outcome == "error":
        _err.print(result.message, highlight=False, markup=False)
    if result.log_path is not None:
        click.echo(f"log: {result.log_path}\nreport: marsupial report {shlex.quote(str(result.log_path))}")
    sys.exit(result.exit_code)


def _live_sink(host: str, port: int) -> Any:
    """Start the live Foxglove server and say where it listens (and that it is open to the network if so)."""
    from .live import DEFAULT_HOST, LiveSink

    try:
        sink = LiveSink(host, port)
    except RuntimeError as err:  # the SDK raises it for a port in use or an address it cannot bind
        raise MissionError(
            f"--live: cannot serve on {host}:{port} ({err})",
            expected="a free port (--port) on an address of this machine (--host)",
        ) from None
    where = "this machine only" if host in (DEFAULT_HOST, "localhost", "::1") else f"open to the network on {host}"
    click.echo(f"live: Foxglove WebSocket on {sink.url} ({where}); in Foxglove: Open connection > Foxglove WebSocket")
    sys.stdout.flush()
    return sink


@cli.command()
@click.argument("mission")
@click.option("--format", "fmt", type=click.Choice(["ascii", "dot", "svg"]), default="ascii", show_default=True)
@click.option("--output", "-o", type=click.Path(dir_okay=False), help="Write to a file instead of stdout.")
@_set_option
def tree(mission: str, fmt: str, output: str | None, sets: tuple[str, ...]) -> None:
    """Draw the compiled tree of MISSION (svg needs Graphviz's dot)."""
    import py_trees

    with bad_input():
        if fmt == "svg" and shutil.which("dot") is None:
            raise MissionError(
                "cannot draw SVG: Graphviz's 'dot' program is not installed",
                expected="graphviz installed (e.g. apt install graphviz), or --format dot / ascii",
            )
        root = _compiled(mission, sets).root
        if fmt == "ascii":
            text = py_trees.display.ascii_tree(root)
        else:
            graph = py_trees.display.dot_tree(root)
            # pydot adds its create_<format> methods at run time
            text = graph.to_string() if fmt == "dot" else graph.create_svg().decode()  # type: ignore[attr-defined]
    _write_text(text, output)


@cli.command()
@click.argument("mission")
@click.option("--format", "fmt", type=click.Choice(["btcpp-xml"]), default="btcpp-xml", show_default=True)
@click.option("--output", "-o", type=click.Path(dir_okay=False), help="Write to a file instead of stdout.")
@_set_option
def export(mission: str, fmt: str, output: str | None, sets: tuple[str, ...]) -> None:
    """Export the compiled tree of MISSION (BehaviorTree.CPP v4 XML, for Groot2)."""
    from .btxml import to_btcpp_xml

    with bad_input():
        text = to_btcpp_xml(_compiled(mission, sets).root)
    _write_text(text, output)


@cli.command()
@click.argument("names", nargs=-1)
def skills(names: tuple[str, ...]) -> None:
    """List the installed skills and conditions, one line each; with NAMES, each of those in detail.

    The detail of a node: its documentation, the robots it acts on, its
    parameters (types, defaults), blackboard keys, resources and metrics.
    Exits 1 when a node it lists cannot be loaded (a broken plug-in), 2 for an unknown name.
    """
    from .errors import one_of, suggest
    from .listing import index_table, node_detail
    from .registry import BUILTIN, GROUPS, installed

    console = Console()
    available = {name: (kind, providers) for kind in GROUPS for name, providers in installed(kind).items()}
    with bad_input():
        for wanted in names:
            if wanted not in available:
                raise MissionError(
                    f"unknown skill or condition '{wanted}'",
                    expected=one_of(available),
                    suggestion=suggest(wanted, available),
                )
    listed = [(kind, name, provider, _load_node(kind, provider.target))
              for name, (kind, providers) in available.items() if not names or name in names for provider in providers]
    if names:
        for kind, name, provider, loaded in listed:
            if not isinstance(loaded, str):
                console.print(node_detail(kind, name, str(provider), loaded))
    else:
        console.print(index_table(
            (kind, name, loaded, "" if provider.distribution == BUILTIN else str(provider))
            for kind, name, provider, loaded in listed
        ))
    failed = [(kind, name, provider, loaded) for kind, name, provider, loaded in listed if isinstance(loaded, str)]
    for kind, name, provider, loaded in failed:
        _err.print(Text.assemble(("error:", "bold red"), f" {kind} '{name}' of {provider} cannot be loaded: {loaded}"),
                   highlight=False, soft_wrap=True)
    if failed:
        sys.exit(1)


def _load_node(kind: str, target: str) -> Any:
    """The node class an entry point names, or the text of why it cannot be loaded."""
    from .registry import GROUPS, import_target

    base = GROUPS[kind][1]
    try:
        cls = import_target(target)
    except MissionError as err:
        return str(err)
    except Exception as err:  # a plug-in module that raises on import
        return f"importing '{target}' raised {type(err).__name__}: {err}"
    if not (isinstance(cls, type) and issubclass(cls, base)):
        return f"'{target}' is not a {base.__name__}"
    return cls


@cli.command()
def missions() -> None:
    """List the missions shipped with the package: team and the first sentence of each description."""
    from .listing import missions_table
    from .mission import known_missions, load_mission

    rows = []
    for name in known_missions():
        spec = load_mission(name).spec
        robots = ", ".join(f"{member}: {m.robot}" for member, m in spec.team.items())
        rows.append((name, robots, spec.description))
    Console().print(missions_table(rows))


@cli.command()
def schema() -> None:
    """Print the JSON Schema of mission files (for editors)."""
    from .mission import mission_schema

    click.echo(json.dumps(mission_schema(), indent=2))


@cli.command()
@click.argument("log", type=click.Path(dir_okay=False))
@click.option(
    "--against", metavar="MISSION_OR_YAML",
    help="Feed the log's recorded inputs (run --record-inputs) to this mission's skills and compare their commands.",
)
@_set_option
def replay(log: str, against: str | None, sets: tuple[str, ...]) -> None:
    """Print the timeline of a run log, or replay its recorded inputs into a mission's skills (--against).

    With --against: exit 0 when every command matches the logged one, exit 1
    at the first that differs (its tick, node and both commands are printed).
    """
    from .replay import format_timeline, read_log

    if against is not None:
        _replay_against(log, against, sets)
        return
    if sets:
        raise click.UsageError("--set changes the mission of --against: add --against MISSION")
    with bad_input():
        run_log = read_log(log)
        marsupial_metadata(run_log, log)
    meta = run_log.metadata
    click.echo(
        f"# {meta.get('mission_name', '?')} seed={meta.get('seed', '?')} outcome={run_log.outcome} "
        f"sim_time={run_log.sim_time}"
    )
    click.echo(format_timeline(run_log), nl=False)


def _replay_against(log: str, mission: str, sets: tuple[str, ...]) -> None:
    """``marsupial replay LOG --against MISSION``: exit 0 identical, 1 diverged (printed)."""
    from .against import replay_against

    with bad_input():
        result = replay_against(log, mission, _assignments(sets, "--set"))
    if result.divergence is None:
        click.echo(f"identical: {result.ticks} ticks, {result.commands} commands as logged")
        return
    click.echo(f"diverged at {result.divergence}")
    sys.exit(1)


@cli.command()
@click.argument("source", type=click.Path())
@click.option(
    "--output",
    "-o",
    type=click.Path(dir_okay=False),
    help="The page to write (default: LOG.html next to a log, CAMPAIGN_DIR/report.html for a campaign).",
)
def report(source: str, output: str | None) -> None:
    """Write the HTML report of a run log (SOURCE.mcap) or of a campaign folder (SOURCE = its --out).

    One self-contained page (no scripts, no network): summary and outcome,
    top-down map with true and estimated paths, behaviour-tree timeline,
    events and operator commands, metric plots, recorded images. A campaign
    page shows the success rate with its Wilson interval, the outcomes,
    histograms, and links to a report of every kept trial log.
    """
    from .report import write_report

    with bad_input():
        page = write_report(source, output)
    click.echo(f"report: {page}")


@cli.command()
@click.argument("log", type=click.Path(dir_okay=False))
def verify(log: str) -> None:
    """Re-run the mission recorded in LOG (same text, subtrees, seed, overrides, operator commands) and compare events.

    Works from the log alone: the mission and the subtree files it used are
    stored in it, so neither the current folder nor the files on disk matter.
    """
    from .mission import parse_mission
    from .operator import OperatorChannel
    from .replay import LogError, compare_events, read_log
    from .runner import run_mission
    from .subtrees import write_mission_copy

    with bad_input(), tempfile.TemporaryDirectory(prefix="marsupial-verify-") as tmp:
        original = read_log(log)
        meta = marsupial_metadata(original, log)
        if original.outcome in ("interrupted", "terminated", "incomplete"):
            raise LogError(f"{log}: the run was {original.outcome}; only runs that ended by themselves can be verified")
        name = Path(meta["mission_path"]).stem if meta.get("mission_path") else meta.get("mission_name", "mission")
        copy = write_mission_copy(Path(tmp) / "mission", name, meta["mission"], json.loads(meta.get("subtrees", "{}")))
        mission = parse_mission(meta["mission"], str(copy), json.loads(meta.get("overrides", "{}")), copy)
        script = [(e.at, e.say, e.why) for e in mission.spec.operator]
        live = [
            (e["t"], e["command"], e.get("why", ""), e["source"])
            for e in original.events_of("operator")
            if e["source"] != "script"
        ]
        fresh_path = Path(tmp) / "verify.mcap"
        run_mission(
            mission,
            seed=int(meta["seed"]),
            log_path=fresh_path,
            until=json.loads(meta.get("until", "null")),
            progress=False,
            operator=OperatorChannel(script + live),
        )
        differences = compare_events(original, read_log(fresh_path))
    if differences:
        click.echo(f"{log}: the re-run differs from the log ({len(differences)} lines):", err=True)
        click.echo("\n".join(differences[:60]), err=True)
        sys.exit(1)
    click.echo(f"{log}: verified, {len(original.events)} events identical")


@cli.command()
@click.argument("mission")
@click.option("--trials", type=click.IntRange(min=1), required=True, help="Trials per parameter combination.")
@click.option(
    "--seed",
    "base_seed",
    callback=_seed,
    metavar="SEED",
    default=0,
    show_default=True,
    help="Seed of trial 0, an integer ≥ 0 (trial i: seed + i).",
)
@_set_option
@click.option("--vary", multiple=True, metavar="KEY=V1,V2", help="Values to compare (cartesian product of all --vary).")
@click.option("--workers", type=click.IntRange(min=1), help="Parallel trials (default: CPU count).")
@click.option("--backend", type=click.Choice(["local", "ray"]), default="local", show_default=True)
@click.option("--address", help="Ray cluster address (default: start a local Ray inside --out).")
@click.option("--out", type=click.Path(file_okay=False), default="campaign", show_default=True)
@click.option("--until", type=float, callback=_positive_time, help="Time limit of each trial (simulated s, > 0).")
@click.option(
    "--logs",
    type=click.Choice(["failed", "all", "none"]),
    default="failed",
    show_default=True,
    help="Which trials keep their MCAP log.",
)
@click.option(
    "--resume",
    is_flag=True,
    help="Read back the trials already finished in --out with the same plan; run only the others.",
)
def campaign(
    mission: str,
    trials: int,
    base_seed: int,
    sets: tuple[str, ...],
    vary: tuple[str, ...],
    workers: int | None,
    backend: str,
    address: str | None,
    out: str,
    until: float | None,
    logs: str,
    resume: bool,
) -> None:
    """Run independent seeded trials of MISSION in parallel; write trials.json/.csv and summary.json in --out.

    Ends by printing the `marsupial report` command that turns the folder into an HTML page.
    """
    from .campaign import run_campaign

    try:
        with bad_input():
            varied = {k: v.split(",") for k, v in _assignments(vary, "--vary").items()}
            summary = run_campaign(
                mission,
                trials,
                out,
                base_seed,
                _assignments(sets, "--set"),
                varied,
                workers,
                backend,
                address,
                until,
                logs,
                resume=resume,
            )
    except KeyboardInterrupt:
        _err.print("campaign interrupted: no summary written (--resume continues it)")
        sys.exit(130)
    table = Table(title=f"campaign {mission} -> {out}", title_justify="left")
    for column in ("params", "trials", "success", "95% CI", "median sim time", "outcomes"):
        table.add_column(column)
    for group in summary["groups"] or [{"params": {}, **summary}]:
        low, high = group["success_rate_ci95"]
        table.add_row(
            ", ".join(f"{k}={v}" for k, v in group["params"].items()) or "all",
            str(group["trials"]),
            f"{group['success_rate']:.0%}",
            f"[{low:.0%}, {high:.0%}]",
            f"{group['median_sim_time']:.1f} s",
            ", ".join(f"{k} {n}" for k, n in group["outcomes"].items()),
        )
    Console().print(table)
    click.echo(f"report: marsupial report {shlex.quote(out)}")


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point (``marsupial``)."""
    cli.main(args=argv, prog_name="marsupial")


if __name__ == "__main__":
    main()
