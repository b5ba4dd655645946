"""UGV-UGV coordinated docking (Zhao et al.): the control laws, the conditions C1-C4 on rendered frames, and the
coordinated docking mission end to end, read back from its MCAP log."""

from __future__ import annotations

import math

import numpy as np
import py_trees
import pytest
from py_trees.common import Status
from skill_harness import Harness

import marsupial
from marsupial.geometry import rotation_matrix
from marsupial.skills.ugv_docking.conditions import BenchmarkCaptured, EntranceMatched, FeaturesLost, WithinCriterion
from marsupial.skills.ugv_docking.criterion import MatchTolerances, load_criterion_list, robot_tolerances
from marsupial.skills.ugv_docking.features import BenchmarkFeatures
from marsupial.skills.ugv_docking.station import Carry, Release
from marsupial.skills.ugv_docking.steering import MatchGains, align_rate, match_command, target_column
from marsupial.world import World
from marsupial.world.robots.ugv_docking import place_child


def _features(u_h=319.5, k_h=0.0, s_u=150) -> BenchmarkFeatures:
    return BenchmarkFeatures(u_h=u_h, v_h=100.0, k_h=k_h, s_u=s_u, n_g=64, image_width=640)


def test_mother_turns_by_remark_1_and_the_child_steers_towards_the_entry_line():
    # k_h < 0: alpha < pi/2, the station's normal points right of the child's heading: the mother turns CCW
    assert align_rate(-0.2, gain=0.5, max_rate=0.15) == pytest.approx(0.1)
    assert align_rate(0.6, gain=0.5, max_rate=0.15) == pytest.approx(-0.15)
    # k_h > 0: the entry line lies to the child's right, I_h is kept left of the centre (the child heads right)
    assert target_column(_features(k_h=0.2), lateral_gain=2.0, max_offset=0.5, delta_k=0.02) == pytest.approx(192.0)
    assert target_column(_features(k_h=0.2), lateral_gain=5.0, max_offset=0.3, delta_k=0.02) == pytest.approx(224.0)
    assert target_column(_features(k_h=-0.9), lateral_gain=2.0, max_offset=0.5, delta_k=0.02) == pytest.approx(480.0)
    assert target_column(_features(k_h=0.01), lateral_gain=2.0, max_offset=0.5, delta_k=0.02) == 320.0


def test_matching_rotates_advances_waits_or_backs_off():
    tolerances, gains = MatchTolerances(s_u_e=184), MatchGains()
    v, omega, what = match_command(_features(u_h=400.0), tolerances, gains)
    assert (v, what) == (0.0, "rotating") and omega < 0  # I_h right of the centre: turn right on the spot
    v, _, what = match_command(_features(u_h=322.0), tolerances, gains)
    assert (v, what) == (gains.speed, "advancing")
    v, _, what = match_command(_features(k_h=0.1, s_u=190), tolerances, gains)
    assert (v, what) == (0.0, "waiting for alignment")  # coordinated: the mother turns the entrance
    alone = MatchGains(lateral_gain=3.0)
    v, _, what = match_command(_features(k_h=0.1, s_u=190), tolerances, alone)
    assert v < 0 and what == "backing off"  # independent: back off to come in again ...
    assert match_command(_features(k_h=0.1, s_u=160), tolerances, alone, retreating=True)[2] == "backing off"
    assert match_command(_features(k_h=0.1, s_u=140), tolerances, alone, retreating=True)[2] != "backing off"


def test_s_u_e_is_measured_for_the_child_ugv_and_the_paper_value_kept_as_the_default():
    f_list = load_criterion_list("child_ugv")
    assert MatchTolerances().s_u_e == 203  # Table 1
    assert f_list.s_u_e is not None and 150 < f_list.s_u_e < 196 and f_list.entrance_distance == 0.25
    assert robot_tolerances(f_list).s_u_e == f_list.s_u_e
    assert robot_tolerances(f_list, s_u_e=203).s_u_e == 203


