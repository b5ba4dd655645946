"""``approach_aperture`` and ``analyze_aperture`` in ``collapsed_mockup``: after ``aperture_scan`` the MMS drives to a
placement, looks, and plans the launches through the aperture it ranked first.

The skill decides from the onboard interface only; the test scores on
truth: the base stands where the placement says, and the camera's true pose
sees the true centre of the aperture the ranking put first.
"""

from __future__ import annotations

import numpy as np
import py_trees
import pytest
from py_trees.common import Status
from skill_harness import Harness

from marsupial.geometry import rotation_matrix, yaw_of
from marsupial.skills.aperture.analyze import LAUNCH_PLANS, AnalyzeAperture
from marsupial.skills.aperture.approach import PLACEMENT, ApproachAperture
from marsupial.skills.aperture.placement import CameraModel, in_view
from marsupial.skills.aperture.scan import APERTURES, ApertureScan
from marsupial.world import World
from marsupial.world.robots.mms import CAMERA_INTRINSICS
from marsupial.world.sensors.camera import OPTICAL_FORWARD


@pytest.mark.slow
def test_the_mms_reaches_a_placement_from_which_its_camera_sees_the_best_aperture_and_plans_launches():
    with World(scene="collapsed_mockup", seed=3) as world:
        mms = world.add_robot("mms", "mms", pose=[0.3, -2.4, 1.5708])
        harness = Harness(world)
        scan, approach = harness.node(ApertureScan, "mms"), harness.node(ApproachAperture, "mms")
        analyze = harness.node(AnalyzeAperture, "mms")
        root = py_trees.composites.Sequence("scan_approach_analyze", memory=True, children=[scan, approach, analyze])
        assert harness.run(root, 130.0) == Status.SUCCESS, (approach.feedback_message, analyze.feedback_message)
        placement = approach.read(f"mms/{PLACEMENT}")
        best = scan.read(f"mms/{APERTURES}")[0]
        p_true, q_true = mms.pose()
        assert np.hypot(*(p_true[:2] - placement.pose[:2])) < 0.15
        assert abs(np.remainder(yaw_of(q_true) - placement.pose[2] + np.pi, 2 * np.pi) - np.pi) < 0.1
        zones = world.scene.zones_tagged("aperture")
        zone = min(zones, key=lambda z: np.linalg.norm(np.asarray(z.center) - best.m_A))
        assert np.linalg.norm(np.asarray(zone.center) - best.m_A) < 0.1  # the ranked aperture is a real one
        p_link, q_link = mms.link_pose("camera_link")
        camera = CameraModel(np.zeros(3), OPTICAL_FORWARD, CAMERA_INTRINSICS.K, CAMERA_INTRINSICS.width,
                             CAMERA_INTRINSICS.height, CAMERA_INTRINSICS.near)
        R_optical = rotation_matrix(q_link) @ OPTICAL_FORWARD
        assert in_view(camera, np.asarray(p_link), R_optical, np.asarray(zone.center), margin_px=40.0)
        assert 0.3 < np.linalg.norm(np.asarray(p_link) - zone.center) < 0.7  # the stand-off (0.5 m)
        plans = analyze.read(f"mms/{LAUNCH_PLANS}")
        assert plans and all(plan.feasible for plan in plans)
        for plan in plans[:5]:  # ξ_MAV on the true aperture's plane, within it; g d_l out along n̂
            assert np.linalg.norm(plan.pre_launch - np.asarray(zone.center)) < 0.12
            assert np.dot(plan.normal, (0.0, -1.0, 0.0)) > 0.95  # the mockup's wall: y = 0, the MMS on its -y side
            assert np.linalg.norm(plan.goal - plan.pre_launch) > 0.1
