"""The visually-servoed micro-scout (Arora & Papachristos, §IV-G): policy, relay, depth stand-in, detector, missions.

The mission runs fly a Tello hovering past the amoeba aperture of the
``collapsed_mockup`` (x 0.3, y 0.4, 0.85 m up, facing the corridor) with the
MMS standing before the wall; they are scored from the MCAP log on truth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner
from pydantic import ValidationError

from marsupial.api.views import LinkState, LinkView
from marsupial.skills.scout.depth import MonocularErrorModel
from marsupial.skills.scout.detection import HsvColourDetector
from marsupial.skills.scout.policy import decide, velocity_command
from marsupial.skills.scout.relay import RelayedFrame, VideoReceiver, VideoSender, decode_frame, encode_frame
from marsupial.skills.scout.skills import Scout
from marsupial.tools.rig import DirectSink, live_view
from marsupial.trees.cli import cli
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission
from marsupial.world import World
from marsupial.world.team_link import TeamLinkConfig

START = [0.3, 0.4, 0.85, math.pi / 2]  # past the amoeba aperture, facing the corridor (+y)
EXTINGUISHER = np.array([5.8, 6.45])  # collapsed_mockup.yaml


def columns(left: float, centre: float, right: float, rows: int = 12, width: int = 12) -> np.ndarray:
    """A depth map (m) whose left, centre and right column thirds have these depths."""
    return np.repeat(np.array([[left] * (width // 3) + [centre] * (width // 3) + [right] * (width // 3)]), rows, 0)


# ------------------------------------------------------------------ policy
@pytest.mark.parametrize(("depths", "action"), [((1, 4, 2), "f"), ((1, 2, 4), "r"), ((4, 2, 1), "l")])
def test_the_policy_heads_for_the_deepest_third(depths, action):
    assert decide(columns(*depths)).action == action


def test_the_bias_breaks_a_tie_between_the_sides_and_can_overturn_forward():
    open_sides = columns(4.0, 3.0, 4.0)
    assert decide(open_sides, bias=0.2).action == "r" and decide(open_sides, bias=-0.2).action == "l"
    slightly_right = columns(1.0, 3.0, 2.8)
    assert decide(slightly_right).action == "f" and decide(slightly_right, bias=0.2).action == "r"
    decision = decide(slightly_right, bias=0.2)
    assert decision.vector == pytest.approx((3.0, 1.2 * 2.8, 0.8 * 1.0))
    assert decision.columns == pytest.approx((1.0, 3.0, 2.8))
    with pytest.raises(ValueError, match=r"bias must lie in \[-1, 1\]"):
        decide(slightly_right, bias=1.5)


def test_the_policy_is_blind_to_the_depth_scale_and_averages_only_the_row_band():
    depth = columns(2.0, 1.0, 3.0)
    assert {decide(k * depth, 0.1).action for k in (0.01, 1.0, 50.0)} == {"r"}
    depth[:4, 4:8] = 10.0  # sky over the centre only, in the top third
    assert decide(depth).action == "f" and decide(depth, rows=(0.35, 0.65)).action == "r"


def test_the_actions_are_forward_and_yaws_of_both_signs():
    assert velocity_command("f", 0.4, 0.1, 0.6) == (0.4, 0.0)
    assert velocity_command("r", 0.4, 0.1, 0.6) == (0.1, -0.6)  # clockwise about z-up
    assert velocity_command("l", 0.4, 0.1, 0.6) == (0.1, 0.6)
    with pytest.raises(ValueError, match="unknown action 'x'"):
        velocity_command("x", 0.4, 0.1, 0.6)


# ----------------------------------------------------------- depth model
def _frame(depth):
    return RelayedFrame(0, 0.0, 0.0, np.zeros((*depth.shape, 3), np.uint8), np.eye(3), depth)


def test_the_error_model_saturates_resamples_and_scales_the_rendered_depth():
    depth = np.full((24, 36), 30.0, np.float32)  # the far plane: nothing drawn
    depth[:, 12:24] = 2.0
    exact = MonocularErrorModel(MonocularErrorModel.Options(blur_px=0, scale_std=0, noise_rel=0),
                                np.random.default_rng(0)).estimate(_frame(depth))
    assert exact.shape == (12, 18) and exact.dtype == np.float32
    assert exact[:, :5].max() == pytest.approx(10.0) and exact[:, 7:11] == pytest.approx(2.0)
    scaled = MonocularErrorModel(MonocularErrorModel.Options(blur_px=0, noise_rel=0), np.random.default_rng(1))
    a, b = scaled.estimate(_frame(depth)), scaled.estimate(_frame(depth))
    ratio_a, ratio_b = a / exact, b / exact
    assert np.ptp(ratio_a) < 1e-5 and abs(ratio_a[0, 0] - ratio_b[0, 0]) > 1e-3  # one scale per frame, new each frame
    noisy = MonocularErrorModel(MonocularErrorModel.Options(), np.random.default_rng(2)).estimate(_frame(depth))
    assert np.ptp(noisy[:, 7:11] / np.median(noisy[:, 7:11])) > 0.02  # structured error over one surface
    with pytest.raises(ValueError, match="needs the frame's rendered depth"):
        scaled.estimate(_frame(depth).__class__(0, 0.0, 0.0, np.zeros((2, 2, 3), np.uint8), np.eye(3), None))


# ---------------------------------------------------------------- detector
def _scene(rgb, box):
    image = np.full((240, 320, 3), 128, np.uint8)
    u0, v0, u1, v1 = box
    image[v0:v1, u0:u1] = rgb
    return decode_frame(encode_frame(image, 80))


def test_the_colour_detector_needs_the_colour_the_shape_and_the_size():
    detector = HsvColourDetector(HsvColourDetector.Options())
    found = detector.detect(_scene((200, 24, 24), (100, 80, 120, 150)), "fire_extinguisher")  # 20 × 70 px, red
    assert len(found) == 1 and found[0].box == pytest.approx((100, 80, 119, 149), abs=1)
    assert found[0].area_px >= 1300 and found[0].object_class == "fire_extinguisher"
    assert detector.detect(_scene((200, 24, 24), (100, 80, 150, 130)), "fire_extinguisher") == []  # square
    assert detector.detect(_scene((200, 24, 24), (100, 80, 110, 115)), "fire_extinguisher") == []  # too small
    assert detector.detect(_scene((150, 82, 60), (100, 80, 120, 150)), "fire_extinguisher") == []  # debris brown
    assert detector.detect(_scene((40, 62, 120), (100, 80, 145, 125)), "fire_extinguisher") == []
    assert len(detector.detect(_scene((40, 62, 120), (100, 80, 145, 125)), "chair")) == 1
    with pytest.raises(ValueError, match="knows no 'sofa'"):
        detector.detect(_scene((40, 62, 120), (100, 80, 145, 125)), "sofa")


# ----------------------------------------------------------------- plug-ins
def test_plugins_are_named_by_entry_point_or_import_target_and_checked():
    assert Scout.Params.model_validate({"depth_estimator": "marsupial.skills.scout.depth:MonocularErrorModel"})
    with pytest.raises(ValidationError, match="unknown depth estimator 'midas'; expected one of monocular_error_model"):
        Scout.Params.model_validate({"depth_estimator": "midas"})
    with pytest.raises(ValidationError, match="unknown object detector 'yolo'; expected one of hsv_colour"):
        Scout.Params.model_validate({"detector": "yolo"})
    with pytest.raises(ValidationError, match="is not a subclass of marsupial.skills.scout.depth.DepthEstimator"):
        Scout.Params.model_validate({"depth_estimator": "marsupial.skills.scout.detection:HsvColourDetector"})
    with pytest.raises(ValidationError, match="blur"):
        Scout.Params.model_validate({"depth_options": {"blur": 2.0}})
    with pytest.raises(ValidationError, match="knows no object class 'sofa'; expected one of fire_extinguisher, chair"):
        Scout.Params.model_validate({"object_class": "sofa"})


def test_an_unknown_detector_in_a_mission_is_an_error_at_its_line(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(MISSION.split("tree:")[0].format(until=10, operator="[]", battery=1.0)
                    + "tree: {skill: scout, robot: scout, params: {carrier: mms, detector: yolo}}\n")
    result = CliRunner().invoke(cli, ["tree", str(path)], env={"COLUMNS": "200"})
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert f"{path}:" in result.output and "unknown object detector 'yolo'" in result.output


# -------------------------------------------------------------------- relay
@pytest.mark.slow
def test_the_relay_delivers_decoded_frames_late_and_counts_the_lost_ones():
    link = TeamLinkConfig(latency_s=0.2, jitter_s=0.0, drop=0.3)
    with World(scene="collapsed_mockup", seed=5, team_link=link) as world:
        world.add_robot("mms", "mms", pose=[0.3, -2.4, 1.5708], mavs=False)
        world.add_robot("tello", "scout", pose=START)
        camera, delivered, radio = live_view(world, "scout").sensor("front_camera"), LinkState(), DirectSink(world)
        sender = VideoSender(LinkView("scout", delivered, radio), quality=80, with_depth=True)
        receiver = VideoReceiver(LinkView("mms", delivered, radio), "scout")
        originals, frames = {}, []
        for _ in range(40):
            world.step(0.1)
            delivered.update(world.team_link.take_delivered())
            reading = camera.read()
            image = reading.data if reading is not None else None
            if image is not None and sender.offer(reading.stamp, image.rgb, image.K, image.depth):
                originals[sender.sent - 1] = reading.data.rgb
            frame = receiver.newest()
            if frame is not None:
                frames.append(frame)
    assert sender.sent >= 30 and receiver.lost > 0 and len(frames) == receiver.received
    assert receiver.received + receiver.lost <= sender.sent and receiver.received >= 0.5 * sender.sent
    for frame in frames:
        assert frame.rgb.shape == (240, 320, 3) and frame.rgb.dtype == np.uint8
        assert frame.delivered - frame.stamp >= 0.2 - 1e-9  # the link's latency on top of the camera's
        assert np.abs(frame.rgb.astype(int) - originals[frame.seq]).mean() < 6.0  # the JPEG of that frame
        assert frame.depth_standin is not None and frame.depth_standin.shape == (240, 320)
    assert [f.seq for f in frames] == sorted({f.seq for f in frames})


def test_a_frame_that_is_no_jpeg_is_refused():
    with pytest.raises(ValueError, match="not a JPEG"):
        decode_frame(b"not an image")


# ----------------------------------------------------------------- missions
MISSION = """\
mission: scout_test
world: {{scene: collapsed_mockup, seed: 3}}
team:
  mms: {{robot: mms, pose: [0.3, -2.4, 1.5708], options: {{mavs: false}}}}
  scout: {{robot: tello, pose: [0.3, 0.4, 0.85, 1.5708], options: {{battery_soc: {battery}}}}}
