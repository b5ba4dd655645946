"""Decoys cut into collapsed_mockup's wall (``world.disturbances.decoys``) and the seeded start pose (``pose_spread``).

The layout must follow the seed, lie where the entry says, be built as the
zones say (rays pass through a hole, stop at a recess's back), and be what the
aperture benchmark relies on: a hole too small for the MAV gets no launch
configuration from the profile analysis, a shallow recess is no hollow
candidate of the detection (and a deep one is).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pybullet
import pytest
from mms_frames import facing_frames
from shapely.geometry import box

from marsupial.api.errors import WorldError
from marsupial.skills.aperture import DetectionParams, detect_apertures, mav_contour, profile_analysis
from marsupial.trees.mission import load_mission
from marsupial.trees.runner import build_world
from marsupial.world import World
from marsupial.world.apertures import rasterised
from marsupial.world.disturbances import apply_disturbances
from marsupial.world.robots.mms import CAMERA_INTRINSICS

ENTRY = {"wall": "mockup_wall_1", "x": [-2.2, -1.1], "z": [0.45, 1.25], "recesses": 1, "holes": 2}
MISSION = Path(__file__).resolve().parents[1] / "benchmarks" / "missions" / "aperture_ranking.yaml"
FACE_Y, BACK_Y = -0.05, 0.05  # the wall's faces


def _layout(seed: int, entry: dict = ENTRY) -> list[tuple[str, tuple, tuple]]:
    with World(scene="collapsed_mockup", seed=seed) as world:
        apply_disturbances(world, {"decoys": entry})
        return [(z.label, z.lo, z.hi) for z in world.scene.zones_tagged("decoy")]


def _ray_hit_y(world: World, x: float, z: float) -> float | None:
    """y (m) where a ray along +y at (x, z) from the approach side first hits something, None if nothing."""
    hit = pybullet.rayTest([x, -1.0, z], [x, 1.0, z], physicsClientId=world.client_id)[0]
    return None if hit[0] < 0 else float(hit[3][1])


def test_the_layout_follows_the_seed():
    assert _layout(3) == _layout(3)
    assert _layout(3) != _layout(4)


def test_decoys_lie_where_the_entry_says_and_are_built_as_their_zones_say():
    with World(scene="collapsed_mockup", seed=7) as world:
        apply_disturbances(world, {"decoys": ENTRY})
        scene = world.scene
        recesses, holes = scene.zones_tagged("recess"), scene.zones_tagged("hole")
        assert len(recesses) == 1 and len(holes) == 2
        assert "mockup_wall_1" not in scene.objects and scene.labels("mockup_wall")  # rebuilt in pieces
        for zone in recesses + holes:
            assert "decoy" in zone.tags
            assert -2.2 < zone.lo[0] < zone.hi[0] < -1.1 and 0.45 < zone.lo[2] < zone.hi[2] < 1.25
            x, _, z = zone.center
            if "hole" in zone.tags:
                assert max(zone.size[0], zone.size[2]) < 0.0945  # the MAV fits at no angle
                hit = _ray_hit_y(world, x, z)  # through the wall: the rubble behind may stop it there (its
                assert hit is None or hit > BACK_Y - 0.01  # corners, turned by up to 0.08 rad, reach 7 mm in)
            else:
                depth = zone.hi[1] - FACE_Y
                assert 0.01 <= depth <= 0.04  # below d_C
                assert _ray_hit_y(world, x, z) == pytest.approx(FACE_Y + depth, abs=1e-3)  # stops at its back
            beside = zone.hi[0] + 0.03  # solid wall just beside the opening (gap 0.06 m)
            assert _ray_hit_y(world, beside, z) == pytest.approx(FACE_Y, abs=1e-3)


def test_a_layout_without_room_is_an_error():
    with World(scene="collapsed_mockup", seed=1) as world, pytest.raises(WorldError, match="no room"):
        apply_disturbances(world, {"decoys": {**ENTRY, "x": [-1.5, -1.2], "recesses": 3}})


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_hole_smaller_than_the_mav_gets_no_launch_configuration(seed):
    K = CAMERA_INTRINSICS.K
    depth = 0.6
    c_m, pixel_m = mav_contour(depth, K), depth / K[0, 0]
    holes = [(lo, hi) for label, lo, hi in _layout(seed) if "hole" in label]
    assert holes
    for lo, hi in holes:
        mask, _ = rasterised(box(lo[0], lo[2], hi[0], hi[2]), pixel_m)  # the exact opening, not a detected one
        assert profile_analysis(mask, c_m) == []
    roomy, _ = rasterised(box(0.0, 0.0, 0.12, 0.08), pixel_m)  # a little larger than the MAV: it fits
    assert profile_analysis(roomy, c_m)


@pytest.mark.parametrize(("depths", "hollow"), [([0.01, 0.04], False), ([0.08, 0.09], True)])
def test_a_shallow_recess_is_not_a_hollow_candidate_and_a_deep_one_is(depths, hollow):
    entry = {**ENTRY, "holes": 0, "recess_width": [0.25, 0.3], "recess_height": [0.18, 0.22], "recess_depth": depths}
    with World(scene="collapsed_mockup", seed=2) as world:
        apply_disturbances(world, {"decoys": entry})
        recess = world.scene.zones_tagged("recess")[0]
        params = DetectionParams(n_frames=2)
        candidates = detect_apertures(facing_frames(world, float(recess.center[0]), 0.6, 2), params)
    in_recess = [c for c in candidates if recess.contains(c.centre_nav, margin=0.02)]
    assert bool(in_recess) == hollow
    for c in in_recess:
        assert c.depth_beyond_m == pytest.approx(recess.hi[1] - FACE_Y, abs=0.01)


def test_pose_spread_draws_the_start_pose_from_the_seed_and_the_estimate_starts_there():
    mission = load_mission(MISSION)
    centre = np.array(mission.spec.team["mms"].pose)
    spread = np.array(mission.spec.team["mms"].pose_spread)
    poses = []
    for seed in (0, 0, 1):
        world = build_world(mission, seed)
        try:
            mms = world.robot("mms")
            position, orientation = mms.pose()
            yaw = 2.0 * math.atan2(orientation[2], orientation[3])
            pose = np.array([position[0], position[1], yaw])
            assert (np.abs(pose - centre) <= spread + 1e-3).all()
            estimate = mms.estimator.estimate()
            assert np.allclose(estimate.position[:2], position[:2], atol=1e-3)
            poses.append(pose)
        finally:
            world.close()
    assert np.allclose(poses[0], poses[1]) and not np.allclose(poses[0], poses[2])
    assert np.linalg.norm(poses[0][:2] - centre[:2]) > 1e-3  # spread, not the mission's pose
