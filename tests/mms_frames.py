"""Posed eye-in-hand depth frames of an MMS standing square to the ``collapsed_mockup`` wall (test helper)."""

from __future__ import annotations

import math

from marsupial.skills.aperture.detection import DepthFrame, eye_in_hand_frame
from marsupial.skills.aperture.scan import LEVEL_POSE
from marsupial.tools.rig import live_view
from marsupial.world import World

WALL_FACE_Y = -0.05  # the aperture wall's face toward the approach side (0.1 m thick at y = 0)
CAMERA_AHEAD_M = 1.057  # the camera ahead of the MMS's base centre at LEVEL_POSE (arm_base_link 0.25 m ahead)


def facing_frames(world: World, x: float, standoff: float, count: int) -> list[DepthFrame]:
    """``count`` frames of an MMS (added to ``world``) with its camera level ``standoff`` m from the wall at ``x``,
    posed through its onboard interface as ``aperture_scan`` does."""
    mms = world.add_robot("mms", pose=[x, WALL_FACE_Y - standoff - CAMERA_AHEAD_M, math.pi / 2], arm_q=LEVEL_POSE,
                          mavs=False)
    onboard = live_view(mms.world, mms.name)
    onboard.set_joint_targets(LEVEL_POSE)
    camera = onboard.sensor("camera")
    world.step(0.3)
    frames, last = [], -1.0
    while len(frames) < count:
        reading = camera.read()
        if reading is not None and reading.stamp > last:
            last = reading.stamp
            frames.append(eye_in_hand_frame(onboard, reading.data.depth, reading.data.K, onboard.joint_positions()))
        world.step(1.0 / 30.0)
    return frames
