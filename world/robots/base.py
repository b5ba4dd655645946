"""What every robot of the world shares: its pybullet body, named links, pose and sensors.

Skills never call pybullet: they read state and send commands through the
methods of a robot class. Poses are in the ``world`` frame (metres,
quaternions ``[x, y, z, w]``); velocities in the world frame (m/s, rad/s).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet

from marsupial.api.assets import asset_path
from marsupial.api.errors import UnknownNameError
from marsupial.api.views import RobotView
from marsupial.geometry import Vector, yaw_of  # (yaw_of is also re-exported for the robot modules)

if TYPE_CHECKING:
    from ..estimation.base import Estimator
    from ..sensors.base import Sensor
    from ..world import World


def pose_from_list(pose: Vector, default_z: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Turn a mission pose into ``(position, quaternion)`` in the world frame.

    Accepted: ``[x, y]``, ``[x, y, yaw]`` (ground robots, z = ``default_z``)
    or ``[x, y, z, yaw]``; yaw in radians about world z.
    """
    values = [float(v) for v in pose]
    if len(values) == 2:
        x, y, z, yaw = values[0], values[1], default_z, 0.0
    elif len(values) == 3:
        x, y, z, yaw = values[0], values[1], default_z, values[2]
    elif len(values) == 4:
        x, y, z, yaw = values
    else:
        raise ValueError(f"a pose is [x, y], [x, y, yaw] or [x, y, z, yaw]; got {list(pose)}")
    return np.array([x, y, z]), np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])


def rotation_matrix(quaternion: Vector) -> np.ndarray:
    """3×3 rotation matrix of an ``[x, y, z, w]`` quaternion."""
    return np.array(pybullet.getMatrixFromQuaternion(quaternion)).reshape(3, 3)


