"""The top-level keys of a mission: world (sensing, disturbances), team, operator, plugins, params, run, tree.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    model_validator,
)
from pydantic_core import PydanticCustomError

from ..errors import one_of, suggest
from .nodes import Node

# ------------------------------------------------------------------------ mission


class TeamLinkSpec(BaseModel):
    """The team's radio: one-way latency, its jitter, message loss and the estimate telemetry rate."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    latency_s: float = Field(0.02, ge=0, le=5.0, description="One-way latency of a message (s).")
    jitter_s: float = Field(0.01, ge=0, le=5.0, description="Standard deviation of the extra delay (s).")
    drop: float = Field(0.02, ge=0, le=1, description="Probability that a message is lost.")
    telemetry_hz: float = Field(
        20.0, gt=0, le=240, description="Rate at which every robot broadcasts its estimate (Hz)."
    )


class SensingSpec(BaseModel):
    """How the robots sense: one knob scaling every noise figure, and the team link."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    noise_scale: float = Field(
        1.0,
        ge=0,
        le=100,
        description=(
            "Multiplies every sensor noise, bias, drift, latency and loss figure (docs/world.md lists them with "
            "their sources); 1: the sourced values, 0: perfect sensing (for debugging only)."
        ),
    )
    team_link: TeamLinkSpec = Field(default_factory=TeamLinkSpec)


class WorldSpec(BaseModel):
    """The world to run in: scene name, seed of every noise source, sensing, disturbances."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
    scene: str | None = Field(None, description="Scene name (world/scenes/<name>.yaml); none: an empty floor.")
    seed: int = Field(0, ge=0, le=2**63 - 1, description="Seed of all randomness in the world (an integer >= 0).")
    sensing: SensingSpec = Field(default_factory=SensingSpec)
    disturbances: dict[str, Any] = Field(
        default_factory=dict, description="Disturbances (wind, sensor faults, kidnaps …; docs/world.md §7)."
    )


MAX_POSE_VALUE = 1000.0
"""Largest magnitude (m; rad for a yaw) of a start pose's entries and spreads: pybullet computes contacts in single
precision, whose step at 1 km is 0.06 mm and grows with the distance."""

PoseValue = Annotated[float, Field(ge=-MAX_POSE_VALUE, le=MAX_POSE_VALUE)]


class TeamMember(BaseModel):
    """A robot of the team: its kind, start pose and options."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
    robot: str = Field(description="Robot kind (see world/robots ROBOT_KINDS).")
    pose: list[PoseValue] | None = Field(
        None,
        description=(
            "Start pose [x, y], [x, y, yaw] (ground robots) or [x, y, z, yaw] (m, rad, world frame), each within "
            "±1000."
        ),
    )
    pose_spread: list[PoseValue] | None = Field(
        None,
        description=(
            "[dx, dy, dyaw] >= 0 (m, m, rad): the start pose is `pose` plus a uniform offset within ± each on x, y "
            "and yaw, drawn from the world seed (the robot's estimate starts there too)."
        ),
    )
    stored_on: str | None = Field(None, description="Team member that carries this robot at the start.")
    sensors: dict[str, Any] = Field(default_factory=dict, description="Sensor configurations by sensor name.")
    options: dict[str, Any] = Field(default_factory=dict, description="Options passed to the robot constructor.")


class OperatorEvent(BaseModel):
    """A scripted operator command at a simulated time."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
    at: float = Field(ge=0, description="Simulated time of the command (s).")
    say: str = Field(min_length=1, description="Command: abort, pause, resume or a mission-defined word (dock …).")
    why: str = Field("", description="Reason, recorded with the command.")


class RunSpec(BaseModel):
    """How the tree is ticked: tick rate and time limit (simulated)."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
    tick_hz: float = Field(
        10.0,
        ge=0.01,
        le=240.0,
        description=(
            "Tree tick rate (Hz, simulated time): at most the physics rate (240 Hz), at least one tick per 100 s."
        ),
    )
    until: float | None = Field(None, gt=0, description="Stop the run at this simulated time (s); none: no limit.")


def _plugin_ref(value: str) -> str:
    module, _, attr = value.partition(":")
    if not module or not attr or not all(p.isidentifier() for p in module.split(".") + attr.split(".")):
        raise PydanticCustomError("plugin_ref", "malformed plugin reference", {"expected": "'package.module:Class'"})
    return value


class MissionSpec(BaseModel):
    """A marsupial mission: world, team, scripted operator, plugins, parameters, run settings and the tree."""

    model_config = ConfigDict(extra="forbid", title="marsupial mission")

    mission: str = Field(description="Mission name.")
    description: str = Field("", description="What the mission does.")
    world: WorldSpec = Field(default_factory=WorldSpec)
    team: dict[str, TeamMember] = Field(default_factory=dict, description="Robots by name.")
    operator: list[OperatorEvent] = Field(default_factory=list, description="Scripted operator commands.")
    plugins: dict[str, Annotated[str, AfterValidator(_plugin_ref)]] = Field(
        default_factory=dict, description="Pinned skill/condition implementations: name -> 'package.module:Class'."
    )
    params: dict[str, Any] = Field(default_factory=dict, description="Mission parameters, referenced as ${name}.")
    run: RunSpec = Field(default_factory=RunSpec)
    tree: Node = Field(description="The behaviour tree.")

    @model_validator(mode="after")
    def _carriers_exist(self) -> MissionSpec:
        for name, member in self.team.items():
            others = set(self.team) - {name}
            if member.stored_on is not None and member.stored_on not in others:
                raise PydanticCustomError(
                    "unknown_carrier",
                    f"'{member.stored_on}' cannot carry '{name}'",
                    {
                        "expected": f"another team member ({one_of(others)})",
                        "suggestion": suggest(member.stored_on, others),
                        "at": ("team", name, "stored_on"),
                    },
                )
        return self
