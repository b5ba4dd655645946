"""Relocalising the MMS against its map: planar point-to-plane ICP (skills/aperture/registration.py).

A synthetic scene in the nav frame: a wall (face at y = 0) with a 0.2 m square
opening and the floor in front of it, sampled every centimetre as M's surface.
A frame's points are the same surfaces sampled on another grid, posed by an
estimate that is off the truth by a known planar error; the registration must
bring the estimate back.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from marsupial.skills.aperture.registration import RegistrationParams, register_planar, register_searched


def _surfaces(step: float, shift: float = 0.0) -> np.ndarray:
    """Wall face (x −0.6…0.6, z 0.2…1.2, an opening x 0…0.2, z 0.6…0.8), the opening's sides into the 0.1 m
    wall (they fix x: a plain wall does not) and the floor (y −0.9…0): points (nav, m) every ``step``."""
    x, z = np.meshgrid(np.arange(-0.6, 0.6, step) + shift, np.arange(0.2, 1.2, step) + shift)
    keep = ~((x > 0.0) & (x < 0.2) & (z > 0.6) & (z < 0.8))
    wall = np.stack((x[keep], np.zeros(keep.sum()), z[keep]), axis=1)
    fx, fy = np.meshgrid(np.arange(-0.6, 0.6, step) + shift, np.arange(-0.9, 0.0, step) + shift)
    floor = np.stack((fx.ravel(), fy.ravel(), np.zeros(fx.size)), axis=1)
    ry, rz = np.meshgrid(np.arange(0.0, 0.1, step) + shift, np.arange(0.6, 0.8, step) + shift)
    sides = [np.stack((np.full(ry.size, x_side), ry.ravel(), rz.ravel()), axis=1) for x_side in (0.0, 0.2)]
    return np.vstack((wall, floor, *sides))


def _posed_by(points: np.ndarray, truth: np.ndarray, true_yaw: float, estimate: np.ndarray, yaw: float
              ) -> np.ndarray:
    """``points`` (true nav positions) as a frame taken at ``truth`` but posed by ``estimate`` shows them."""
    d = yaw - true_yaw
    c, s = math.cos(d), math.sin(d)
    local = points[:, :2] - truth[:2]
    out = points.copy()
    out[:, :2] = estimate[:2] + local @ np.array([[c, s], [-s, c]])
    return out


def test_the_registration_removes_the_odometrys_planar_drift():
    truth, true_yaw = np.array([0.1, -1.4, 0.0]), math.pi / 2
    estimate, yaw = truth + [0.04, -0.06, 0.0], true_yaw + 0.02  # the drift of a 1.5 m drive (4-7.5 cm measured)
    frame = _posed_by(_surfaces(0.013, shift=0.004), truth, true_yaw, estimate, yaw)
    found = register_planar(frame, _surfaces(0.01), estimate)
    assert found is not None and found.pairs > 1000
    position, corrected_yaw = found.apply(estimate, yaw)
    assert np.linalg.norm(position[:2] - truth[:2]) < 0.005, (position, found.summary())
    assert abs(corrected_yaw - true_yaw) < 0.003
    assert found.rms < 0.005


def test_a_frame_that_meets_nothing_of_the_map_is_not_registered():
    far_away = _surfaces(0.02) + [5.0, 5.0, 0.0]
    assert register_planar(far_away, _surfaces(0.01), np.array([5.0, 3.6, 0.0])) is None


def test_a_correction_beyond_the_plausible_drift_is_refused():
    truth, true_yaw = np.array([0.1, -1.4, 0.0]), math.pi / 2
    estimate, yaw = truth + [0.04, -0.06, 0.0], true_yaw + 0.02
    frame = _posed_by(_surfaces(0.013, shift=0.004), truth, true_yaw, estimate, yaw)
    assert register_planar(frame, _surfaces(0.01), estimate, RegistrationParams(max_correction=0.05)) is None
    assert register_planar(frame, _surfaces(0.01), estimate, RegistrationParams(max_correction=0.1)) is not None


@pytest.mark.slow
def test_a_drift_of_a_slipping_wheel_is_found_along_the_heading():
    # the base held by an obstacle while its wheels turned: the odometry ran 0.6 m on along the heading (measured
    # 0.58 and 0.82 m in insertion trials); the plain registration pairs the floor only, the searched one finds it
    truth, true_yaw = np.array([0.1, -1.4, 0.0]), math.pi / 2 + 0.05
    estimate, yaw = truth + [0.6 * math.cos(true_yaw), 0.6 * math.sin(true_yaw), 0.0], true_yaw + 0.004
    frame = _posed_by(_surfaces(0.013, shift=0.004), truth, true_yaw, estimate, yaw)
    reference = _surfaces(0.01)
    plain = register_planar(frame, reference, estimate)
    assert plain is None or plain.pairs < 0.5 * len(frame)
    found = register_searched(frame, reference, estimate, yaw)
    assert found is not None and found.pairs > 0.5 * len(frame)
    position, corrected_yaw = found.apply(estimate, yaw)
    assert np.linalg.norm(position[:2] - truth[:2]) < 0.01, (position, found.summary())
    assert abs(corrected_yaw - true_yaw) < 0.005


def test_the_searched_registration_keeps_a_small_drift_to_the_plain_one():
    truth, true_yaw = np.array([0.1, -1.4, 0.0]), math.pi / 2
    estimate, yaw = truth + [0.04, -0.06, 0.0], true_yaw + 0.02
    frame = _posed_by(_surfaces(0.013, shift=0.004), truth, true_yaw, estimate, yaw)
    plain = register_planar(frame, _surfaces(0.01), estimate)
    searched = register_searched(frame, _surfaces(0.01), estimate, yaw)
    assert plain is not None and searched is not None
    assert np.allclose(plain.translation, searched.translation) and plain.yaw == searched.yaw
