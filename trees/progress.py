"""The live progress line of ``marsupial run``: where the run is, against its time limit, and what each robot does.

::

    t 123.4 / 900.0 s (14 %) · 9.8× real time · ETA ≤ 1 min 19 s · uav: explore, battery 97 % · carrier: navigate

- simulated time against the time limit (``--until`` / ``run.until``);
- the speed, as simulated seconds per wall-clock second;
- ETA: wall-clock time until the time limit at that speed (``≤``: the
  mission may finish earlier);
- per robot, its running skills (``idle`` when none) and, if it has one,
  its battery's state of charge.

It is drawn on a terminal only (rich ``Live``, transient), at most
:data:`REFRESH_S` apart. It takes plain values: the runner gathers them.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

from rich.console import Console
from rich.live import Live
from rich.text import Text

__all__ = ["REFRESH_S", "ProgressLine", "RobotStatus", "progress_text"]

REFRESH_S = 0.1  # wall-clock seconds between redraws


@dataclass(frozen=True)
class RobotStatus:
    """One robot in the progress line: its name, running skills and battery state of charge (0..1, None: none)."""

    name: str
    skills: tuple[str, ...]
    battery: float | None = None


def _duration(seconds: float) -> str:
    """``"45 s"``, ``"1 min 19 s"``, ``"2 h 03 min"`` (wall clock)."""
    seconds = max(0.0, seconds)
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{int(seconds // 60)} min {int(seconds % 60):02d} s"
    return f"{int(seconds // 3600)} h {int(seconds % 3600 // 60):02d} min"


def progress_text(
    sim_time: float, until: float | None, wall: float, paused: bool, robots: Sequence[RobotStatus]
) -> str:
    """The progress line for simulated time ``sim_time`` (s) of ``until`` (s; None: no limit) after ``wall`` s."""
    speed = sim_time / wall if wall > 0 else 0.0
    if until is None:
        parts = [f"t {sim_time:.1f} s (no time limit)"]
    else:
        parts = [f"t {sim_time:.1f} / {until:.1f} s ({100 * min(sim_time / until, 1.0):.0f} %)"]
    parts.append(f"{speed:.1f}× real time")
    if paused:
        parts.append("PAUSED by the operator")
    elif until is not None and speed > 0:
        parts.append(f"ETA ≤ {_duration((until - sim_time) / speed)}")
    for robot in robots:
        text = f"{robot.name}: {', '.join(robot.skills) or 'idle'}"
        if robot.battery is not None:
            text += f", battery {100 * robot.battery:.0f} %"
        parts.append(text)
    return " · ".join(parts)


class ProgressLine:
    """The progress line on ``console`` (only when ``enabled`` and the console is a terminal)."""

    def __init__(self, console: Console, enabled: bool):
        self.live: Live | None = None
        if enabled and console.is_terminal:
            self.live = Live(Text(""), console=console, refresh_per_second=8, transient=True)
            self.live.start()
        self._last = -REFRESH_S

    def due(self) -> bool:
        """Whether a redraw is due (the line is shown and :data:`REFRESH_S` passed since the last one)."""
        return self.live is not None and time.perf_counter() - self._last >= REFRESH_S

    def show(
        self, sim_time: float, until: float | None, wall: float, paused: bool, robots: Sequence[RobotStatus]
    ) -> None:
        """Redraw the line (see :func:`progress_text`)."""
        if self.live is None:
            return
        self._last = time.perf_counter()
        self.live.update(Text(progress_text(sim_time, until, wall, paused, robots)))

    def stop(self) -> None:
        """Remove the line (transient) and stop redrawing."""
        if self.live is not None:
            self.live.stop()