operator: {operator}
run: {{tick_hz: 10, until: {until}}}
tree:
  sequence:
    - {{subtree: scout_object, params: {{scout: scout, carrier: mms, bias: 0.2}}, name: scout the hallway}}
    - {{skill: wait, name: settle, params: {{seconds: 1.0}}}}   # the log sees the scout come to rest
"""


def _run(tmp_path, operator="[]", battery=1.0, until=60):
    path = tmp_path / "scout.yaml"
    path.write_text(MISSION.format(until=until, operator=operator, battery=battery))
    result = run_mission(str(path), log_path=tmp_path / "run.mcap", progress=False)
    return result, read_log(tmp_path / "run.mcap")


def _at(log, robot, t):
    times, xyz = log.poses(robot)
    return xyz[min(np.searchsorted(times, t), len(times) - 1)]


@pytest.mark.slow
def test_one_scout_with_a_right_bias_finds_the_fire_extinguisher(tmp_path):
    result, log = _run(tmp_path)
    assert result.outcome == "success", result.message
    found = [e for e in log.events_of("state_change") if e.get("phase") == "object_found"]
    assert len(found) == 1 and found[0]["object_class"] == "fire_extinguisher" and found[0]["robot"] == "scout"
    u0, v0, u1, v1 = found[0]["box"]
    assert v1 - v0 > u1 - u0 > 0  # a standing cylinder
    position = _at(log, "scout", found[0]["t"])
    assert position[1] > 4.7  # through the door, in the hallway
    assert np.hypot(*(position[:2] - EXTINGUISHER)) < 2.5  # near the extinguisher when it is reported
    outcome = [e for e in log.events_of("outcome") if e["skill"] == "scout"]
    assert outcome[-1]["status"] == "SUCCESS" and "fire_extinguisher found" in outcome[-1]["message"]
    _, lost = log.metric("scout_frames_lost", robot="scout")
    _, received = log.metric("scout_frames_received", robot="scout")
    _, sent = log.metric("scout_frames_sent", robot="scout")
    assert received[-1] + lost[-1] <= sent[-1] and received[-1] > 0.8 * sent[-1]
    assert not log.events_of("unintended_contact")


@pytest.mark.slow
def test_a_low_battery_lands_the_scout_where_it_is(tmp_path):
    result, log = _run(tmp_path, battery=0.201, until=20)
    assert result.outcome == "success", result.message
    preemptions = log.events_of("preemption")
    assert [p["by"] for p in preemptions] == ["low battery landing"] and preemptions[0]["robot"] == "scout"
    t_pre = preemptions[0]["t"]
    _, xyz = log.poses("scout")
    assert xyz[-1, 2] < 0.05  # on the floor (landed height 0.02 m)
    assert np.hypot(*(xyz[-1, :2] - _at(log, "scout", t_pre)[:2])) < 0.3  # where it was


@pytest.mark.slow
def test_the_operator_recall_flies_the_scout_back_along_its_path(tmp_path):
    result, log = _run(tmp_path, operator="[{at: 6.0, say: recall_scout, why: come back}]", until=40)
    assert result.outcome == "success", result.message
    preemptions = log.events_of("preemption")
    assert [p["by"] for p in preemptions] == ["recall"]
    assert _at(log, "scout", preemptions[0]["t"])[1] > 1.5  # it had flown up the corridor
    _, xyz = log.poses("scout")
    assert np.hypot(*(xyz[-1, :2] - np.array(START[:2]))) < 0.4 and xyz[-1, 2] < 0.05  # landed at the start


STUCK_MISSION = """\
mission: scout_stuck
world: {scene: collapsed_mockup, seed: 3}
team:
  mms: {robot: mms, pose: [0.3, -2.4, 1.5708], options: {mavs: false}}
  scout: {robot: tello, pose: [6.88, 6.6, 0.7, 0.0]}   # its nose in the hallway's far right corner
