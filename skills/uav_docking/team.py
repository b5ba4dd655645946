"""What the UAV skills of the docking family share: the carrier they work with, their blackboard keys.

A UAV skill (``explore``, ``rendezvous``, ``relative_hold``, ``deploy``)
runs on the UAV (``robot:``) and names its carrier, a team member of class
``MobileManipulator``, by the parameter ``carrier``. It reaches the carrier
through :func:`carrier_port`: the carrier's onboard interface (encoders,
camera, docking device states, its state estimate), whose commands (arm
targets) are stamped by the run's arbiter like its commands to the UAV.

Blackboard keys written by the family, under the carrier's name
(``"<carrier>/<key>"``):

- :data:`DOCKING_FLAG` ``docking`` — True while a docking or a deployment is
  in progress; ``navigate`` limits the carrier to its docking speed
  (0.5 m/s, Narváez §V-B-1) while it holds (its ``docking_flag`` parameter
  names this key, e.g. ``carrier/docking``);
- :data:`UAV_POSE` ``uav_pose_M`` — the last eye-in-hand measurement of the
  UAV (an :class:`~.observer.UavObservation`);
- :data:`UAV_STORED` ``uav_stored`` — True while a UAV is stored on the
  carrier (written by ``store`` and ``deploy``);
- :data:`PART_B_YAW` ``part_b_yaw`` — the heading (rad) of the locked UAV's
  Part B about Part A's axis, from the camera's estimate at the lock
  (written by ``contact``; read by ``deploy`` for the hand-over and cleared
  at the release; unset: 0, a UAV the mission stores on Part A's frame).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any

from marsupial.api.capabilities import Carrier
from marsupial.api.errors import UnknownNameError
from marsupial.api.views import CarrierView
from marsupial.trees.skill import TeamMember

if TYPE_CHECKING:
    from marsupial.trees.skill import MissionNode

#: a parameter naming the carrier a skill works with (checked by the compiler: a team member that is a Carrier)
CarrierName = Annotated[str, TeamMember(Carrier)]

DOCKING_FLAG = "docking"
UAV_POSE = "uav_pose_M"
UAV_STORED = "uav_stored"
PART_B_YAW = "part_b_yaw"


def carrier_port(skill: MissionNode[Any], name: str) -> CarrierView:
    """The onboard interface of team member ``name`` as ``skill`` commands it (through the run's arbiter).

    It must be a :class:`~marsupial.api.capabilities.Carrier`: an arm with
    its kinematics and a docking device (the ``mobile_manipulator``). Raises :class:`UnknownNameError` naming the
    team's carriers when ``name`` is not one of them.
    """
    context = skill.context
    carriers = [n for n in context.team() if skill.member(n).provides(Carrier)]
    if name not in carriers:
        raise UnknownNameError(f"carrier of {skill.name} (a mobile_manipulator)", name, carriers)
    return skill.member(name)