def _checks(harness: Harness, world: World, conditions: dict, seconds: float = 0.8) -> dict:
    """Each condition checked every 0.1 s (as the tree ticks) for ``seconds``; the last results."""
    results = {}
    for _ in range(round(seconds / 0.1)):
        harness.feed(*conditions.values())
        results = {name: node.check() for name, node in conditions.items()}
        harness.flush()  # the child's features go out on the team link
        world.step(0.1)
    return results


@pytest.fixture
def yard():
    with World(scene="marsupial_yard", seed=1) as world:
        mother = world.add_robot("mother_ugv", name="mother", pose=[0.0, 0.0, 0.0])
        child = world.add_robot("child_ugv", name="child", pose=[-2.0, 0.0, 0.0])
        harness = Harness(world)
        yield world, mother, child, harness


@pytest.mark.slow
def test_conditions_on_the_child_camera(yard):
    world, mother, child, h = yard
    own = {
        "C1": h.node(BenchmarkCaptured, "child"),
        "C2": h.node(WithinCriterion, "child"),
        "C3": h.node(EntranceMatched, "child"),
        "C3 paper": h.node(EntranceMatched, "child", s_u_e=203),
        "C4": h.node(FeaturesLost, "child", frames=3),
    }
    place_child(mother, child, math.pi / 2, 0.0, 0.24)  # aligned, just outside the entrance
    assert _checks(h, world, own) == {"C1": True, "C2": True, "C3": True, "C3 paper": False, "C4": False}
    place_child(mother, child, math.pi / 2 - math.radians(20), 0.0, 0.30)  # 20 deg off the entry direction
    assert _checks(h, world, own) == {"C1": True, "C2": True, "C3": False, "C3 paper": False, "C4": False}
    place_child(mother, child, math.pi / 2, 0.0, 1.2)  # aligned but far: captured, not within the criterion
    assert _checks(h, world, own) == {"C1": True, "C2": False, "C3": False, "C3 paper": False, "C4": False}
    child.diff_drive.teleport(np.array([-2.0, 0.0]), math.pi)  # facing away
    captured, lost = h.node(BenchmarkCaptured, "child"), h.node(FeaturesLost, "child", frames=3)
    c1, c4 = [], []
    for _ in range(8):  # 0.1 s steps: one 10 Hz camera frame each
        world.step(0.1)
        h.feed(captured, lost)
        c1.append(captured.check())
        c4.append(lost.check())
    # C1 fails from the first frame taken facing away; C4 holds from the third successive such frame on
    first_miss, first_lost = c1.index(False), c4.index(True)
    assert not any(c1[first_miss:]) and all(c4[first_lost:])
    assert first_lost - first_miss >= 2 and not any(c4[:first_lost])


@pytest.mark.slow
def test_the_mother_judges_c1_and_c3_on_the_features_the_child_sends(yard):
    world, mother, child, h = yard
    mother_nodes = {
        "C1": h.node(BenchmarkCaptured, "mother", child="child"),
        "C3": h.node(EntranceMatched, "mother", child="child"),
    }
    child_c1 = h.node(BenchmarkCaptured, "child")
    place_child(mother, child, math.pi / 2, 0.0, 0.24)
    assert _checks(h, world, mother_nodes) == {"C1": False, "C3": False}  # the child's camera is not read: silent
    both = {**mother_nodes, "child": child_c1}
    assert _checks(h, world, both) == {"C1": True, "C3": True, "child": True}
    child.diff_drive.teleport(np.array([-2.0, 0.0]), math.pi)
    # the child sends nothing once it loses the benchmark; the mother's view goes stale after max_age (0.5 s)
    assert _checks(h, world, both, seconds=1.2) == {"C1": False, "C3": False, "child": False}


