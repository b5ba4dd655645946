"""The estimate frame's motion when the UAV's optical flow changes surfaces, and the below-0.7 m abort (landing)."""

import math

import numpy as np

from marsupial.skills.landing.flowframe import FrameShift, flow_surface, rays_on_platform
from marsupial.skills.landing.tracking import TrackingModule

HALF_ANGLE = math.radians(15.0)  # the flow field of the world's sensor (its port's static fact ``half_angle``)
LEVEL = np.eye(3)


def test_the_flow_rays_meet_a_1_m_platform_below_a_height_set_by_the_field_and_the_heading():
    centred = dict(origin_xy=np.zeros(2), platform_xy=np.zeros(2), half_side=0.5)
    # aligned: the corner rays leave the platform at h·tan 15° = 0.5 m, i.e. h = 1.87 m
    assert rays_on_platform(HALF_ANGLE, LEVEL, height=1.8, platform_yaw=0.0, **centred) == 5
    assert rays_on_platform(HALF_ANGLE, LEVEL, height=1.95, platform_yaw=0.0, **centred) == 1
    # at 45° the corners point along the platform's axes: √2·h·tan 15° = 0.5 m at h = 1.32 m
    assert rays_on_platform(HALF_ANGLE, LEVEL, height=1.4, platform_yaw=math.pi / 4, **centred) == 1
    assert rays_on_platform(HALF_ANGLE, LEVEL, height=1.25, platform_yaw=math.pi / 4, **centred) == 5
    # 0.4 m off the centre at 1 m: the centre ray and the two corners on the platform's side
    off = dict(centred, platform_xy=np.array([0.4, 0.0]))
    assert rays_on_platform(HALF_ANGLE, LEVEL, height=1.0, platform_yaw=0.0, **off) == 3
    # at 1.85 m the corners are 0.01 m inside the edges: the median follows the platform, but only just
    assert flow_surface(HALF_ANGLE, LEVEL, np.zeros(2), 1.85, np.zeros(2), 0.0, 0.5) == (True, True)
    assert flow_surface(HALF_ANGLE, LEVEL, np.zeros(2), 4.0, np.zeros(2), 0.0, 0.5) == (False, False)
    assert flow_surface(HALF_ANGLE, LEVEL, np.zeros(2), 0.8, np.zeros(2), 0.0, 0.5) == (True, False)


def _imu(t0, t1, force_xy, rate=200.0):
    return [(t, np.array([force_xy[0], force_xy[1], 9.81])) for t in np.arange(t0, t1, 1.0 / rate)[1:]]


def test_the_frame_shift_is_the_flow_made_part_of_the_estimated_velocity_change():
    shift, bias = FrameShift(settle_s=0.4), np.array([0.05, -0.03])  # the IMU's bias (m/s²), no true acceleration
    t, v = 0.0, np.array([0.5, 0.0])  # the UAV flies with the platform at 0.5 m/s over the floor
    assert not shift.step(t, v, LEVEL, _imu(-0.1, 0.0, bias), switching=False).any()
    for _ in range(300):  # 10 s outside any window: the bias is learnt, nothing is shifted
        assert not shift.step(t + 1 / 30, v, LEVEL, _imu(t, t + 1 / 30, bias), switching=False).any()
        t += 1 / 30
    np.testing.assert_allclose(shift.bias, bias, atol=0.005)
    total = np.zeros(2)
    for k in range(30):  # the flow meets the platform: the estimate falls to 0 with the estimator's 8 /s
        v_next = np.array([0.5, 0.0]) * math.exp(-8.0 * (k + 1) / 30)
        total += shift.step(t + 1 / 30, v_next, LEVEL, _imu(t, t + 1 / 30, bias), switching=k < 10)
        t += 1 / 30
    np.testing.assert_allclose(total, [-0.5, 0.0], atol=0.01)  # the platform's frame velocity: -0.5 m/s
    assert not shift.active(t)  # 0.4 s after the last possible switch


class _Stub:
    """What :meth:`TrackingModule.relocalization_due` reads of the module."""

    relocalization_due = TrackingModule.relocalization_due

    def __init__(self, height, offset_height):
        self.state, self.pending_relocalization, self.last_seen, self.now = "landing", None, 10.0, 10.1
        self.offset, self.offset_at, self.offset_height, self.height = np.array([0.3, 0.0]), 10.0, offset_height, height


def test_the_error_abort_fires_below_the_final_height_with_a_location_from_just_above_it():
    # the platform fills the view below ≈0.72 m: the last location is taken above 0.7 m (§3.3.1's rule)
    assert _Stub(height=0.65, offset_height=0.72).relocalization_due(0.5, 0.25, 0.7).startswith("error 0.30 m")
    assert _Stub(height=0.9, offset_height=0.92).relocalization_due(0.5, 0.25, 0.7) is None  # not down there yet
