"""The multi-phase helper of the node API (marsupial.trees.phases): dispatch, transitions and their events, checks.

The skills here take no robot, so they run without a world (simulated time stays 0); their events are read
back from the MCAP log.
"""

from __future__ import annotations

from enum import Enum

import py_trees
import pytest
from py_trees.common import Status

from marsupial.trees.phases import Phased, Transition, go
from marsupial.trees.recorder import Recorder
from marsupial.trees.replay import read_log
from marsupial.trees.skill import RunContext, Skill


class Pick(Phased, Skill):
    """Reach, then grasp and lift in one tick (``at_once``), then a silent hand-over: three ticks to SUCCESS."""

    class Phase(Enum):
        REACH = "reach"
        GRASP = "grasp"
        LIFT = "lift"
        DONE = "done"

    uses_robot = False
    phase: Phase

    def start(self) -> None:
        self.ticks: list[tuple[str, ...]] = []
        self.enter(go(self.Phase.REACH, target=[0.5, 0.0]))

    def step(self) -> Status:
        self.ticks.append(())
        return self.step_phase("tick")

    def _ran(self, argument: str) -> None:
        self.ticks[-1] += (f"{self.phase.value}:{argument}",)

    def _step_reach(self, argument: str) -> Status | Transition:
        self._ran(argument)
        return go(self.Phase.GRASP, event="reached", error_m=0.004)

    def _step_grasp(self, argument: str) -> Status | Transition:
        self._ran(argument)
        return go(self.Phase.LIFT, at_once=True)

    def _step_lift(self, argument: str) -> Status | Transition:
        self._ran(argument)
        return go(self.Phase.DONE, event=None)

    def _step_done(self, argument: str) -> Status:
        self._ran(argument)
        return Status.SUCCESS


def _run(node: Skill, path, ticks: int) -> list[dict]:
    """Tick ``node`` (at most ``ticks`` times, until it ends), its events recorded as a run records them; the log's."""
    py_trees.blackboard.Blackboard.clear()
    recorder = Recorder(path, {"mission_name": "phases"})
    node.context = context = RunContext()
    for _ in range(ticks):
        node.tick_once()
        for record in context.records:
            recorder.log_event(0.0, record.name, **record.fields)
        context.records.clear()
        if node.status != Status.RUNNING:
            break
    recorder.close("success")
    return read_log(path).events


def test_transitions_are_applied_and_recorded_as_phase_events(tmp_path):
    pick = Pick("pick")
    events = _run(pick, tmp_path / "pick.mcap", 10)
    assert pick.status == Status.SUCCESS and pick.phase is Pick.Phase.DONE
    # one method per tick, and the at_once transition runs the next phase's method in the same tick (same argument)
    assert pick.ticks == [("reach:tick",), ("grasp:tick", "lift:tick"), ("done:tick",)]
    phases = [(e["phase"], {k: v for k, v in e.items() if k not in ("t", "kind", "node", "skill", "robot", "phase")})
              for e in events if "phase" in e]
    assert phases == [
        ("reach", {"target": [0.5, 0.0]}),  # the first phase, entered in start()
        ("reached", {"error_m": 0.004}),  # a transition that names its own event
        ("lift", {}),  # named after the phase entered
    ]  # (no event for the silent hand-over to DONE)
    kinds = [(e["kind"], e["node"], e["skill"], e.get("status")) for e in events if "node" in e]
    assert kinds == [("state_change", "pick", "pick", "RUNNING")] + [("state_change", "pick", "pick", None)] * 3 + [
        ("outcome", "pick", "pick", "SUCCESS")]


def test_a_phase_without_its_method_is_refused_when_the_class_is_defined():
    with pytest.raises(TypeError, match="Broken: phase SLIP has no method _step_slip"):

        class Broken(Phased, Skill):
            class Phase(Enum):
                GRIP = "grip"
                SLIP = "slip"

            def _step_grip(self) -> Status:
                return Status.RUNNING


def test_phase_values_are_the_names_the_log_shows():
    with pytest.raises(TypeError, match=r"Numbered.Phase.FIRST: its value names the phase in the log, a string, not 1"):

        class Numbered(Phased, Skill):
            class Phase(Enum):
                FIRST = 1

            def _step_first(self) -> Status:
                return Status.RUNNING


class Loop(Phased, Skill):
    """Two phases that hand over to each other at once: a plug-in bug."""

    class Phase(Enum):
        PING = "ping"
        PONG = "pong"

    uses_robot = False

    def start(self) -> None:
        self.enter(go(self.Phase.PING, event=None))

    def step(self) -> Status:
        return self.step_phase()

    def _step_ping(self) -> Transition:
        return go(self.Phase.PONG, event=None, at_once=True)

    def _step_pong(self) -> Transition:
        return go(self.Phase.PING, event=None, at_once=True)


def test_a_loop_of_at_once_transitions_is_an_error_naming_it(tmp_path):
    with pytest.raises(RuntimeError, match=r"'loop': at_once transitions through PING -> PONG -> PING in one tick"):
        _run(Loop("loop"), tmp_path / "loop.mcap", 1)


class Sloppy(Phased, Skill):
    """A phase method that returns neither a status nor a transition."""

    class Phase(Enum):
        ONLY = "only"

    uses_robot = False

    def start(self) -> None:
        self.enter(go(self.Phase.ONLY, event=None))

    def step(self) -> Status:
        return self.step_phase()

    def _step_only(self) -> object:
        return "only"


def test_a_phase_method_returning_something_else_is_an_error_naming_it(tmp_path):
    with pytest.raises(TypeError, match=r"Sloppy._step_only returned 'only'; expected a py_trees Status or a "
                                        r"Transition"):
        _run(Sloppy("sloppy"), tmp_path / "sloppy.mcap", 1)


def test_a_silent_transition_has_no_fields_to_record():
    with pytest.raises(ValueError, match="records no event has no fields"):
        go(Pick.Phase.DONE, event=None, holster="left")
