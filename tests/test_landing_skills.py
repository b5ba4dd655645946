"""Landing skills of Palafox et al. (2019) in full runs, checked from the MCAP log: cycle, re-localisation, ground."""

import numpy as np
import pytest
from pydantic import ValidationError

from marsupial.geometry import heading_rotation, yaw_of
from marsupial.skills.landing.skills import DrivePattern, FlightParams, Land
from marsupial.trees.mission import parse_mission
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission

PLATFORM_TOP = 0.40  # m, summit_xl platform surface
LANDED_HEIGHT = 0.061  # m, ardrone2 base above what it stands on


def _states(log):
    return [(e["t"], e["state"], e["why"]) for e in log.events if e["kind"] == "state_change" and "state" in e]


def _run(tmp_path, mission, **overrides):
    log_path = tmp_path / "run.mcap"
    result = run_mission(
        mission, log_path=log_path, progress=False, overrides={k: str(v) for k, v in overrides.items()}
    )
    return result, read_log(log_path)


def _landing_offset(log):
    """True platform centre minus UAV (heading frame, m) when the UAV was declared landed (scoring, from the log)."""
    t_landed = next(t for t, s, _ in _states(log) if s == "landed")
    t, uav, q = log.poses("uav", orientation=True)
    _, ugv = log.poses("ugv")  # the platform's centre is above the UGV's base
    i = min(np.searchsorted(t, t_landed), len(t) - 1)
    return heading_rotation(yaw_of(q[i])) @ (ugv[i, :2] - uav[i, :2])


def _assert_rides_the_platform(log):
    _, uav = log.poses("uav")
    _, ugv = log.poses("ugv")
    assert np.hypot(*(uav[-1, :2] - ugv[-1, :2])) < 0.25  # on the 1 m platform, inside the abort threshold
    assert uav[-1, 2] == pytest.approx(PLATFORM_TOP + LANDED_HEIGHT, abs=0.02)  # resting on it, not on the ground
    _, landed = log.metric("landed", robot="uav")
    assert landed.tolist() == [1.0]


@pytest.mark.slow
def test_one_cycle_on_the_circular_track_lands_on_the_platform(tmp_path):
    result, log = _run(tmp_path, "landing_circular", **{"cycle.land_after": 2.0})
    assert result.outcome == "success" and log.outcome == "success"
    states = [s for _, s, _ in _states(log)]
    assert states == ["taking_off", "tracking", "landing", "landed"]  # the paper's state machine, §3.1
    _assert_rides_the_platform(log)
    assert np.hypot(*_landing_offset(log)) < 0.1
    t, height = log.poses("uav")
    takeoff_end = next(t for t, s, _ in _states(log) if s == "tracking")
    assert height[np.searchsorted(t, takeoff_end), 2] - PLATFORM_TOP == pytest.approx(4.0, abs=0.25)  # nominal height


@pytest.mark.slow
def test_an_occluded_platform_triggers_relocalize_and_the_cycle_completes(tmp_path):
    occlusion = "{occlusion: {robot: ugv, link: landing_platform, start: 6.0, duration: 1.5}}"
    result, log = _run(tmp_path, "landing_circular", **{"cycle.land_after": 2.0, "world.disturbances": occlusion})
    assert result.outcome == "success"
    states = _states(log)
    relocalizing = [(t, why) for t, s, why in states if s == "relocalizing"]
    assert len(relocalizing) == 1
    t_lost, why = relocalizing[0]
    # 0.5 s after the last frame before the occlusion arrived (the predictive controller reads one per 0.1 s), §3.1
    assert 6.4 <= t_lost <= 6.7 and why.startswith("platform unseen for")
    preemptions = [e for e in log.events if e["kind"] == "preemption"]
    assert preemptions and preemptions[0]["by"] == "re-localizing"
    after = [s for t, s, _ in states if t > t_lost]
    assert after == ["tracking", "landing", "landed"]  # seen again, tracked back up, landed
    _, count = log.metric("relocalizations", robot="uav")
    assert count.tolist() == [1.0]
    _assert_rides_the_platform(log)


