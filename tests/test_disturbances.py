"""Disturbances: seeded gusty wind, marker occlusion, camera frame drops, video latency and kidnapping."""

import math

import cv2
import numpy as np
import pybullet
import pytest
from pydantic import ValidationError

from marsupial.api.config import WindConfig
from marsupial.api.errors import UnknownNameError
from marsupial.api.model import Intrinsics
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import parse_mission
from marsupial.world import World, WorldError
from marsupial.world.disturbances import DisturbanceSchedule, When, apply_disturbances
from marsupial.world.robots.base import Robot, yaw_of
from marsupial.world.sensors.base import SensorConfig
from marsupial.world.sensors.camera import OPTICAL_DOWN, Camera
from marsupial.world.wind import GustyWind

TAG_ID = 7
TAGS = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)


class _Rig(Robot):
    """A static stand-in robot: an invisible base at ``position`` and optional visual-only links."""

    kind = "test_rig"

    def __init__(self, world, name, position, link_visuals=()):
        super().__init__(world, name)
        n = len(link_visuals)
        self.body_id = pybullet.createMultiBody(
            0.0, -1, -1, position,
            linkMasses=[0.0] * n, linkCollisionShapeIndices=[-1] * n, linkVisualShapeIndices=list(link_visuals),
            linkPositions=[[0, 0, 0]] * n, linkOrientations=[[0, 0, 0, 1]] * n,
            linkInertialFramePositions=[[0, 0, 0]] * n, linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
            linkParentIndices=[0] * n, linkJointTypes=[pybullet.JOINT_FIXED] * n, linkJointAxis=[[0, 0, 1]] * n,
            physicsClientId=world.client_id,
        )
        self.links = {"base": -1, **{f"link{i}": i for i in range(n)}}
        world.robots[name] = self

    def safe_stop(self):
        pass


def _tag_quad(world, tmp_path, side=0.3):
    """A visual shape: an upward-facing square of ``side`` m textured with AprilTag 36h11 #TAG_ID."""
    image = cv2.copyMakeBorder(
        cv2.aruco.generateImageMarker(TAGS, TAG_ID, 200), 50, 50, 50, 50, cv2.BORDER_CONSTANT, value=255
    )
    cv2.imwrite(str(tmp_path / "tag.png"), image)
    h = side / 2
    (tmp_path / "tag.obj").write_text(
        f"v {-h} {-h} 0\nv {h} {-h} 0\nv {h} {h} 0\nv {-h} {h} 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n"
    )
    return pybullet.createVisualShape(
        pybullet.GEOM_MESH, fileName=str(tmp_path / "tag.obj"), physicsClientId=world.client_id
    )


def _marker_scene(world, tmp_path, rate_hz=30.0, size=(320, 240)):
    """A textured tag on robot 'uav' (link 'link0') 1 m under a downward camera 'rig/eye'."""
    uav = _Rig(world, "uav", [0, 0, 0.5], [_tag_quad(world, tmp_path)])
    pybullet.changeVisualShape(
        uav.body_id,
        0,
        textureUniqueId=pybullet.loadTexture(str(tmp_path / "tag.png"), physicsClientId=world.client_id),
        physicsClientId=world.client_id,
    )
    rig = _Rig(world, "rig", [0, 0, 1.5])
    camera = rig.add_sensor(
        Camera(
            rig,
            "eye",
            Intrinsics(*size, 60.0),
            SensorConfig(rate_hz=rate_hz),
            R_link_optical=OPTICAL_DOWN,
            segmentation=True,
        )
    )
    return uav, camera


def _tag_seen(camera):
    corners, ids, _ = cv2.aruco.ArucoDetector(TAGS).detectMarkers(
        cv2.cvtColor(camera.measure().rgb, cv2.COLOR_RGB2GRAY)
    )
    return ids is not None and TAG_ID in ids.ravel()


def _gusts(seed, times):
    with World(seed=seed) as world:
        wind = GustyWind(world, WindConfig(steady=[1.0, 0.0, 0.0], gust=3.0, gust_period_s=2.0))
        return np.array([wind.velocity(t, np.zeros(3)) for t in times])


