"""External vision fixes fused by the quadrotors' flight estimator (world/estimation/external.py): delayed
measurements over the team link, a history for late fixes, optical-flow gating only while fixes are recent."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from marsupial.api.readings import VisionFix, vision_fix_topic
from marsupial.world import World
from marsupial.world.estimation.external import VisionFixFusion, VisionFixGains
from marsupial.world.team_link import TeamLinkConfig


def _fix_from_truth(uav, stamp):
    """A fix of the UAV's true pose at ``stamp`` (the test plays the observer; the pose was read then)."""
    p, q = uav.pose()
    return VisionFix(
        stamp, tuple(float(v) for v in p), math.atan2(2 * (q[3] * q[2] + q[0] * q[1]), 1 - 2 * (q[1] ** 2 + q[2] ** 2))
    )


def test_late_fixes_correct_a_drifted_estimate_without_moving_the_vehicle():
    with World(seed=3) as world:
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.5, 0.0])
        world.step(1.0)
        p_true = uav.pose()[0]
        uav.estimator.reset(p_true + np.array([0.3, -0.2, 0.0]), 0.0)  # the estimate 36 cm off
        world.step(0.2)
        start = uav.pose()[0]
        pending = []  # fixes measured now, sent 0.1 s later (camera latency, processing): 0.12-0.15 s late on arrival
        for _ in range(50):
            pending.append(_fix_from_truth(uav, world.now))
            world.step(0.1)
            world.team_link.send("observer", vision_fix_topic(uav.name), pending.pop(0))
        error = np.linalg.norm(uav.estimator.estimate().position - uav.pose()[0])
        assert uav.estimator.fixes.fused >= 45  # 2 % of the messages are lost
        assert error < 0.02  # 36 cm worked off in 5 s
        assert np.linalg.norm((uav.pose()[0] - start)[:2]) < 0.1  # a frame shift: the autopilot's references followed


def test_a_fix_older_than_the_history_is_ignored():
    with World(seed=4, team_link=TeamLinkConfig(drop=0.0)) as world:  # the one message must arrive
        uav = world.add_robot("bebop2", pose=[0.0, 0.0, 1.5, 0.0])
        world.step(1.0)
        old = _fix_from_truth(uav, world.now)
        uav.estimator.reset(uav.pose()[0] + np.array([0.3, 0.0, 0.0]), 0.0)  # the history starts anew
        world.step(0.6)
        before = uav.estimator.estimate().position.copy()
        world.team_link.send("observer", vision_fix_topic(uav.name), VisionFix(world.now - 0.7, old.position, old.yaw))
        world.step(0.1)
        fixes = uav.estimator.fixes
        assert fixes.stale == 1 and fixes.fused == 0
        assert abs(uav.estimator.estimate().position[0] - before[0]) < 0.01  # only the hover's own drift


class _Source:
    """A radio that delivers the fixes handed to it (a stand-in for ``TeamLink.latest_on``)."""

    def __init__(self):
        self.message = None

    def deliver(self, fix):
        self.message = SimpleNamespace(payload=fix)

    def __call__(self):
        return self.message


def _fusion_with_history(t_end=1.0, rate=120.0):
    source = _Source()
    fusion = VisionFixFusion(source, VisionFixGains())
    for k in range(int(t_end * rate) + 1):
        fusion.record(k / rate, [0.5 * k / rate, 0.0, 1.0], 0.0)  # flying at 0.5 m/s along x
    return fusion, source


def test_a_late_fix_is_compared_with_the_estimate_at_its_stamp():
    fusion, source = _fusion_with_history()
    source.deliver(VisionFix(0.8, (0.42, 0.0, 1.0), 0.0))  # the estimate read 0.40 at 0.8 s, 0.50 now
    dpx, dpy, dpz, dvx, _, _, dyaw, dbx, _, _ = fusion.poll()
    g = fusion.gains
    assert math.isclose(dpx, g.position * g.max_dt * 0.02, rel_tol=1e-6)  # innovation +2 cm (not -8 cm against now)
    assert math.isclose(dvx, g.velocity * g.max_dt * 0.02, rel_tol=1e-6) and dpy == dpz == dyaw == 0.0
    assert math.isclose(dbx, -g.bias * g.max_dt * 0.02, rel_tol=1e-6)  # the accelerometer bias, too
    assert fusion.poll() is None  # the same message is fused once


def test_flow_outliers_are_gated_only_while_fixes_are_recent():
    fusion, source = _fusion_with_history()
    assert not fusion.flow_rejected(1.0, 0.5, 0.0)  # no fix yet: the flow is the velocity reference
    source.deliver(VisionFix(0.9, (0.45, 0.0, 1.0), 0.0))
    assert fusion.poll() is not None
    assert fusion.flow_rejected(1.0, 0.5, 0.0)  # a flow over the deck, off by the carrier's speed
    assert not fusion.flow_rejected(1.0, 0.05, 0.05)  # within the gate: fused
    assert not fusion.flow_rejected(0.9 + fusion.gains.timeout + 0.01, 0.5, 0.0)  # fixes no longer recent
    far, source_far = _fusion_with_history()
    source_far.deliver(VisionFix(0.9, (1.45, 0.0, 1.0), 0.0))  # 1 m off: an offset of the frame, not converged
    dpx, _, _, dvx, _, _, _, dbx, _, _ = far.poll()
    assert math.isclose(dpx, far.gains.position * far.gains.max_dt * far.gains.innovation_limit, rel_tol=1e-6)
    assert dvx == dbx == 0.0 and not far.flow_rejected(1.0, 0.5, 0.0)


def test_relative_pose_propagates_without_the_jumps_of_the_uavs_frame_corrections():
    from marsupial.api.readings import StateEstimate
    from marsupial.geometry import quaternion_from_yaw
    from marsupial.skills.uav_docking.relative_pose import unshifted

    shift0 = (0.1, 0.0, -0.05, 0.02)
    moved = StateEstimate(
        3.0, "odom", np.array([1.0, 2.0, 1.2]), quaternion_from_yaw(0.5), frame_shift=(0.1, 0.03, 0.15, 0.12)
    )
    back = unshifted(moved, shift0)
    assert list(back.position) == pytest.approx([1.0, 1.97, 1.0])  # the 20 cm height correction taken out
    assert back.yaw == pytest.approx(0.4) and back.frame_shift == shift0
    assert unshifted(back, shift0) is back