@pytest.mark.slow
def test_coordinated_docking_ends_with_the_child_lifted_inside_the_capsule(tmp_path):
    result = marsupial.run("ugv_docking", log=tmp_path / "ugv.mcap")
    assert result.outcome == "success", result.message
    log = marsupial.read_log(result.log_path)
    started = [e["node"] for e in log.events_of("state_change") if e["status"] == "RUNNING"]
    child = [n for n in started if n.startswith("child ")]
    mother = [n for n in started if n.startswith("mother ") or n in ("lifting", "carrying")]
    assert child[0] == "child linking" and child[-1] == "child directed"  # Fig. 5, the child's states
    assert {"child approaching", "child matching"} <= set(child)
    assert child.index("child approaching") < child.index("child matching") < child.index("child directed")
    assert mother == ["mother linking", "mother aligning", "mother directing", "lifting", "carrying"]
    outcomes = {e["node"]: e["status"] for e in log.events_of("outcome")}
    assert outcomes["child directed"] == outcomes["lifting"] == outcomes["carrying"] == "SUCCESS"
    # the features as the child saw them (Fig. 11b): s* grows as it approaches, u* ends near 0.5
    t_features, s_star = log.metric("ugv_s_star", robot="child")
    _, u_star = log.metric("ugv_u_star", robot="child")
    assert s_star[-1] > 1.5 * s_star[0] and abs(u_star[-1] - 0.5) < 0.02
    # directed, the child still sends its features: the mother's C3 does not hang on one frame crossing the link
    directed_at = next(e["t"] for e in log.events_of("state_change") if e["node"] == "child directed")
    assert any(t > directed_at for t in t_features)
    _assert_stored(log)
    _, p_mother = log.poses("mother")
    assert np.linalg.norm(p_mother[-1][:2] - p_mother[0][:2]) > 0.4  # carried away


def _assert_stored(log, index: int = -1) -> None:
    """Truth at pose sample ``index``: the child rose 0.30 m with the platform and stands on the plate between the
    entrance walls."""
    _, p_child, q_child = log.poses("child", orientation=True)
    _, p_mother, q_mother = log.poses("mother", orientation=True)
    assert p_child[index][2] - p_child[0][2] == pytest.approx(0.30, abs=0.01)
    R_mother = rotation_matrix(q_mother[index])
    x, y, _ = R_mother.T @ (p_child[index] - p_mother[index])
    yaw = math.atan2(*(R_mother.T @ rotation_matrix(q_child[index])[:, 0])[1::-1])
    assert -0.445 + 0.10 <= x <= -0.06 - 0.10  # the 0.2 m child wholly on the 0.385 m plate (x: -0.445 .. -0.06)
    assert abs(y) + 0.085 * math.cos(yaw) + 0.10 * abs(math.sin(yaw)) <= 0.095  # inside the 0.19 m entrance


KIDNAP_AT = 8.0  # s: the child is approaching (from 4.5 s with seed 0)
KIDNAP_POSE = [-1.4, 0.2, 2.77]  # position B, its back towards the benchmark (it headed ≈ -0.37 rad)


