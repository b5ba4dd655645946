"""The landing tracking module on onboard data only, and the touchdown test at every tick rate (Palafox et al. 2019)."""

import math

import numpy as np
import pytest

from marsupial.geometry import heading_rotation, rotation_matrix, yaw_of
from marsupial.skills.landing.touchdown import TouchdownParams, TouchdownTest
from marsupial.skills.landing.tracking import StampedHistory, TrackingModule
from marsupial.tools.rig import live_view
from marsupial.trees.skill import RunContext
from marsupial.world import World

IMU_HZ = 200.0  # AR.Drone 2 IMU rate of the world model
UGV_POSE = [0.3, -0.2, 0.4]
UAV_OFFSET = (0.25, -0.15)  # m, UAV from the platform centre


def test_stamped_history_returns_the_value_nearest_a_stamp():
    history = StampedHistory(span_s=1.0)
    assert history.nearest(0.0) is None
    for k in range(31):
        history.add(k / 10.0, k)
    assert history.nearest(2.04) == 20 and history.nearest(2.06) == 21  # nearest, not the newest
    assert history.nearest(9.0) == 30 and history.nearest(-5.0) == 20  # clamped to the span kept (last 1 s)
    history.add(2.5, -1)  # out of order: ignored
    history.add(3.0, 99)  # same stamp: replaced
    assert history.nearest(3.0) == 99 and history.nearest(2.5) == 25


def _module(world: World, uav: str = "uav") -> TrackingModule:
    """The tracking module on ``uav``'s view read live from ``world``; set ``module.context.now`` before updates."""
    return TrackingModule(live_view(world, uav), live_view(world, "ugv").platform_size, RunContext())


def test_frames_are_posed_with_the_estimate_and_the_urdf_mount_not_the_true_camera_pose():
    with World(scene="open_field", seed=0) as world:
        ugv = world.add_robot("summit_xl", "ugv", pose=UGV_POSE)
        p_platform, _ = ugv.platform_pose()
        pose = [p_platform[0] + UAV_OFFSET[0], p_platform[1] + UAV_OFFSET[1], p_platform[2] + 2.0, 0.6]
        uav = world.add_robot("ardrone2", "uav", pose=pose)
        module = _module(world)
        world.step(0.5)
        module.context.now = world.now
        module.update()
        camera = module.camera_pose(world.now)
        estimate = module.estimate
        # camera pose relative to the estimated base = the camera's mount relative to the true base
        p_true, q_true = uav.pose()
        p_optical, R_optical = uav.sensor("bottom_camera").optical_pose()
        R_est, R_true = rotation_matrix(estimate.orientation), rotation_matrix(q_true)
        assert R_est.T @ (camera.position - estimate.position) == pytest.approx(
            R_true.T @ (p_optical - p_true), abs=1e-6
        )
        assert R_est.T @ camera.rotation == pytest.approx(R_true.T @ R_optical, abs=1e-6)
        # the sonar's plane is the platform's top: the camera's height above it within the sonar noise
        assert camera.position[2] - camera.z_plane == pytest.approx(p_optical[2] - p_platform[2], abs=0.05)
        # a located platform: its offset from the UAV in the heading frame, from onboard data
        for _ in range(4):
            world.step(1.0 / 30.0)
            module.context.now = world.now
            module.update()
        assert module.located >= 1
        expected = heading_rotation(yaw_of(q_true)) @ (p_platform[:2] - p_true[:2])
        assert module.offset == pytest.approx(expected, abs=0.05)


def _vibration(t: np.ndarray, rng: np.random.Generator, rms: float, touchdown: float) -> np.ndarray:
    """A rider's specific force (m/s², body frame): descending until ``touchdown`` (s), an impact, then riding a
    platform that shakes it along x at 11–29 Hz with ``rms`` (0: the ground), plus noise and a constant bias."""
    riding = t >= touchdown
    fx = np.where(
        riding, rms * (np.sin(2 * math.pi * 11.0 * t) + 0.8 * np.sin(2 * math.pi * 29.2 * t + 1.0)) / 0.9, 0.0
    )
    fz = np.full_like(t, 9.81)
    impact = (t >= touchdown) & (t < touchdown + 0.01)
    fz[impact] = 150.0
    fx[impact] = 1.7  # the touchdown rocks the vehicle, whatever it lands on
    bias = np.array([0.05, -0.07, 0.0])
    return np.c_[fx, np.zeros_like(t), fz] + bias + rng.normal(0.0, 0.05, (len(t), 3))


def _verdict(tick_hz: float, rms: float, seed: int = 0, touchdown: float = 0.27) -> tuple[str, float, int]:
    """Drive a :class:`TouchdownTest` with the sonar low from t = 0 and the IMU at its rate; ticks at ``tick_hz``."""
    rng = np.random.default_rng(seed)
    stamps = np.arange(0.0, 3.0, 1.0 / IMU_HZ)
    forces = _vibration(stamps, rng, rms, touchdown)
    test, k = TouchdownTest(), 0
    for tick in np.arange(0.0, 3.0, 1.0 / tick_hz):
        n = int(np.searchsorted(stamps, tick + 1e-9, side="right"))
        new = [(float(s), f) for s, f in zip(stamps[k:n], forces[k:n], strict=True)]
        k = n
        verdict = test.update(float(tick), 0.2, new)
        if verdict is not None:
            return verdict, float(tick), test.samples
    raise AssertionError("no verdict")


@pytest.mark.parametrize("tick_hz", [10.0, 30.0, 60.0])
def test_touchdown_verdict_is_the_same_at_every_tick_rate(tick_hz):
    # riding the platform (vibration RMS 0.35 m/s²) and resting on the ground (noise and bias only)
    p = TouchdownParams()
    ready = 0.27 + p.settle_s + p.evidence_s  # touchdown, settling, evidence
    for seed in range(5):
        verdict, t, samples = _verdict(tick_hz, 0.35, seed)
        assert verdict == "platform"
        assert ready <= t < ready + 1.0 / tick_hz + 1e-9  # the first tick with the evidence complete
        assert samples >= p.evidence_s * IMU_HZ  # every IMU sample of the evidence, not one per tick
        assert _verdict(tick_hz, 0.0, seed)[0] == "ground"  # the impact's rocking is not taken for motion


def test_touchdown_waits_for_a_persistent_low_sonar():
    test = TouchdownTest()
    force = np.array([0.5, 0.0, 9.81])
    assert test.update(0.0, 0.25, [(0.0, force)]) is None
    assert test.update(0.2, 0.4, [(0.2, force)]) is None  # the sonar rose: the window restarts
    assert test.since is None and test.samples == 0
    samples = [(0.3 + k / IMU_HZ, force * [1 - 2 * (k % 2), 1, 1]) for k in range(81)]  # ±0.5 m/s² along x
    assert test.update(0.3, 0.25, samples[:1]) is None
    assert test.update(0.6, 0.25, samples[1:61]) is None  # held long enough, but no impact: evidence from 0.4 s on
    assert test.update(0.7, 0.25, samples[61:]) == "platform" and test.ride_rms == pytest.approx(0.5, abs=0.01)
    with pytest.raises(ValueError, match="min_samples"):
        TouchdownParams(min_samples=0)