run: {tick_hz: 10, until: 12}
tree: {skill: scout, robot: scout, params: {carrier: mms, bias: 0.0}}
"""


@pytest.mark.slow
def test_a_scout_pressed_against_a_wall_turns_away(tmp_path):
    # in the corner the walls fill the view near the depth map's floor and the policy keeps saying forward
    # (§IV-G); the Tello's own estimate does not move, and stuck_time later it turns by unstick_angle
    path = tmp_path / "stuck.yaml"
    path.write_text(STUCK_MISSION)
    run_mission(str(path), log_path=tmp_path / "run.mcap", progress=False)
    log = read_log(tmp_path / "run.mcap")
    stuck = [e for e in log.events_of("state_change") if e.get("phase") == "stuck"]
    assert stuck and stuck[0]["robot"] == "scout" and stuck[0]["moved"] < 0.15
    assert 3.0 <= stuck[0]["t"] <= 9.0
    times, _, quats = log.poses("scout", orientation=True)
    yaw = [2.0 * math.atan2(q[2], q[3]) for q in quats]  # about z, the Tello flies level
    after = yaw[min(np.searchsorted(times, stuck[0]["t"] + 2.7), len(yaw) - 1)]
    assert math.remainder(after - yaw[0], math.tau) < -0.5  # turning away, clockwise (bias 0)