def base_frame_offset(p_base: np.ndarray, q_base: np.ndarray, p_link: np.ndarray,
                      q_link: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation of a link in its base frame, from the two world poses (model set-up only)."""
    R_base = rotation_matrix(q_base)
    return R_base.T @ (np.asarray(p_link) - np.asarray(p_base)), R_base.T @ rotation_matrix(q_link)


class Robot:
    """Base of every robot: owns one pybullet body (or more) and its sensors.

    Subclasses load their URDF in ``__init__`` with :meth:`load_urdf`, add
    sensors with :meth:`add_sensor`, drive themselves in ``pre_physics`` /
    ``post_physics`` (called by the world every physics step) and implement
    :meth:`safe_stop`.
    """

    #: registry name of the kind, e.g. ``"bebop2"``
    kind: str = ""
    #: the view of it that nodes hold (:mod:`marsupial.api.views`): its kind's readings and commands
    view_class: type[RobotView] = RobotView
    #: the onboard state estimator (set by each kind's constructor, :mod:`marsupial.world.estimation`)
    estimator: Estimator

    def __init__(self, world: World, name: str):
        self.world = world
        self.name = name
        self.cid = world.client_id
        self.body_id: int = -1
        self.links: dict[str, int] = {}
        self.sensors: dict[str, Sensor] = {}
        self._link_offsets: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    # ------------------------------------------------------------ building
    def load_urdf(
        self,
        filename: str,
        position: Vector,
        orientation: Vector = (0.0, 0.0, 0.0, 1.0),
        fixed_base: bool = False,
    ) -> int:
        """Load ``world/assets/<filename>`` as this robot's body; fill :attr:`links`."""
        body = pybullet.loadURDF(
            str(asset_path(filename)),
            basePosition=list(position),
            baseOrientation=list(orientation),
            useFixedBase=fixed_base,
            flags=pybullet.URDF_USE_INERTIA_FROM_FILE | pybullet.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT,
            physicsClientId=self.cid,
        )
        self.body_id = body
        base_name = pybullet.getBodyInfo(body, physicsClientId=self.cid)[0].decode()
        self.links = {base_name: -1}
        for j in range(pybullet.getNumJoints(body, physicsClientId=self.cid)):
            info = pybullet.getJointInfo(body, j, physicsClientId=self.cid)
            self.links[info[12].decode()] = j
        p_base, q_base = self.pose()
        self._link_offsets = {
            name: base_frame_offset(p_base, q_base, *self.link_pose(index)) for name, index in self.links.items()
        }
        return body

    def add_sensor(self, sensor: Sensor) -> Sensor:
        """Attach ``sensor`` under its name; returns it."""
        self.sensors[sensor.name] = sensor
        return sensor

    # --------------------------------------------------------------- state
    def link_index(self, link: str) -> int:
        """pybullet index of the link called ``link`` (-1 for the base)."""
        try:
            return self.links[link]
        except KeyError:
            raise UnknownNameError(f"link of {self.kind}", link, self.links) from None

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Base position (m) and orientation quaternion ``[x, y, z, w]`` in the world frame."""
        p, q = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
        return np.array(p), np.array(q)

    def velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """Base linear (m/s) and angular (rad/s) velocity in the world frame."""
        v, w = pybullet.getBaseVelocity(self.body_id, physicsClientId=self.cid)
        return np.array(v), np.array(w)

    def base_state(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """Base position, orientation, linear and angular velocity (world frame) as plain tuples (sensor models)."""
        p, q = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.cid)
        v, w = pybullet.getBaseVelocity(self.body_id, physicsClientId=self.cid)
        return p, q, v, w

    def restart_estimate(self) -> None:
        """Scene set-up only (a robot placed where the run starts it): restart its estimate at the true pose there.

        The mission declares where a robot starts, so this is its declared start
        pose, as at spawning; robots without an estimator (test rigs) are left alone.
        """
        estimator = getattr(self, "estimator", None)
        if estimator is not None:
            p, q = self.estimate_frame_pose()
            estimator.reset(p, yaw_of(q))

    def estimate_frame_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """True pose of the frame the estimator estimates (the base; ground robots: ``base_footprint``)."""
        return self.pose()

    def link_pose(self, link: str | int) -> tuple[np.ndarray, np.ndarray]:
        """World pose of a link frame (URDF link frame, not its inertial frame)."""
        index = self.link_index(link) if isinstance(link, str) else link
        if index == -1:
            return self.pose()
        state = pybullet.getLinkState(
            self.body_id, index, computeForwardKinematics=True, physicsClientId=self.cid
        )
        return np.array(state[4]), np.array(state[5])

    def link_offset(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """Position (m) and rotation of ``link`` in the base frame as the URDF places it.

        This is the model, not a measurement.
        """
        try:
            p, R = self._link_offsets[link]
        except KeyError:
            raise UnknownNameError(f"link of {self.kind}", link, self.links) from None
        return p.copy(), R.copy()

    def mounted_frame(
        self, link: str | int, offset: np.ndarray, R_link_frame: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """World position (m) and rotation of a frame fixed to ``link`` at ``offset`` with ``R_link_frame``."""
        p_link, q_link = self.link_pose(link)
        R_world_link = rotation_matrix(q_link)
        return p_link + R_world_link @ offset, R_world_link @ R_link_frame

    def sensor(self, name: str) -> Sensor:
        """The sensor called ``name`` (full ``"<robot>/<sensor>"`` or short name).

        The error for an unknown name lists this robot's sensors.
        """
        try:
            return self.sensors[name] if name in self.sensors else self.sensors[f"{self.name}/{name}"]
        except KeyError:
            raise UnknownNameError(f"sensor of {self.name}", name, self.sensors) from None

    def state(self) -> dict[str, Any]:
        """JSON-ready summary for logs: pose (world frame) plus what subclasses add."""
        p, q = self.pose()
        return {"position": p.tolist(), "orientation": q.tolist()}

    # ------------------------------------------------------------ stepping
    def pre_physics(self, dt: float) -> None:
        """Apply this step's forces/commands (called by the world before each physics step)."""

    def post_physics(self, dt: float) -> None:
        """Update internal state after each physics step (batteries, estimates)."""

    @classmethod
    def declared_sensors(cls) -> frozenset[str] | None:
        """Short names of the sensors every robot of this kind has (``None``: not declared, not checked)."""
        return None

    def safe_stop(self) -> None:
        """Leave the robot safe: hover in place, stop the wheels, hold the arm."""
        raise NotImplementedError(f"{type(self).__name__} must say how it stops safely")