# ------------------------------------------------------------------ wind
def test_gusts_are_a_deterministic_function_of_seed_and_time():
    times = np.arange(0.0, 120.0, 0.1)
    shuffled = np.random.default_rng(0).permutation(times)  # any query order sees the same wind
    a = _gusts(5, times)
    b = _gusts(5, shuffled)[np.argsort(shuffled)]
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, _gusts(6, times))
    assert np.abs(a - [1.0, 0.0, 0.0]).max() > 2.9  # there are gusts at all


def test_gust_peaks_match_the_setting_and_gusts_fill_half_the_time():
    with World(seed=2) as world:
        wind = GustyWind(world, WindConfig(
            steady=[1.0, -0.5, 0.0], gust=3.0, gust_period_s=2.0, gust_gap_s=2.0, gust_elevation_deg=10.0
        ))
        times = np.arange(0.0, 800.0, 0.02)
        gust = np.array([wind.velocity(t, np.array([5.0, 0.0, 1.0])) for t in times]) - [1.0, -0.5, 0.0]
    speed = np.linalg.norm(gust, axis=1)
    on = speed > 0
    edges = np.flatnonzero(np.diff(on.astype(int)))
    assert not on[0]  # the record starts between gusts: edges alternate start, end, ...
    starts, ends = edges[on[edges + 1]], edges[~on[edges + 1]]  # ... and a gust still blowing at its end has no end
    runs = [speed[a + 1 : b + 1] for a, b in zip(starts[: len(ends)], ends, strict=True)]
    peaks = np.array([r.max() for r in runs])
    assert 150 < len(peaks) < 250  # one 2 s gust per ≈ 4 s
    assert peaks.min() > 2.99 and peaks.max() <= 3.0 + 1e-9  # every gust peaks at the 3 m/s setting
    assert on.mean() == pytest.approx(0.5, abs=0.08)  # gust 2 s, calm 2 s on average
    elevation = np.degrees(np.arcsin(np.abs(gust[on, 2]) / speed[on]))
    assert elevation.max() <= 10.0 + 1e-6
    heading = np.arctan2(gust[on, 1], gust[on, 0])
    assert np.histogram(heading, bins=4, range=(-math.pi, math.pi))[0].min() > 0.15 * on.sum()  # all directions


def test_apply_disturbances_installs_the_wind():
    with World(seed=1) as world:
        apply_disturbances(world, {"wind": {"steady": [2, 0, 0], "gust": 3.0, "gust_period_s": 1.5}})
        assert isinstance(world.wind, GustyWind)
        speeds = [np.linalg.norm(world.wind.velocity(t, np.zeros(3)) - [2, 0, 0]) for t in np.arange(0, 60, 0.01)]
        assert min(speeds) == 0.0 and max(speeds) == pytest.approx(3.0, abs=0.01)


# ------------------------------------------------------------- occlusion
def test_occlusion_hides_a_textured_marker_during_its_window(tmp_path):
    with World() as world:
        _, camera = _marker_scene(world, tmp_path)
        schedule = apply_disturbances(
            world, {"occlusion": [{"robot": "uav", "link": "link0", "start": 0.5, "duration": 0.5}]}
        )
        seen = {}
        for t in (0.25, 0.5, 0.75, 0.99, 1.0, 1.25):
            world.step(t - world.now)
            seen[t] = _tag_seen(camera)
            if t == 0.75:
                assert schedule.active() == ["occlusion uav/link0"]
                frame = camera.measure()
                assert not (frame.segmentation == world.robot("uav").body_id).any()  # no colour, depth or id left
        assert seen == {0.25: True, 0.5: False, 0.75: False, 0.99: False, 1.0: True, 1.25: True}


def test_overlapping_occlusions_hide_until_the_last_ends(tmp_path):
    with World() as world:
        uav, camera = _marker_scene(world, tmp_path, size=(64, 48))
        schedule = DisturbanceSchedule.of(world)
        schedule.occlude(uav, "link0", When(start=0.2, duration=0.5))
        schedule.occlude(uav, None, When(start=0.5, duration=0.5))  # the whole robot
        visible = []
        for _ in range(12):
            world.step(0.1)
            visible.append(bool((camera.measure().segmentation == uav.body_id).any()))
        # t = 0.1 … 1.2: hidden from 0.2 until 1.0
        assert visible == [True] + [False] * 8 + [True] * 3


