"""The volumetric map M and the log-odds aperture belief L_a (Arora & Papachristos, §IV-C, eq. 1).

Synthetic depth frames of a level camera 1.2 m in front of a 0.1 m wall (face
at y = 0) with two 0.2 m square openings A (left) and B (right), a back wall
at y = 2 m behind them: depth by exact ray casting, nothing else in view.
Then one short ``aperture_scan`` run of the MMS in ``collapsed_mockup``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Point
from skill_harness import Harness

from marsupial.skills.aperture.belief import ApertureBelief, BeliefParams, aperture_region
from marsupial.skills.aperture.detection import DepthFrame, DetectionParams, detect_apertures
from marsupial.skills.aperture.ranking import associate, rank_apertures
from marsupial.skills.aperture.scan import ApertureScan
from marsupial.skills.aperture.volumetric import FREE, OCCUPIED, UNKNOWN, VolumetricMap, sensor_cloud, voxel_centres
from marsupial.world import World
from marsupial.world.apertures import aperture_outline

RESOLUTION = 0.03
WALL_Y, WALL_T, BACK_Y = 0.0, 0.1, 2.0
HOLES = {"A": ((-0.45, -0.25), (0.7, 0.9)), "B": ((0.25, 0.45), (0.7, 0.9))}  # x and z ranges (m)
R_NAV_OPTICAL = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # looking along +y, level
K = np.array([[216.0, 0.0, 160.0], [0.0, 216.0, 120.0], [0.0, 0.0, 1.0]])


def _frame(x: float = 0.0) -> DepthFrame:
    """A 320×240 depth frame from (x, -1.2, 0.8) looking at the wall."""
    origin = np.array([x, WALL_Y - 1.2, 0.8])
    v, u = np.mgrid[0:240, 0:320]
    rays = np.stack(((u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones(u.shape)), axis=-1) @ R_NAV_OPTICAL.T
    depth = (WALL_Y - origin[1]) / rays[..., 1]  # to the wall face, along the optical axis
    face = origin + depth[..., None] * rays
    through = np.zeros(depth.shape, bool)
    for (x0, x1), (z0, z1) in HOLES.values():
        through |= (face[..., 0] > x0) & (face[..., 0] < x1) & (face[..., 2] > z0) & (face[..., 2] < z1)
    depth = np.where(through, (BACK_Y - origin[1]) / rays[..., 1], depth)
    return DepthFrame(depth.astype(np.float32), K, origin, R_NAV_OPTICAL, far=10.0)


def _region(name: str, d_a: float) -> np.ndarray:
    """Points filling hole ``name`` from the face to ``d_a`` behind it (nav frame, m)."""
    (x0, x1), (z0, z1) = HOLES[name]
    x, y, z = np.meshgrid(np.arange(x0 + 0.02, x1 - 0.02, 0.01), np.arange(WALL_Y, WALL_Y + d_a, 0.01),
                          np.arange(z0 + 0.02, z1 - 0.02, 0.01))
    return np.stack((x.ravel(), y.ravel(), z.ravel()), axis=1)


def _mean_l_a(belief: ApertureBelief, occupancy: VolumetricMap, name: str) -> float:
    voxels = voxel_centres(_region(name, belief.params.d_a), RESOLUTION)
    voxels = voxels[occupancy.state(voxels) == FREE]
    assert len(voxels) > 10
    return float(np.nan_to_num(belief.log_odds(voxels)).mean())


def test_the_map_marks_the_wall_occupied_the_space_in_front_free_and_behind_it_unknown():
    occupancy = VolumetricMap(RESOLUTION)
    occupancy.insert(sensor_cloud(_frame()))
    wall = [[0.0, WALL_Y + 0.01, 0.5], [0.1, WALL_Y + 0.01, 1.2], [-0.6, WALL_Y + 0.01, 0.3]]
    in_front = [[0.0, -0.6, 0.8], [0.2, -0.3, 0.6], [-0.1, -0.9, 0.9]]
    behind_wall = [[0.0, 0.5, 0.4], [0.0, 1.0, 1.2]]  # shadowed by the wall: no ray reaches them
    through_a_hole = [[-0.35, 0.05, 0.8], [-0.35 * 2.2 / 1.2, 1.0, 0.8]]  # on the ray through A's centre
    back_wall = [[-0.35 * 3.2 / 1.2, BACK_Y - 0.005, 0.8]]  # where that ray ends
    assert (occupancy.state(np.array(wall)) == OCCUPIED).all()
    assert (occupancy.state(np.array(in_front)) == FREE).all()
    assert (occupancy.state(np.array(behind_wall)) == UNKNOWN).all()
    assert (occupancy.state(np.array(through_a_hole)) == FREE).all()
    assert (occupancy.state(np.array(back_wall)) == OCCUPIED).all()


@pytest.mark.slow
def test_a_consistent_aperture_ranks_above_an_erratic_one():
    occupancy, belief = VolumetricMap(RESOLUTION), ApertureBelief(RESOLUTION)
    params = belief.params
    a, b = _region("A", params.d_a), _region("B", params.d_a)
    after_b_hits = None
    for i in range(6):
        cloud = sensor_cloud(_frame(x=0.02 * i))
        occupancy.insert(cloud)
        detected_b = i % 3 == 0  # B in a third of the frames, A in every one
        belief.update(cloud, [a, b] if detected_b else [a], occupancy)
        if i == 0:
            after_b_hits = _mean_l_a(belief, occupancy, "B")
    l_hit = np.log(params.p_hit / (1 - params.p_hit))
    l_miss = np.log(params.p_miss / (1 - params.p_miss))
    clamp = np.log(params.p_max / (1 - params.p_max))
    assert after_b_hits == pytest.approx(l_hit, abs=1e-3)  # one hit, not a hit plus the ray's miss
    assert _mean_l_a(belief, occupancy, "A") == pytest.approx(min(6 * l_hit, clamp), abs=1e-3)
    # B: two hits and four misses from the rays through it
    assert _mean_l_a(belief, occupancy, "B") == pytest.approx(2 * l_hit + 4 * l_miss, abs=0.05)

    # ranked as tracks; a track that no frame saw free scores -inf
    wall_patch = np.array([[0.0, WALL_Y + 0.05, 0.3]])  # inside the wall: never free
    candidates = detect_apertures([_frame()], DetectionParams(n_frames=1))
    assert len(candidates) == 2
    tracks: list = []
    for c in candidates:
        associate(tracks, c, b if c.centre_nav[0] > 0 else a, radius=0.1)
    ranked = rank_apertures(tracks, belief, occupancy)
    assert [r.centre_nav[0] < 0 for r in ranked] == [True, False]  # A first
    assert ranked[0].score > ranked[1].score + 2.0
    tracks[0].region_nav = wall_patch
    assert rank_apertures(tracks, belief, occupancy)[-1].score == -np.inf


def test_a_detections_region_fills_its_opening_from_the_face_to_d_a_behind_it():
    params = BeliefParams()
    candidates = detect_apertures([_frame()], DetectionParams(n_frames=1))
    assert len(candidates) == 2
    for candidate in candidates:
        name = "A" if candidate.centre_nav[0] < 0 else "B"
        (x0, x1), (z0, z1) = HOLES[name]
        region = aperture_region(candidate, RESOLUTION, params.d_a)
        assert region[:, 0].min() > x0 - 1e-3 and region[:, 0].max() < x1 + 1e-3
        assert region[:, 2].min() > z0 - 1e-3 and region[:, 2].max() < z1 + 1e-3
        assert region[:, 1].min() == pytest.approx(WALL_Y, abs=2e-3)
        assert region[:, 1].max() == pytest.approx(WALL_Y + params.d_a, abs=2e-3)
        # most of the opening (the detected contour lies two or three pixels inside it: 0.74 measured)
        span = (region[:, 0].max() - region[:, 0].min()) * (region[:, 2].max() - region[:, 2].min())
        assert span > 0.65 * (x1 - x0) * (z1 - z0)


@pytest.mark.slow
def test_aperture_scan_in_collapsed_mockup_ranks_the_opening_it_faces_first():
    """One sweep of five pan poses 1.3 m from the wall, facing the amoeba opening; the collapsed and U openings
    drift in and out of view and the orthogonal one is at the edge: all are real, the faced one is the most
    consistently seen."""
    with World(scene="collapsed_mockup", seed=5) as world:
        world.add_robot("mms", "mms", pose=[0.3, -0.05 - 1.3 - 1.057, math.pi / 2])
        harness = Harness(world)
        node = harness.node(ApertureScan, robot="mms")
        assert harness.run(node, 30.0).name == "SUCCESS", node.feedback_message
        ranked = harness.blackboard("mms/apertures")
    outlines = {s: aperture_outline(s) for s in ("orthogonal", "collapsed", "amoeba", "u")}
    best = ranked[0]
    assert outlines["amoeba"].contains(Point(best.m_A[0], best.m_A[2]))
    assert -0.05 <= best.m_A[1] <= 0.05  # inside the wall's thickness: the see-through region
    assert best.score > ranked[1].score
    for r in ranked:  # each candidate's m_A lies in a real opening (the U's centroid does not: it is on the tongue)
        assert any(o.buffer(0.02).contains(Point(r.m_A[0], r.m_A[2])) for o in outlines.values()), r.summary()
