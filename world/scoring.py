"""The referee: truth-based scores of a run, measured on the world side and written to the log.

Skills decide from what the robots sense (:mod:`marsupial.api.views`);
how well they did is measured here, on simulator truth, and only recorded —
no skill or condition can read it back. The runner attaches one
:class:`Referee` to every run. It records, with the same names and labels
whatever the mission:

- ``tracking_error_x`` / ``tracking_error_y`` (label ``robot`` = the UAV),
  every :data:`TRACKING_PERIOD_S` while a quadrotor flies (motors on, not
  docked) in a team with exactly one robot carrying a landing platform: the
  platform's centre minus the UAV's position in the UAV's true heading
  frame (x forward, y left, m), as Palafox et al. report it (§4.2.1);
- ``unintended_contacts`` (label ``robot`` = the UAV), cumulative, and an
  ``unintended_contact`` event (``uav``, ``carrier``, ``uav_link``,
  ``carrier_link``) for every touch between a quadrotor that is not docked
  and a carrier with a docking device, other than on Part A (Narváez §V);
- ``rim_contacts`` (label ``robot`` = the MMS), cumulative, and a
  ``rim_contact`` event (``carrier``, ``part``, ``wall``, ``position``) for
  every touch of an MMS's arm, launching apparatus or held MAV with the
  aperture structure (:mod:`.rim_contacts`; Arora & Papachristos §IV-F).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from marsupial.geometry import heading_rotation, yaw_of

from .contacts import ContactEvent, ContactMonitor
from .rim_contacts import RimContacts, RimTouch

if TYPE_CHECKING:
    from .robots.base import Robot
    from .world import World

TRACKING_PERIOD_S = 0.1  # s between tracking-error samples

#: the referee's metrics as the metric registry declares them (``MetricSpec`` fields of
#: :mod:`marsupial.trees.metrics`, kept as plain data: the world does not import the runtime)
SCORES: tuple[dict[str, str], ...] = (
    {"name": "tracking_error_x", "unit": "m", "aggregation": "mean_abs",
     "meaning": "platform centre minus UAV position, forward in the UAV's heading frame (truth)"},
    {"name": "tracking_error_y", "unit": "m", "aggregation": "mean_abs",
     "meaning": "platform centre minus UAV position, leftward in the UAV's heading frame (truth)"},
    {"name": "unintended_contacts", "unit": "count", "aggregation": "total",
     "meaning": "touches of the flying UAV with the carrier other than on Part A (truth)"},
    {"name": "rim_contacts", "unit": "count", "aggregation": "total",
     "meaning": "touches of the MMS's arm, launcher or held MAV with the aperture structure (truth)"},
)
PART_A_LINK = "part_a"


class ScoreSink(Protocol):
    """Where scores go (the run's context: ``metric`` and ``event`` stamped with sim time)."""

    def metric(self, name: str, value: float, **labels: Any) -> None: ...

    def event(self, kind: str, **fields: Any) -> None: ...


def _flying(robot: Any) -> bool:
    return bool(getattr(robot, "motors_on", False)) and not bool(getattr(robot, "docked", False))


class Referee:
    """An actor scoring one world's run on truth (see the module docstring); add it with ``world.add_actor``."""

    def __init__(self, world: World, sink: ScoreSink):
        self.world = world
        self.sink = sink
        quadrotors = [r for r in world.robots.values() if hasattr(r, "motors_on")]
        platforms = [r for r in world.robots.values() if hasattr(r, "platform_pose")]
        carriers = [r for r in world.robots.values() if hasattr(r, "docking")]
        self._landing = [(uav, platforms[0]) for uav in quadrotors] if len(platforms) == 1 else []
        self._next_sample = 0.0
        self.contacts: dict[str, int] = {}
        self._monitors: list[tuple[Robot, ContactMonitor]] = []
        for uav in quadrotors:
            for carrier in carriers:
                monitor = ContactMonitor(
                    world, uav, carrier, allowed_links_b=[PART_A_LINK], on_contact=self._touch_handler(uav, carrier)
                )
                self._monitors.append((uav, monitor))
                self.contacts[uav.name] = 0
        for name in self.contacts:
            sink.metric("unintended_contacts", 0, robot=name)
        self.rim = RimContacts(world, self._rim_touched)
        for name in self.rim.count:
            sink.metric("rim_contacts", 0, robot=name)

    def _rim_touched(self, touch: RimTouch) -> None:
        self.sink.metric("rim_contacts", self.rim.count[touch.carrier], robot=touch.carrier)
        self.sink.event("rim_contact", carrier=touch.carrier, part=touch.part, wall=touch.wall,
                        position=[round(x, 4) for x in touch.position])

    def _touch_handler(self, uav: Robot, carrier: Robot) -> Any:
        def touched(event: ContactEvent) -> None:
            if getattr(uav, "docked", False):
                return  # held by the levers: the parts are meant to touch
            self.contacts[uav.name] += 1
            self.sink.metric("unintended_contacts", self.contacts[uav.name], robot=uav.name)
            self.sink.event(
                "unintended_contact",
                uav=uav.name,
                carrier=carrier.name,
                uav_link=event.link_a,
                carrier_link=event.link_b,
            )

        return touched

    def pre_physics(self, dt: float) -> None:
        """Nothing before physics."""

    def post_physics(self, dt: float) -> None:
        """Update the contact monitors and the rim watch; sample the tracking errors when due."""
        for _, monitor in self._monitors:
            monitor.post_physics(dt)
        self.rim.post_physics(dt)
        now = self.world.now
        if self._landing and now + 1e-9 >= self._next_sample:
            self._next_sample = now + TRACKING_PERIOD_S
            for uav, platform in self._landing:
                if _flying(uav):
                    error = platform_offset(uav, platform)
                    self.sink.metric("tracking_error_x", float(error[0]), robot=uav.name)
                    self.sink.metric("tracking_error_y", float(error[1]), robot=uav.name)


def platform_offset(uav: Any, platform: Any) -> np.ndarray:
    """Truth: platform centre minus UAV position in the UAV's heading frame (x, y in m)."""
    p_uav, q_uav = uav.pose()
    p_platform = platform.platform_pose()[0]
    return heading_rotation(yaw_of(q_uav)) @ (np.asarray(p_platform[:2]) - np.asarray(p_uav[:2]))

