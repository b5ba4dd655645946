"""Inserting and launching a micro-scout through an aperture (Arora & Papachristos §IV-F): ``insert_scout`` and
``launch_scout`` after the scan, approach and profile analysis, with the referee's rim contacts read from the log.

The skills decide from the onboard interface; the referee and the assertions use truth.
"""

from __future__ import annotations

import fcl
import numpy as np
import py_trees
import pytest
from py_trees.common import Status
from skill_harness import Harness

from marsupial.skills.aperture.analyze import AnalyzeAperture
from marsupial.skills.aperture.approach import ApproachAperture
from marsupial.skills.aperture.insert import InsertScout
from marsupial.skills.aperture.insertion import Rim, rim_objects, voxels_off_the_opening
from marsupial.skills.aperture.launch import LaunchScout
from marsupial.skills.aperture.launch_pose import D_L_M
from marsupial.skills.aperture.scan import ApertureScan
from marsupial.skills.aperture.takeoff import ScoutTakeoff
from marsupial.trees.replay import read_log
from marsupial.world import World

WALL_FRONT_Y, WALL_BACK_Y = -0.05, 0.05  # the mockup wall's faces (collapsed_mockup.yaml: y = 0, 0.1 m thick)


def _opening(width: float = 0.2, height: float = 0.12) -> Rim:
    """A rectangular opening in a plane facing −y at y = WALL_FRONT_Y, centred at (0, ·, 1)."""
    corners = np.array([[-width / 2, WALL_FRONT_Y, 1 - height / 2], [width / 2, WALL_FRONT_Y, 1 - height / 2],
                        [width / 2, WALL_FRONT_Y, 1 + height / 2], [-width / 2, WALL_FRONT_Y, 1 + height / 2]])
    R = np.column_stack(((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)))  # u, v in the plane; n̂ toward −y
    return Rim(corners, R, np.array([0.0, WALL_FRONT_Y, 1.0]))


def _touches(objects, box_size, centre) -> bool:
    box = fcl.CollisionObject(fcl.Box(*box_size), fcl.Transform(np.asarray(centre, dtype=float)))
    request = fcl.CollisionRequest(gjk_solver_type=fcl.GJKSolverType.GST_INDEP)
    return any(fcl.collide(box, o, request, fcl.CollisionResult()) for o in objects)


def test_the_rim_model_lets_a_body_through_the_opening_and_stops_one_across_its_edge():
    rim = _opening()
    objects = rim_objects(rim, np.eye(4), wall_depth=0.1)
    mav = (0.09, 0.1, 0.04)  # across, along the insertion, up (m)
    assert not _touches(objects, mav, (0.0, 0.0, 1.0))  # centred in the 0.2 × 0.12 m opening, inside the wall
    assert not _touches(objects, mav, (0.05, 0.0, 1.0))  # 0.5 cm from the side
    assert _touches(objects, mav, (0.07, 0.0, 1.0))  # 1.5 cm across the side
    assert _touches(objects, mav, (0.0, 0.0, 1.05))  # 1 cm into the head
    assert not _touches(objects, mav, (0.0, 0.12, 1.05))  # beyond the wall's back face


def test_the_rim_closes_convex_corners_and_stays_out_of_the_opening_at_reflex_ones():
    # an L-shaped opening: 0.3 × 0.1 m along the bottom and 0.1 m wide up the left, its reflex corner at (-0.05, 1.0)
    uv = np.array([[-0.15, 0.9], [0.15, 0.9], [0.15, 1.0], [-0.05, 1.0], [-0.05, 1.2], [-0.15, 1.2]])
    contour = np.c_[uv[:, 0], np.full(len(uv), WALL_FRONT_Y), uv[:, 1]]
    R = np.column_stack(((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)))
    objects = rim_objects(Rim(contour, R, np.array([-0.1, WALL_FRONT_Y, 0.95])), np.eye(4), wall_depth=0.1)
    probe = (0.01, 0.02, 0.01)  # a 1 cm probe in the wall's middle
    assert not _touches(objects, probe, (-0.04, 0.0, 0.99))  # inside, 1 cm from the reflex corner
    assert _touches(objects, probe, (0.17, 0.0, 1.02))  # off the convex corner (0.15, 1.0), beyond both edges
    assert _touches(objects, probe, (-0.03, 0.0, 1.02))  # in the wall beside the reflex corner


