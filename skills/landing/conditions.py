"""Conditions of the landing state machine of Palafox et al. (2019, §3.1): lost platform, landed, flight time.

They read only the onboard state of the UAV's :class:`~.tracking.TrackingModule` (blackboard key
``<uav>/tracking``, written by the landing skills); before the first
take-off there is none and none of them holds.

- ``platform_lost`` — the recovery module's trigger: the platform unseen for
  more than 0.5 s, or more than 0.25 m away below 0.7 m; it keeps holding
  until ``relocalize`` is back at the nominal height.
- ``landed`` — the UAV is in the landed state (set by ``land``).
- ``flight_time`` — the automatic land signal: so many seconds since the
  take-off (§4.2.3) or since the nominal height was reached (§4.2.1).
"""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field

from marsupial.api.capabilities import Rotorcraft
from marsupial.trees.skill import Condition, NodeParams, P

from .tracking import TrackingModule


class _TrackingCondition(Condition[P]):
    """Base: reads the UAV's tracking module from the blackboard."""

    reads = ("{robot}/tracking",)
    robot_kinds = (Rotorcraft,)

    def module(self) -> TrackingModule | None:
        """The UAV's tracking module, ``None`` before its first flight."""
        return self.read(f"{self.robot_name}/tracking")


class PlatformLost(_TrackingCondition["PlatformLost.Params"]):
    """Holds while the platform must be re-localised (§3.1): unseen too long, or too far off in the final descent."""

    class Params(NodeParams):
        seconds: float = Field(0.5, gt=0.0)  # 0.5 s without a new position, §3.1
        """Longest time (s) without seeing the platform, §3.1."""
        max_error: float = Field(0.25, gt=0.0)  # 0.25 m, §3.1
        """Largest horizontal UAV–platform error (m) accepted below ``final_height``, §3.1."""
        final_height: float = Field(0.7, gt=0.0)  # sonar below 0.7 m, §3.1
        """Sonar height (m) of the final landing stage, §3.1."""

    primary: ClassVar[str] = "seconds"

    def check(self) -> bool:
        module = self.module()
        if module is None:
            return False
        module.update()
        p = self.params
        why = module.relocalization_due(p.seconds, p.max_error, p.final_height)
        if why is not None:
            self.feedback_message = why
        return why is not None

    def describe(self) -> str:
        module = self.module()
        why = module.pending_relocalization if module is not None else None
        return super().describe() + (f": {why}" if why else "")


class Landed(_TrackingCondition["Landed.Params"]):
    """Holds while the UAV is in the landed state: down on the moving platform, motors off (§3.1)."""

    class Params(NodeParams):
        value: bool = True
        """Hold when landed (``true``) or when not landed (``false``)."""

    primary: ClassVar[str] = "value"

    def check(self) -> bool:
        module = self.module()
        landed = module is None or module.state == "landed"
        return landed == self.params.value


class FlightTime(_TrackingCondition["FlightTime.Params"]):
    """Holds once the UAV has flown a number of seconds since its take-off or since it reached the nominal height."""

    class Params(NodeParams):
        seconds: float = Field(10.0, ge=0.0)  # land signal 10 s after take-off, §4.2.3
        """Seconds (simulated) after which the condition holds: the automatic land signal, §4.2.3 / §4.2.1."""
        since: Literal["takeoff", "tracking"] = "takeoff"
        """Count from the take-off (§4.2.3) or from reaching the nominal height, i.e. time in tracking mode (§4.2.1)."""

    primary: ClassVar[str] = "seconds"

    def check(self) -> bool:
        module = self.module()
        if module is None or module.state == "landed":
            return False
        start = module.flight_start if self.params.since == "takeoff" else module.tracking_start
        return start is not None and self.now + 1e-9 >= start + self.params.seconds
