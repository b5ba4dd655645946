"""marsupial: behaviour-tree missions for marsupial robot teams (carrier + child robots).

For notebooks and scripts::

    import marsupial
    result = marsupial.run("demo_hover", seed=3, set={"params.cruise_height": 2.0})
    result.outcome, result.log_path          # "success", PosixPath("runs/demo_hover-20261201T120000Z.mcap")
    log = marsupial.read_log(result.log_path)
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from marsupial.trees.replay import RunLog
    from marsupial.trees.runner import RunResult

__version__ = "0.1.0"


def run(
    mission: str | Path,
    *,
    seed: int | None = None,
    set: dict[str, Any] | None = None,  # noqa: A002 - the name the CLI uses (--set)
    log: bool | str | Path = True,
    until: float | None = None,
    record_images: bool = False,
    progress: bool = False,
    isolate: bool = False,
) -> RunResult:
    """Run ``mission`` (a shipped name or a ``.yaml`` path) to its end, as ``marsupial run`` does.

    Args:
        seed: world seed (default: the mission's ``world.seed``).
        set: overrides, ``{"params.cruise_height": 2.0, "run.until": 30}`` (values as in ``--set``).
        log: ``True``: log to ``runs/<mission>-<UTC time>.mcap`` (relative to the current folder);
            a path: log there; ``False``: no log.
        until: time limit in simulated seconds (default: the mission's ``run.until``).
        record_images: record the camera frames skills log.
        progress: print the progress line and the summary table.
        isolate: run the tree and its skills in a process of their own (``--isolate``).

    Returns the :class:`~marsupial.trees.runner.RunResult` (``outcome``,
    ``sim_time``, ``metrics``, ``log_path`` …). Bad input raises
    :class:`~marsupial.trees.errors.MissionError` before anything runs.
    """
    from marsupial.trees.mission import load_mission
    from marsupial.trees.runner import default_log_path, run_mission

    overrides = {str(k): v if isinstance(v, str) else _text(v) for k, v in (set or {}).items()}
    loaded = load_mission(mission, overrides)
    log_path = default_log_path(loaded.name) if log is True else Path(log) if log else None
    return run_mission(loaded, seed=seed, log_path=log_path, until=until, progress=progress,
                       record_images=record_images, isolate=isolate)


def read_log(path: str | Path) -> RunLog:
    """Read a run's MCAP log (:func:`marsupial.trees.replay.read_log`: events, metrics, poses, tree snapshots)."""
    from marsupial.trees.replay import read_log as read

    return read(path)


def _text(value: Any) -> str:
    """A Python value as ``--set`` text (JSON, which YAML reads back: lists, numbers, booleans)."""
    import json

    return json.dumps(value)