@pytest.mark.slow
def test_at_10_hz_with_gusts_the_uav_lands_on_the_moving_platform(tmp_path):
    # the touchdown test reads every IMU sample of its window, not one per tick: at a 10 Hz tick rate the
    # platform's vibration is not aliased away into "landed on the ground" (§3.3.1)
    gusts = "{wind: {gust: 3.0}}"
    overrides = {"cycle.land_after": 2.0, "run.tick_hz": 10, "world.disturbances": gusts}
    result, log = _run(tmp_path, "landing_circular", **overrides)
    assert result.outcome == "success"
    outcome = next(e for e in log.events if e["kind"] == "outcome" and e["skill"] == "land")
    assert outcome["status"] == "SUCCESS" and "landed on the moving platform" in outcome["message"]
    assert "ground_landing" not in {m["name"] for m in log.metrics}
    _assert_rides_the_platform(log)


# the UGV never drives: its platform is as still as the ground (a driven Summit XL shakes its rider even at 1 mm/s)
STILL_PLATFORM = """
mission: still_platform
world: {scene: open_field, seed: 0}
team:
  ugv: {robot: summit_xl, pose: [0, 0, 0]}
  uav: {robot: ardrone2, pose: [0, 0, 0.466, 0], options: {motors_on: false}}
run: {tick_hz: 30, until: 60}
tree:
  subtree: landing_cycle
  params: {uav: uav, platform: ugv, land_after: 0.5, land_after_since: tracking, tracker: {nominal_height: 2.0}}
"""


@pytest.mark.slow
@pytest.mark.parametrize("tick_hz", [10, 30])
def test_a_still_platform_feels_like_the_ground_and_the_landing_fails(tmp_path, tick_hz):
    # the landed test needs the IMU to feel the moving platform (§3.3.1): on a still one it reports the ground
    mission = parse_mission(STILL_PLATFORM, "still_platform.yaml", {"run.tick_hz": str(tick_hz)})
    result = run_mission(mission, log_path=tmp_path / "run.mcap", progress=False)
    log = read_log(tmp_path / "run.mcap")
    assert result.outcome == "failure"
    outcome = next(e for e in log.events if e["kind"] == "outcome" and e["skill"] == "land")
    assert outcome["status"] == "FAILURE" and "landed on the ground" in outcome["message"]
    _, ground = log.metric("ground_landing", robot="uav")
    assert ground.tolist() == [1.0]


def test_an_empty_battery_ends_the_cycle_with_a_failure(tmp_path):
    result, log = _run(tmp_path, "landing_lifelong", cycles=1, **{"team.uav.options.battery_capacity_mAh": 1})
    assert result.outcome == "failure"  # not a run that hangs until its time limit
    outcome = next(e for e in log.events if e["kind"] == "outcome" and e["skill"] == "takeoff")
    # the gauge's last sample (1 Hz) may predate the last milliamp-hour: the failure names what it read
    assert outcome["status"] == "FAILURE" and outcome["message"].startswith("motors stopped, battery at ")


def test_flight_params_resolve_the_controller_variants():
    ours = FlightParams().tracker_config()
    assert (ours.mode, ours.gain_schedule, ours.velocity_feedforward, ours.path_time_s, ours.integral_band) == (
        "predictive", "table1", True, 0.0, 0.1)
    paper = FlightParams(velocity_feedforward=False).tracker_config()
    assert (paper.velocity_feedforward, paper.path_time_s, paper.integral_band) == (False, 0.1, None)  # §3.3.2
    reactive = FlightParams(mode="reactive").tracker_config()
    assert (reactive.mode, reactive.velocity_feedforward, reactive.integral_band) == ("reactive", False, None)
    assert paper.build(max_speed=3.0).pi.gains.at(4.0) == pytest.approx((0.694, 0.198), abs=5e-4)  # Table 1
    manual = FlightParams(gain_schedule="manual_fit").tracker_config().build(max_speed=3.0)
    assert manual.pi.gains.at(4.0) == pytest.approx((0.45, 0.1)) and manual.pi.max_speed == 3.0
    land = Land.Params()
    assert (land.descent_speed, land.final_height, land.final_speed) == (0.3, 0.7, 2.0)  # §3.3.1
    with pytest.raises(ValidationError, match="gain_schedule"):
        FlightParams(gain_schedule="printed")
    with pytest.raises(ValidationError, match="drives straight"):
        DrivePattern.Params(pattern="linear", omega=0.05)