@pytest.mark.slow
def test_a_kidnapped_child_falls_back_through_c4_relinks_and_docks(tmp_path):
    """Zhao et al. §4.2, Experiment II: moved by hand while approaching, its back to the benchmark."""
    kidnap = {"kidnap": [{"robot": "child", "at": KIDNAP_AT, "pose": KIDNAP_POSE}]}
    result = marsupial.run("ugv_docking", log=tmp_path / "kidnap.mcap", set={"world.disturbances": kidnap})
    assert result.outcome == "success", result.message
    log = marsupial.read_log(result.log_path)
    t, p_child = log.poses("child")
    i = int(np.searchsorted(t, KIDNAP_AT + 0.2))
    assert p_child[i][:2] == pytest.approx(KIDNAP_POSE[:2], abs=0.03)  # the world moved it (truth)
    (fallback,) = [e for e in log.events_of("preemption") if e["by"] == "child linking"]  # once, after the kidnap
    assert fallback["preempted"] == "child approaching" and fallback["by"] == "child linking"
    assert fallback["why"].startswith("features_lost") and KIDNAP_AT < fallback["t"] < KIDNAP_AT + 2.0  # C4
    started = [(e["t"], e["node"]) for e in log.events_of("state_change") if e["status"] == "RUNNING"]
    after = [n for when, n in started if when >= fallback["t"]]
    assert after[:2] == ["child linking", "child approaching"]  # relinked, then approached again
    assert after.index("child matching") < after.index("child directed") < after.index("lifting")
    mother = [n for _, n in started if n.startswith("mother ")]
    assert mother == ["mother linking", "mother aligning", "mother directing"]  # it kept aligning meanwhile
    outcomes = {e["node"]: e["status"] for e in log.events_of("outcome")}
    assert outcomes["child directed"] == outcomes["lifting"] == "SUCCESS"
    (lifted,) = [e["t"] for e in log.events_of("outcome") if e["node"] == "lifting"]
    _assert_stored(log, int(np.searchsorted(log.poses("child")[0], lifted)) - 1)


@pytest.mark.slow
def test_independent_docking_repositions_onto_the_entry_line_then_docks(tmp_path):
    """Experiment III's baseline: the mother holds still; the child estimates the entry line from its first view."""
    result = marsupial.run("ugv_docking_independent", log=tmp_path / "independent.mcap")
    assert result.outcome == "success", result.message
    log = marsupial.read_log(result.log_path)
    outcomes = {e["node"]: (e["t"], e["status"]) for e in log.events_of("outcome")}
    repositioned_at, status = outcomes["child repositioning"]
    assert status == "SUCCESS" and outcomes["lifting"][1] == "SUCCESS"
    t, p_child, q_child = log.poses("child", orientation=True)
    _, p_mother = log.poses("mother")
    assert np.linalg.norm(p_mother[-1][:2] - p_mother[0][:2]) < 0.01  # static: nothing turned the entrance
    i = int(np.searchsorted(t, repositioned_at))
    yaw = math.atan2(*(rotation_matrix(q_child[i])[:, 0])[1::-1])
    # on the entry line y = 0 (truth), 0.6 m before E (x = -0.45 - 0.6 + the camera's lead), facing in (+x)
    assert abs(p_child[i][1]) < 0.05 and abs(yaw) < math.radians(8.0)
    assert -1.15 < p_child[i][0] < -0.85
    _assert_stored(log)


def test_carry_refuses_an_empty_platform_and_release_lowers_it_and_backs_the_child_out():
    with World(scene="marsupial_yard", seed=2) as world:
        mother = world.add_robot("mother_ugv", name="mother", pose=[0.0, 0.0, 0.0])
        child = world.add_robot("child_ugv", name="child", pose=[-1.5, 0.0, 0.0])
        h = Harness(world)
        assert h.run(h.node(Carry, "mother", target=(0.5, 0.0)), 1.0) == Status.FAILURE  # nothing stored
        mother.store(child)
        z_stored = child.pose()[0][2]
        tree = py_trees.composites.Sequence("carry and release", memory=True, children=[
            h.node(Carry, "mother", target=(0.5, 0.0), tolerance=0.05),
            h.node(Release, "mother", child="child", distance=0.5),
        ])
        assert h.run(tree, 30.0) == Status.SUCCESS
        assert child.carrier is None and not mother.carried and mother.platform_height() < 0.005
        assert z_stored - child.pose()[0][2] == pytest.approx(0.30, abs=0.01)  # back on the floor
        p_entrance, heading = mother.entrance_pose()
        out = np.array([math.cos(heading), math.sin(heading)]) @ (p_entrance - child.pose()[0])[:2]
        assert out - child.size[0] / 2 > 0.1 and not mother.child_on_platform(child)  # its front 10 cm out
        assert np.linalg.norm(mother.pose()[0][:2]) > 0.4  # it was carried first
