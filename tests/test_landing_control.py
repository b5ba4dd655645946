"""Height-adaptive PI, Kalman prediction and platform tracking of Palafox et al. (2019), §3.3 (numpy only)."""

import math

import numpy as np
import pytest

from marsupial.api.errors import UnknownNameError
from marsupial.skills.landing.control import HeightAdaptivePI, PIGains, PlatformTracker
from marsupial.skills.landing.prediction import KalmanParams, PlatformPredictor

CAMERA_HZ = 30.0  # AR.Drone 2 bottom camera of the world


def test_fitted_gains_at_the_tracking_height_and_at_the_platform():
    gains = PIGains()
    assert gains.at(0.0) == pytest.approx((0.7, 0.2))  # Q_p, Q_i
    assert gains.at(4.0) == pytest.approx((0.45, 0.1))  # tuned at the 4 m tracking height
    assert (gains.T_p, gains.T_i) == pytest.approx((0.1105, 0.1733), abs=1e-4)  # 1/m
    assert gains.at(-0.2) == gains.at(0.0)
    kp, ki = zip(*(gains.at(h) for h in np.linspace(0.0, 4.0, 9)), strict=True)
    assert np.all(np.diff(kp) < 0) and np.all(np.diff(ki) < 0)  # faster response closer to the platform
    printed = PIGains(T_p=0.002, T_i=0.002)  # the printed law with p_z in metres: Table 1
    assert printed.at(4.0) == pytest.approx((0.694, 0.198), abs=5e-4)
    assert printed.at(2.0) == pytest.approx((0.697, 0.199), abs=5e-4)


def test_pi_speed_limit_and_anti_windup():
    pi = HeightAdaptivePI(max_speed=3.0)
    for _ in range(1000):  # 100 s far away: saturated
        command = pi.step([50.0, 0.0], 4.0, 0.1)
        assert np.hypot(*command) == pytest.approx(3.0)
    assert pi.gains.at(4.0)[1] * np.hypot(*pi.integral) <= 3.0 + 1e-9
    command = pi.step([-1.0, 0.0], 4.0, 0.1)  # overshoot: the command reverses at once
    assert command[0] < 0.0
    pi.reset()
    assert pi.step([1.0, -2.0], 0.0, 0.0) == pytest.approx([0.7, -1.4])  # K_p(0) e, empty integral


def test_kalman_prediction_leads_a_linear_track_by_v_times_path_time():
    for path_time, lead in ((0.1, 0.05), (0.2, 0.10)):
        predictor = PlatformPredictor(KalmanParams(path_time_s=path_time))
        fused = []
        for k in range(int(10.0 * CAMERA_HZ)):
            t = k / CAMERA_HZ
            truth = np.array([1.0 + 0.5 * t, -2.0])  # 0.5 m/s along world x
            fused.append(predictor.observe(t, truth))
            if t > 5.0:  # converged
                assert predictor.predicted(t) - truth == pytest.approx([lead, 0.0], abs=0.01)
        assert sum(fused) == pytest.approx(10.0 / 0.1, abs=1)  # one fused frame per 0.1 s step
        assert predictor.filter.velocity == pytest.approx([0.5, 0.0], abs=0.01)
    assert PlatformPredictor().predicted(0.0) is None


def _track(mode, platform, latency=0.0, **options):
    """Kinematic closed loop, numpy only: the UAV flies its velocity command through a first-order lag.

    The camera measures the platform at 30 Hz (time-stamped at capture,
    available ``latency`` s later); the tracker commands at 30 Hz at 4 m
    height; the UAV starts 1 m behind. Returns times and platform - UAV errors (world, m).
    """
    dt, tau, steps_per_frame = 1.0 / 120.0, 0.25, 4
    tracker = PlatformTracker(mode, **options)
    p_uav, v_uav, command = np.array([-1.0, 0.0]), np.zeros(2), np.zeros(2)
    delay = round(latency / dt)
    times, errors = [], []
    for k in range(int(60.0 / dt)):
        t = k * dt
        if k % steps_per_frame == 0:
            if k >= delay:
                tracker.observe((k - delay) * dt, platform((k - delay) * dt))
            command = tracker.command(t, p_uav, 0.0, 4.0)
        v_uav = v_uav + (command - v_uav) * dt / tau
        p_uav = p_uav + v_uav * dt
        times.append(t + dt)
        errors.append(platform(t + dt) - p_uav)
    return np.array(times), np.array(errors)


def _linear(t):
    return np.array([0.5 * t, 0.0])


def _circle(t, v=0.5, omega=0.05):
    r = v / omega
    return np.array([r * math.sin(omega * t), r * (1.0 - math.cos(omega * t))])


def test_pi_converges_on_a_constant_velocity_platform():
    for latency in (0.0, 0.1):
        t, e = _track("reactive", _linear, latency)
        steady = e[t > 40.0]
        # type-2 loop: the integral supplies the platform speed, only the measurement age is left (v · latency)
        assert np.abs(steady[:, 0] - 0.5 * latency).max() < 0.01 and np.abs(steady[:, 1]).max() < 1e-9
        t, e = _track("predictive", _linear, latency)
        steady = e[t > 40.0]
        # time-stamped prediction: the UAV holds the point one path time ahead, whatever the latency
        assert np.abs(steady[:, 0] + 0.05).max() < 0.005
        t, e = _track("predictive", _linear, latency, kalman=KalmanParams(path_time_s=0.0))
        assert np.abs(e[t > 40.0, 0]).max() < 0.005  # zero steady-state error


def test_circular_track_lag_and_velocity_feedforward():
    t, e = _track("reactive", _circle)
    lag = np.hypot(*e[t > 40.0].T)
    assert lag.mean() == pytest.approx(0.5 * 0.05 / 0.1, rel=0.1)  # v ω / K_i(4 m)
    t, e = _track("predictive", _circle, 0.1, kalman=KalmanParams(path_time_s=0.0), velocity_feedforward=True)
    assert np.hypot(*e[t > 40.0].T).max() < 0.03


def test_command_in_the_heading_frame():
    tracker = PlatformTracker("reactive")
    assert tracker.command(0.0, [0.0, 0.0, 4.0], 0.0, 4.0) == pytest.approx([0.0, 0.0])  # nothing seen yet
    tracker.observe(0.0, [1.0, 3.0, 0.4])
    command = tracker.command(0.0, [1.0, 2.0, 4.4], math.pi / 2, 4.0)  # heading +y: platform straight ahead
    assert command == pytest.approx([0.45, 0.0])
    tracker.reset()
    assert tracker.target(0.0) is None


def test_bad_tracker_options():
    with pytest.raises(UnknownNameError, match="Did you mean 'predictive'"):
        PlatformTracker("predicitve")
    with pytest.raises(ValueError, match="mode='predictive'"):
        PlatformTracker("reactive", velocity_feedforward=True)
    with pytest.raises(ValueError, match="step_s"):
        KalmanParams(step_s=0.0)