def test_random_occlusions_follow_their_rate_and_seed(tmp_path):
    def occluded_fraction(seed):
        with World(seed=seed) as world:
            uav, _ = _marker_scene(world, tmp_path, size=(16, 12))
            apply_disturbances(world, {"occlusion": {"robot": "uav", "rate_hz": 0.5, "duration": 0.5}})
            states = []
            for _ in range(3000):
                world.step(0.05)
                states.append(bool(DisturbanceSchedule.of(world).active()))
            return np.array(states)

    a, b, c = occluded_fraction(3), occluded_fraction(3), occluded_fraction(4)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    # windows of 0.5 s after calm spells of 2 s on average: occluded 0.5 / 2.5 of the time
    assert a.mean() == pytest.approx(0.2, abs=0.06)
    assert np.count_nonzero(np.diff(a.astype(int)) == 1) == pytest.approx(150 * 0.4, rel=0.35)


# ----------------------------------------------------------- frame drops
def test_frame_drops_lose_the_configured_fraction_of_due_frames(tmp_path):
    with World(seed=11) as world:
        _, camera = _marker_scene(world, tmp_path, rate_hz=30.0, size=(16, 12))
        apply_disturbances(
            world, {"frame_drops": {"camera": "rig/eye", "probability": 0.1, "start": 5.0, "duration": 100.0}}
        )
        counts = {}
        for phase, until in (("before", 5.0), ("during", 105.0), ("after", 110.0)):
            taken0, dropped0 = camera.samples_taken, camera.samples_dropped
            while world.now < until - 1e-9:
                camera.read()
                world.step(1 / 30)
            counts[phase] = (camera.samples_taken - taken0, camera.samples_dropped - dropped0)
    assert counts["before"][1] == 0 and counts["after"][1] == 0
    taken, dropped = counts["during"]
    n = taken + dropped
    assert n == 3000
    sigma = math.sqrt(n * 0.1 * 0.9)
    assert abs(dropped - 0.1 * n) < 4 * sigma  # binomial(3000, 0.1): 300 ± 66 at 4 sigma


# --------------------------------------------------------- video latency
def test_video_latency_delays_readings_by_the_configured_time(tmp_path):
    with World() as world:
        _, camera = _marker_scene(world, tmp_path, rate_hz=30.0, size=(16, 12))
        rig = world.robot("rig")
        apply_disturbances(world, {"video_latency": {"camera": "rig/eye", "seconds": 0.2, "start": 1.0}})
        ages, lags = [], []
        while world.now < 3.0:
            pybullet.resetBasePositionAndOrientation(
                rig.body_id, [world.now, 0, 1.5], [0, 0, 0, 1], physicsClientId=world.client_id
            )
            reading = camera.read()
            ages.append((world.now, world.now - reading.stamp))
            lags.append(world.now - reading.data.position[0])  # the rig moves at 1 m/s: position tells capture time
            world.step(1 / 30)
    for (now, age), lag in zip(ages, lags, strict=True):
        if now < 1.0 - 1e-9:
            assert age == pytest.approx(0.0, abs=1e-9) and lag == pytest.approx(0.0, abs=1e-9)
        elif now > 1.25:
            assert 0.2 - 1e-9 <= age < 0.2 + 1 / 30 and lag == pytest.approx(age, abs=1e-9)