def test_the_voxels_in_the_opening_are_left_to_the_rim():
    rim = _opening()
    centres = np.array([[0.0, 0.0, 1.0], [0.11, 0.0, 1.0], [0.2, 0.0, 1.0], [0.0, 0.0, 1.2], [0.0, -0.5, 1.0]])
    kept, _ = voxels_off_the_opening(centres, np.full(5, 0.03), rim, wall_depth=0.1)
    # inside, and 1 cm outside the side (its box reaches in), go; 10 cm beside, 14 cm above, 0.45 m in front stay
    assert kept.tolist() == centres[2:].tolist()


def test_a_stray_apparatus_against_the_wall_is_a_rim_contact_in_the_log(tmp_path):
    with World(scene="collapsed_mockup", seed=3) as world:
        mms = world.add_robot("mms", "mms", pose=[0.3, -2.4, 1.5708])
        harness = Harness(world, log_path=tmp_path / "stray.mcap")
        apparatus = mms.launch_apparatus("holster_left")
        apparatus.unlatch()
        world.bullet.resetBasePositionAndOrientation(apparatus.body_id, [-1.5, WALL_FRONT_Y - 0.1, 0.8], [0, 0, 0.7071,
                                                                                                           0.7071])
        world.step(0.5)
        harness.close()
    log = read_log(tmp_path / "stray.mcap")
    touches = log.events_of("rim_contact")
    assert touches and touches[0]["carrier"] == "mms" and touches[0]["wall"] == "mockup_wall_1"
    assert {t["part"] for t in touches} <= {apparatus.name, apparatus.mav.name}
    _, counts = log.metric("rim_contacts", robot="mms")
    assert counts[-1] == len(touches)


@pytest.mark.slow
def test_the_mms_slips_a_scout_through_the_aperture_launches_it_and_stows_the_apparatus_without_rim_contact(tmp_path):
    with World(scene="collapsed_mockup", seed=3) as world:
        mms = world.add_robot("mms", "mms", pose=[0.3, -2.4, 1.5708])
        harness = Harness(world, log_path=tmp_path / "insert.mcap")
        tello = mms.holsters["holster_right"].mav
        nodes = [harness.node(ApertureScan, "mms"), harness.node(ApproachAperture, "mms"),
                 harness.node(AnalyzeAperture, "mms"), harness.node(InsertScout, "mms", holster="holster_right")]
        launch = [harness.node(LaunchScout, "mms", scout=tello.name),
                  harness.node(ScoutTakeoff, tello.name, carrier="mms")]
        nodes.append(py_trees.composites.Parallel(
            "launch", py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=True), children=launch))
        root = py_trees.composites.Sequence("deploy", memory=True, children=nodes)
        at_launch = {}

        def watch():  # truth, for the assertions: where the MAV was when the apparatus let it go
            if not tello.docked:
                at_launch.setdefault("position", tello.pose()[0])

        status = harness.run(root, 150.0, on_tick=watch)
        assert status == Status.SUCCESS, [n.feedback_message for n in nodes[:4] + launch]
        assert mms.launch_apparatus("holster_right").latched and mms.held is None  # back in its holster
        assert tello.pose()[0][1] > WALL_BACK_Y  # the scout is behind the wall
        harness.close()
    assert at_launch["position"][1] - 0.05 > WALL_BACK_Y  # released with its tail past the wall's back face
    log = read_log(tmp_path / "insert.mcap")
    arm_nodes = {nodes[3].name, launch[0].name}
    phases = [e["phase"] for e in log.events_of("state_change") if e.get("node") in arm_nodes and "phase" in e]
    assert phases == ["grasped", "insertion_plan", "phase1", "phase2", "phase3", "launched", "cleared", "stowed"]
    plan = next(e for e in log.events_of("state_change") if e.get("phase") == "insertion_plan")
    assert 0.16 <= plan["depth"] <= D_L_M and plan["plan"]["feasible"]
    _, counts = log.metric("rim_contacts", robot="mms")
    assert counts.size and counts[-1] == 0 and not log.events_of("rim_contact")
