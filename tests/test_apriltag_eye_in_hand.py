"""The Bebop 2's AprilTag bundle is detected by cv2.aruco in eye-in-hand frames from 0.3 m to 2 m.

Narváez et al. track the UAV with the PS Eye at the end effector (640×480,
§V-B) looking up at a bundle of AprilTags under the UAV (§V-A, Fig. 17).
"""

import cv2
import numpy as np
import pybullet
import pytest

from marsupial.api.tags import load_tag_bundle
from marsupial.world import World
from marsupial.world.robots import ROBOT_KINDS

pytestmark = pytest.mark.skipif("bebop2" not in ROBOT_KINDS, reason="needs the bebop2 robot kind")

DISTANCES = (0.3, 0.6, 1.0, 1.5, 2.0)  # m, camera to the tag plate along the optical axis
YAWS = (0.0, 0.5)  # rad, UAV heading


def _side_px(corners):
    """Mean side (px) of a detected tag."""
    c = corners.reshape(4, 2)
    return float(np.mean(np.linalg.norm(c - np.roll(c, 1, axis=0), axis=1)))


def test_bundle_is_detected_in_eye_in_hand_frames_from_0_3_to_2_m():
    bundle = load_tag_bundle()
    detector = cv2.aruco.ArucoDetector(
        cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, bundle.aruco_dictionary)), cv2.aruco.DetectorParameters()
    )
    with World(seed=0) as world:
        mm = world.add_robot("mobile_manipulator", arm_pose="docking_ready")
        camera = mm.eye_in_hand
        assert (camera.intrinsics.width, camera.intrinsics.height) == (640, 480)
        p_cam, R_world_optical = camera.optical_pose()
        assert R_world_optical[:, 2] @ [0, 0, 1] > 0.999  # looking straight up
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 3.0, 0.0], motors_on=False)
        plate_center = np.array([np.mean(bundle.plate_x), np.mean(bundle.plate_y), bundle.plate_z])  # base frame
        f = camera.K[1, 1]
        report = []  # (distance m, yaw rad, detected bundle ids, their sides px, projected sides px by id)
        for distance in DISTANCES:
            for yaw in YAWS:
                q = pybullet.getQuaternionFromEuler([0.0, 0.0, yaw])
                R = np.array(pybullet.getMatrixFromQuaternion(q)).reshape(3, 3)
                p_uav = p_cam + distance * R_world_optical[:, 2] - R @ plate_center
                pybullet.resetBasePositionAndOrientation(
                    uav.body_id, p_uav.tolist(), q, physicsClientId=world.client_id
                )
                frame = camera.measure()
                corners, ids, _ = detector.detectMarkers(cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2GRAY))
                seen = [(int(i), _side_px(c)) for c, i in zip(corners, [] if ids is None else ids.ravel(), strict=True)]
                seen = [(i, round(side, 1)) for i, side in seen if i in bundle.ids]
                projected = {t.id: round(f * t.size / distance, 1) for t in bundle.tags}
                report.append((distance, yaw, [i for i, _ in seen], [s for _, s in seen], projected))
        missed = "; ".join(str(r) for r in report if not r[2])
        assert not missed, f"no bundle tag detected at (distance, yaw, ids, sides px, projected px): {missed}"
        # the large tag carries the far range: still found at 2 m
        assert all(0 in r[2] for r in report if r[0] == 2.0)
