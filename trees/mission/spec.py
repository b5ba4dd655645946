"""The top-level keys of a mission: world (sensing, disturbances), team, operator, plugins, params, run, tree.

The sections the world consumes (team members' options and sensor settings,
disturbances) are the models of :mod:`marsupial.api.config`.
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

from marsupial.api.config import Disturbances, TeamMember

from ..errors import one_of, suggest
from .nodes import Node

# ------------------------------------------------------------------------ mission


class TeamLinkSpec(BaseModel):
    """The team's radio: one-way latency, its jitter, message loss and the estimate telemetry rate."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
    latency_s: float = Field(0.02, ge=0, le=5.0, description="One-way latency of a message (s).")
    jitter_s: float = Field(0.01, ge=0, le=5.0, description="Standard deviation of the extra delay (s).")
    drop: float = Field(0.02, ge=0, le=1, description="Probability that a message is lost.")
    telemetry_hz: float = Field(
        20.0, gt=0, le=240, description="Rate at which every robot broadcasts its estimate (Hz)."
    )
    retry_s: float = Field(
        0.5, gt=0, le=10.0,
        description="Acknowledgement timeout of a one-shot command before it is sent again (s).",
    )
    max_retries: int = Field(3, ge=0, le=100, description="Times a one-shot command is sent again before it is lost.")


class SensingSpec(BaseModel):
    """How the robots sense: one knob scaling every noise figure, and the team link."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
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
    disturbances: Disturbances = Field(
        default_factory=Disturbances, description="Disturbances (wind, sensor faults, kidnaps …; docs/world.md §7)."
    )


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
    def _team_members_exist(self) -> MissionSpec:
        """Carriers (``stored_on``) and the robots that disturbances name are team members."""
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
        for at, robot in self.world.disturbances.robots():
            if robot not in self.team:
                raise PydanticCustomError(
                    "unknown_robot",
                    f"unknown robot '{robot}'",
                    {
                        "expected": f"a team member ({one_of(self.team)})",
                        "suggestion": suggest(robot, self.team),
                        "at": ("world", "disturbances", *at),
                    },
                )
        return self
