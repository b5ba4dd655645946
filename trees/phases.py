"""Multi-phase skills: the phases in an ``Enum``, one method per phase, the transitions in one place.

A skill that goes through phases (``deploy``: raise the arm, spin the motors
up, climb clear) mixes in :class:`Phased` before its skill base, names its
phases in a nested ``Phase`` enum whose values are the names the log shows,
and writes one method ``_step_<member name in lower case>`` per phase::

    class Deploy(Phased, Skill["Deploy.Params"]):
        class Phase(Enum):
            RAISE = "raise"
            SPIN_UP = "spin_up"
            CLIMB = "climb"

        phase: Phase

        def start(self) -> None:
            self.enter(go(self.Phase.RAISE))   # the first phase, recorded as "raise"

        def step(self) -> Status:
            return self.step_phase()           # _step_raise, _step_spin_up or _step_climb

        def _step_raise(self) -> Status | Transition:
            ...
            return go(self.Phase.SPIN_UP)      # recorded as "spin_up"

A phase method returns a py_trees ``Status`` (``RUNNING``: stay in the phase;
``SUCCESS`` or ``FAILURE``: the skill ends) or the next phase as a
:class:`Transition` built by :func:`go`. :meth:`Phased.step_phase` applies it
(:meth:`Phased.enter`): it sets :attr:`Phased.phase` and records the phase
event, named after the new phase unless the transition names another event
(``go(Phase.APPROACH, event="capture_failed", failed=2)``) or none
(``event=None``: the transition is not logged). It then returns ``RUNNING``,
or, for a transition made ``at_once``, runs the new phase's method in the
same tick, with the same arguments.

A phase event is a ``state_change`` event with the node, skill, robot,
``phase`` (the event's name) and the transition's fields; :func:`phase_event`
records one for what happens within a phase (a sighting, a cancellation).
The methods are found when the class is defined: a phase without its method,
or a phase value that is not a string, is a ``TypeError`` then.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

from py_trees.common import Status

if TYPE_CHECKING:
    from .skill import RunContext


class _Node(Protocol):
    """What a phase event names: a mission node (its name, registry kind, robot) and the run it belongs to."""

    name: str
    kind: str
    robot_name: str | None
    context: RunContext


def phase_event(node: _Node, phase: str, **fields: Any) -> None:
    """Record that ``node`` entered ``phase``: a ``state_change`` event with the node, skill, robot and ``fields``.

    Stamped with the run's simulated time (s); ``fields`` are JSON values.
    """
    node.context.event("state_change", node=node.name, skill=node.kind, robot=node.robot_name, phase=phase, **fields)


class _Name(Enum):
    """The default event name of a transition: the new phase's value."""

    OF_PHASE = "the new phase's value"


@dataclass(frozen=True)
class Transition:
    """A phase method's request to enter ``phase``.

    Attributes:
        phase: the phase entered (a member of the skill's ``Phase`` enum).
        event: the name of the phase event recorded (``None``: none is).
        fields: the event's fields (JSON values, SI units).
        at_once: run the new phase's method in the same tick (else it runs from the next tick on).
    """

    phase: Enum
    event: str | None
    fields: Mapping[str, Any] = field(default_factory=dict)
    at_once: bool = False


def go(phase: Enum, *, event: str | None | _Name = _Name.OF_PHASE, at_once: bool = False,
       **fields: Any) -> Transition:
    """The transition to ``phase``, recorded as a phase event named ``event`` with ``fields``.

    ``event`` defaults to the phase's value; ``None`` records no event.
    ``at_once`` runs the new phase's method in the same tick.
    """
    name = phase.value if event is _Name.OF_PHASE else event
    if event is None and fields:
        raise ValueError(f"a transition to {phase.name} that records no event has no fields to record: {fields}")
    return Transition(phase, name, fields, at_once)


class Phased:
    """Mixin of a skill that goes through phases: its ``Phase`` enum, one ``_step_<phase>`` method per phase.

    Put it before the skill base (``class Contact(Phased, Skill["Contact.Params"])``); see the module
    docstring. :attr:`phase` is the present phase, set by :meth:`enter` (in ``start()``, the first
    phase) and by :meth:`step_phase` (the transitions the phase methods return).
    """

    #: the skill's phases (a nested ``class Phase(Enum)``); a class without one is an abstract base
    Phase: ClassVar[type[Enum]]
    #: the phase method of each phase, found when the class is defined
    _phase_steps: ClassVar[Mapping[Enum, Callable[..., Status | Transition]]]
    #: the present phase
    phase: Enum
    # what a phase event names (set by the node base the mixin goes with)
    name: str
    kind: str
    robot_name: str | None
    context: RunContext

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        phases = getattr(cls, "Phase", None)
        if phases is None:
            return
        if not (isinstance(phases, type) and issubclass(phases, Enum)):
            raise TypeError(f"{cls.__name__}.Phase must be an Enum of the skill's phases, not {phases!r}")
        steps: dict[Enum, Callable[..., Status | Transition]] = {}
        for member in phases:
            if not isinstance(member.value, str):
                raise TypeError(f"{cls.__name__}.Phase.{member.name}: its value names the phase in the log, "
                                f"a string, not {member.value!r}")
            method = getattr(cls, f"_step_{member.name.lower()}", None)
            if not callable(method):
                raise TypeError(f"{cls.__name__}: phase {member.name} has no method _step_{member.name.lower()}")
            steps[member] = method
        cls._phase_steps = steps

    def enter(self, transition: Transition) -> None:
        """Enter ``transition.phase`` and record its phase event (if it names one)."""
        if transition.phase not in self._phase_steps:
            raise ValueError(f"{type(self).__name__}: {transition.phase!r} is not one of its phases")
        self.phase = transition.phase
        if transition.event is not None:
            phase_event(self, transition.event, **transition.fields)

    def step_phase(self, *args: Any) -> Status:
        """Run the present phase's method with ``args`` and apply what it returns (see the module docstring).

        A tick enters each phase at most once: a chain of ``at_once`` transitions longer than the phases
        is a ``RuntimeError`` naming them.
        """
        visited = []
        for _ in range(len(self._phase_steps)):
            visited.append(self.phase.name)
            method = self._phase_steps[self.phase]
            outcome = method(self, *args)
            if isinstance(outcome, Status):
                return outcome
            if not isinstance(outcome, Transition):
                raise TypeError(f"{type(self).__name__}.{method.__name__} returned {outcome!r}; expected a py_trees "
                                "Status or a Transition (go(...))")
            self.enter(outcome)
            if not outcome.at_once:
                return Status.RUNNING
        raise RuntimeError(f"{type(self).__name__} '{self.name}': at_once transitions through "
                           f"{' -> '.join(visited)} -> {self.phase.name} in one tick (a loop)")