# ------------------------------------------------------------ validation
def _mission_error(disturbances: str) -> str:
    """The error of a mission whose ``world.disturbances`` is the flow mapping ``disturbances`` (on line 4)."""
    text = ("mission: m\nteam: {uav: {robot: bebop2}, rig: {robot: summit_xl}}\nworld:\n"
            f"  disturbances: {disturbances}\ntree: {{idle: true}}\n")
    with pytest.raises(MissionError) as caught:
        parse_mission(text, "m.yaml")
    return str(caught.value)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("{wind: {stedy: [1, 0, 0]}}", "m.yaml:4:25: world.disturbances.wind.stedy: unknown key 'stedy'; expected one "
         "of gust, gust_elevation_deg, gust_gap_s, gust_period_s, steady; did you mean 'steady'?"),
        ("{gusts: 3}", "m.yaml:4:18: world.disturbances.gusts: unknown key 'gusts'; expected one of aperture_fit, "
         "decoys, frame_drops, kidnap, occlusion, video_latency, wind"),
        ("{wind: {gust: strong}}", "world.disturbances.wind.gust: invalid value 'strong'; expected a number"),
        ("{wind: {gust: true}}", "world.disturbances.wind.gust: invalid value True; expected a number"),
        ("{wind: {gust: .nan}}", "world.disturbances.wind.gust: invalid value nan; expected a finite number"),
        ("{wind: {gust_period_s: 1e-300}}", "wind.gust_period_s: invalid value 1e-300; expected a value >= 0.1"),
        ("{wind: {steady: [1, 0]}}", "world.disturbances.wind.steady: invalid value [1, 0]; expected at least 3"),
        ("{occlusion: [{robot: uav, start: ten}]}",
         "m.yaml:4:43: world.disturbances.occlusion[0].start: invalid value 'ten'; expected a number"),
        ("{occlusion: {link: link0}}", "world.disturbances.occlusion.robot: missing required key 'robot'"),
        ("{occlusion: uav}", "world.disturbances.occlusion: invalid value 'uav'; expected a list"),
        ("{occlusion: {robot: uav, rate_hz: 0.1}}", "world.disturbances.occlusion.rate_hz: random windows (rate_hz) "
         "need a duration; expected duration (s) beside rate_hz"),
        ("{occlusion: {robot: uav, stop: 5}}", "world.disturbances.occlusion.stop: only random windows"),
        ("{occlusion: {robot: uav, rate_hz: 1, duration: 1, start: 5, stop: 2}}",
         "world.disturbances.occlusion.stop: stop 2.0 s comes before start 5.0 s; expected stop >= start"),
        ("{occlusion: {robot: uva}}", "m.yaml:4:30: world.disturbances.occlusion.robot: unknown robot 'uva'; "
         "expected a team member (one of rig, uav); did you mean 'uav'?"),
        ("{frame_drops: {camera: rig/eye, probability: 1.5}}",
         "world.disturbances.frame_drops.probability: invalid value 1.5; expected a value <= 1"),
        ("{video_latency: {camera: rig/eye, seconds: 0.2, every: 3}}", "video_latency.every: unknown key 'every'"),
        ("{video_latency: {camera: eye, seconds: 0.2}}",
         "video_latency.camera: 'eye' does not name a sensor; expected 'robot/sensor' (e.g. carrier/eye_in_hand)"),
        ("{frame_drops: {camera: rg/eye, probability: 0.1}}", "frame_drops.camera: unknown robot 'rg'"),
        ("{kidnap: {robot: uav, pose: [0, 0, 0]}}", "world.disturbances.kidnap.at: missing required key 'at'"),
        ("{kidnap: [{robot: uav, at: -1.0, pose: [0, 0, 0]}]}",
         "world.disturbances.kidnap[0].at: invalid value -1.0; expected a value >= 0"),
        ("{kidnap: {robot: uav, at: 1.0, pose: [0, 0]}}", "kidnap.pose: invalid value [0, 0]; expected at least 3"),
        ("{kidnap: {robot: uav, at: 1.0, pose: [0, a, 0]}}", "kidnap.pose[1]: invalid value 'a'; expected a number"),
        ("{kidnap: {robot: uav, at: 1.0, pose: [0, 0, 0], spread: [0.1, -0.1, 0]}}",
         "world.disturbances.kidnap.spread[1]: invalid value -0.1; expected a value >= 0"),
        ("{kidnap: {robot: uav, at: true, pose: [0, 0, 0]}}", "kidnap.at: invalid value True; expected a number"),
        ("{decoys: {wall: w, x: [1, 0], z: [0, 1]}}",
         "decoys.x: [low, high] = [1.0, 0.0] is not increasing; expected [low, high] with low < high"),
        ("{decoys: {wall: w, x: [0, 1], z: [0, 1], holes: 1.5}}", "decoys.holes: invalid value 1.5; expected an "
         "integer"),
        ("{decoys: {wall: w, x: [0, 1], z: [0, 1], holes: 1000000}}", "decoys.holes: invalid value 1000000; "
         "expected a value <= 100"),
    ],
)
def test_bad_entries_are_refused_at_their_line_when_the_mission_loads(spec, message):
    assert message in _mission_error(spec)


def test_a_mapping_from_python_is_validated_by_the_same_models():
    with World() as world, pytest.raises(ValidationError, match="gust_period_s"):
        apply_disturbances(world, {"wind": {"gust_period_s": 0.0}})
    assert not isinstance(world.wind, GustyWind)


