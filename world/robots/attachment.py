"""Rigid attachments between bodies: welds (fixed constraints) and contact filtering.

A weld holds two links at the relative pose they have when it is made, like
a latch or a gripper closing on a part. pybullet places constraint frames in
the links' centre-of-mass frames; :func:`weld` takes care of that.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import pybullet

from marsupial.geometry import Vector

if TYPE_CHECKING:
    from .base import Robot


def _com_pose(body: int, link: int, cid: int) -> tuple[Any, Any]:
    """World pose of the centre-of-mass frame of ``link`` of ``body`` (-1: the base)."""
    if link == -1:
        return pybullet.getBasePositionAndOrientation(body, physicsClientId=cid)
    state = pybullet.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=cid)
    return state[0], state[1]


def weld(parent_body: int, parent_link: int, child_body: int, child_link: int, max_force: float, cid: int) -> int:
    """Fixed constraint holding two links at their present relative pose, up to ``max_force`` (N); returns its id."""
    p_parent, q_parent = _com_pose(parent_body, parent_link, cid)
    p_child, q_child = _com_pose(child_body, child_link, cid)
    p_inv, q_inv = pybullet.invertTransform(p_parent, q_parent)
    p_rel, q_rel = pybullet.multiplyTransforms(p_inv, q_inv, p_child, q_child)
    constraint = pybullet.createConstraint(
        parent_body, parent_link, child_body, child_link, pybullet.JOINT_FIXED, [0, 0, 0],
        p_rel, [0, 0, 0], q_rel, physicsClientId=cid,
    )
    pybullet.changeConstraint(constraint, maxForce=max_force, physicsClientId=cid)
    return constraint


def set_collisions(
    body_a: int, links_a: Sequence[int], body_b: int, links_b: Sequence[int], enabled: bool, cid: int
) -> None:
    """Enable or disable contacts between every link of ``links_a`` and every link of ``links_b``."""
    for link_a in links_a:
        for link_b in links_b:
            pybullet.setCollisionFilterPair(body_a, body_b, link_a, link_b, int(enabled), physicsClientId=cid)


def place_link_at(robot: Robot, link: str, position: Vector, orientation: Vector) -> None:
    """Teleport ``robot`` at rest so that its ``link`` frame lands on the given world pose (m, [x, y, z, w]).

    Scene set-up only (a robot that starts the run stored): its onboard
    estimate restarts there, as if it had been spawned there.
    """
    cid = robot.cid
    p_base, q_base = pybullet.getBasePositionAndOrientation(robot.body_id, physicsClientId=cid)
    p_link, q_link = robot.link_pose(link)
    p_inv, q_inv = pybullet.invertTransform(p_base, q_base)
    p_base_link, q_base_link = pybullet.multiplyTransforms(p_inv, q_inv, list(p_link), list(q_link))
    p_link_base, q_link_base = pybullet.invertTransform(p_base_link, q_base_link)
    p_new, q_new = pybullet.multiplyTransforms(list(position), list(orientation), p_link_base, q_link_base)
    pybullet.resetBasePositionAndOrientation(robot.body_id, p_new, q_new, physicsClientId=cid)
    pybullet.resetBaseVelocity(robot.body_id, (0, 0, 0), (0, 0, 0), physicsClientId=cid)
    robot.restart_estimate()
