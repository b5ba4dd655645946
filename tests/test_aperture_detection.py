"""Aperture detection (Arora & Papachristos, §IV-B) on depth frames rendered by the MMS's eye-in-hand camera.

The MMS stands in ``collapsed_mockup`` 0.6 m in front of one aperture, its
camera level and facing the wall; three depth frames are posed through its
onboard interface (base estimate, arm encoders, URDF model) and nothing
else. The model plane must be the wall (normal -y) and the candidate the
opening, as the scene defines them; the profile analysis on that candidate
must place the MAV inside the true opening.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mms_frames import WALL_FACE_Y, facing_frames
from shapely.geometry import Polygon

from marsupial.skills.aperture import mav_contour, profile_analysis
from marsupial.skills.aperture.detection import DetectionParams, detect_apertures
from marsupial.world import World
from marsupial.world.apertures import aperture_outline

STANDOFF_M = 0.6


def _frames(x: float, standoff: float, count: int):
    """``count`` posed depth frames of the MMS facing the wall at ``x`` (m) from ``standoff`` (m)."""
    with World(scene="collapsed_mockup", seed=5) as world:
        return facing_frames(world, x, standoff, count)


@pytest.mark.parametrize("shape", ["orthogonal", "collapsed", "amoeba", "u"])
def test_the_wall_and_the_aperture_are_found_where_the_scene_has_them(shape):
    outline = aperture_outline(shape)
    params = DetectionParams(n_frames=3)
    candidates = detect_apertures(_frames(outline.centroid.x, STANDOFF_M, params.n_frames), params)
    assert candidates, "no aperture detected"
    found = candidates[0]  # the largest
    n = found.normal_nav
    assert math.degrees(math.acos(np.clip(n @ [0.0, -1.0, 0.0], -1, 1))) < 1.0  # the wall faces -y
    assert found.view.plane_depth == pytest.approx(STANDOFF_M, abs=0.01)
    centre = found.centre_nav
    assert centre[1] == pytest.approx(WALL_FACE_Y, abs=0.01)
    assert np.hypot(centre[0] - outline.centroid.x, centre[2] - outline.centroid.y) < 0.01
    assert found.depth_beyond_m > params.d_c
    pixel_m = found.view.plane_depth / found.view.K[0, 0]
    assert 0.75 < found.area_px * pixel_m**2 / outline.area <= 1.02  # the contour hugs the opening, inside it

    # the profile analysis on the detected contour puts the MAV inside the true opening
    c_m = mav_contour(found.view.plane_depth, found.view.K)
    valid = profile_analysis(found.mask(), c_m)
    assert valid
    for config in valid:
        placed = found.frame.to_nav(found.view.pixel_to_I(config.placed(c_m)))
        assert np.allclose(placed[:, 1], WALL_FACE_Y, atol=0.01)
        assert outline.contains(Polygon(placed[:, [0, 2]])), config


def test_a_plain_wall_has_no_aperture():
    # 0.15 m from the wall between two openings: x -0.71 … -0.49 in view (the orthogonal one ends at -0.78,
    # the collapsed one starts at -0.45)
    assert detect_apertures(_frames(-0.6, 0.15, 1), DetectionParams(n_frames=1)) == []