def test_unknown_names_list_the_known_ones(tmp_path):
    with World() as world:
        _marker_scene(world, tmp_path, size=(16, 12))
        with pytest.raises(UnknownNameError, match="unknown robot 'uva'. Did you mean 'uav'"):
            apply_disturbances(world, {"wind": {"gust": 3.0}, "occlusion": {"robot": "uva"}})
        assert not isinstance(world.wind, GustyWind)  # a bad entry leaves the world untouched
        with pytest.raises(UnknownNameError, match="Known: base, link0"):
            apply_disturbances(world, {"occlusion": {"robot": "uav", "link": "tag"}})
        with pytest.raises(UnknownNameError, match="unknown sensor of rig 'rig/eyes'. Did you mean 'rig/eye'"):
            apply_disturbances(world, {"frame_drops": {"camera": "rig/eyes", "probability": 0.1}})
        with pytest.raises(UnknownNameError, match="unknown robot 'chld'"):
            apply_disturbances(world, {"kidnap": {"robot": "chld", "at": 1.0, "pose": [0, 0, 0]}})


# ------------------------------------------------------------- kidnapping
def _driving_child(seed=0):
    world = World(scene="marsupial_yard", seed=seed)
    child = world.add_robot("child_ugv", name="child", pose=[-2.0, 0.0, 0.0])
    child.drive(0.2, 0.0)
    return world, child


def test_kidnap_moves_the_body_at_its_time_and_the_estimate_is_not_told():
    world, child = _driving_child()
    with world:
        apply_disturbances(world, {"kidnap": {"robot": "child", "at": 2.0, "pose": [1.0, 2.0, math.pi]}})
        world.step(1.95)
        before = child.pose()[0]
        assert before[0] > -1.9 and abs(before[1]) < 0.01  # still driving along +x
        world.step(0.1)
        p, q = child.pose()
        assert p[:2] == pytest.approx([1.0, 2.0], abs=1e-6) and p[2] == pytest.approx(before[2], abs=1e-6)
        assert abs(math.remainder(yaw_of(q) - math.pi, 2 * math.pi)) < 1e-6
        v, w = child.velocity()
        assert np.linalg.norm(v) < 1e-3 and np.linalg.norm(w) < 1e-3
        estimate = child.estimator.estimate()
        assert np.linalg.norm(estimate.position[:2] - before[:2]) < 0.05  # dead reckoning kept on where it was
        assert DisturbanceSchedule.of(world).kidnapped == [(pytest.approx(2.0, abs=0.01), "child", (1.0, 2.0, math.pi))]
        child.drive(0.2, 0.0)  # it drives on from where it was put: along -x now
        world.step(1.0)
        assert child.pose()[0][0] < 0.9


def test_kidnap_spread_is_seeded_and_bounded():
    spec = {"kidnap": {"robot": "child", "at": 0.5, "pose": [1.0, 2.0, 0.0], "spread": [0.3, 0.2, 0.5]}}
    poses = []
    for seed in (4, 4, 5):
        world, child = _driving_child(seed)
        with world:
            schedule = apply_disturbances(world, spec)
            world.step(0.6)
            (_, _, pose), = schedule.kidnapped
            assert child.pose()[0][:2] == pytest.approx(pose[:2], abs=1e-6)
            poses.append(pose)
    assert poses[0] == poses[1] != poses[2]  # the seed's draw, another seed's another
    for x, y, yaw in poses:
        assert abs(x - 1.0) <= 0.3 and abs(y - 2.0) <= 0.2 and abs(yaw) <= 0.5


def test_a_child_carried_on_the_lift_cannot_be_kidnapped():
    with World(scene="marsupial_yard", seed=0) as world:
        mother = world.add_robot("mother_ugv", name="mother", pose=[0.0, 0.0, 0.0])
        child = world.add_robot("child_ugv", name="child", pose=[-2.0, 0.0, 0.0])
        mother.store(child)
        apply_disturbances(world, {"kidnap": {"robot": "child", "at": 0.5, "pose": [1.0, 2.0, 0.0]}})
        with pytest.raises(WorldError, match="kidnap child: it is carried by mother"):
            world.step(1.0)
