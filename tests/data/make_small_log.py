"""Write the small reference run log ``small_run.mcap`` and its timeline ``small_run.timeline.txt``.

Deterministic (no randomness, no wall clock): every channel of the recorder
with a few messages — a world with a floor and three primitive objects, two
robots moving along straight lines, a five-node tree ticked ten times at
10 Hz, battery metrics, a scripted preemption, one 8 x 6 PNG image.
``tests/test_replay.py`` reads the committed files back (reader drift) and
regenerates the log to compare the event sequences (writer drift).

Run ``python tests/data/make_small_log.py`` to refresh the committed files
after a deliberate change of the log format.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import py_trees
import pybullet
from py_trees.common import Status

from marsupial.trees.btxml import TreeTracker
from marsupial.trees.recorder import Recorder
from marsupial.trees.replay import format_timeline, read_log
from marsupial.world import World
from marsupial.world.scene import SceneObject

HERE = Path(__file__).resolve().parent
MISSION_TEXT = "mission: small_run\ntree:\n  sequence:\n    - skill: wait\n"
COMMAND_LINE = "marsupial run small_run --seed 7"
TICK_S = 0.1  # s, 10 Hz tree rate


def _add_objects(world: World) -> None:
    """A box, a cylinder and a sphere as static scene objects (world frame, m)."""
    cid = world.client_id
    specs = [
        ("crate", "box", {"halfExtents": [0.5, 0.25, 0.4]}, {"halfExtents": [0.5, 0.25, 0.4]}, [2.0, 1.0, 0.4]),
        ("barrel", "cylinder", {"radius": 0.3, "height": 0.9}, {"radius": 0.3, "length": 0.9}, [-1.0, 2.0, 0.45]),
        ("ball", "sphere", {"radius": 0.2}, {"radius": 0.2}, [0.0, -2.0, 0.2]),
    ]
    geoms = {"box": pybullet.GEOM_BOX, "cylinder": pybullet.GEOM_CYLINDER, "sphere": pybullet.GEOM_SPHERE}
    for label, shape, col, vis, position in specs:
        collision = pybullet.createCollisionShape(geoms[shape], physicsClientId=cid, **col)
        visual = pybullet.createVisualShape(geoms[shape], rgbaColor=[0.6, 0.4, 0.2, 1.0], physicsClientId=cid, **vis)
        body = pybullet.createMultiBody(0.0, collision, visual, position, physicsClientId=cid)
        world.scene.objects[label] = SceneObject(label, body, shape, tuple(position), ("obstacle",))


def _tree() -> py_trees.behaviour.Behaviour:
    """Takeoff runs 3 ticks, then explore runs until it is preempted by dock at tick 7."""
    takeoff = py_trees.behaviours.StatusQueue(
        "takeoff", queue=[Status.RUNNING, Status.RUNNING, Status.SUCCESS], eventually=Status.SUCCESS
    )
    low_battery = py_trees.behaviours.StatusQueue("battery_low", queue=[Status.FAILURE] * 4, eventually=Status.SUCCESS)
    dock = py_trees.behaviours.Running("dock")
    explore = py_trees.behaviours.Running("explore")
    guarded = py_trees.composites.Sequence("when battery low", memory=False, children=[low_battery, dock])
    priorities = py_trees.composites.Selector("priorities", memory=False, children=[guarded, explore])
    return py_trees.composites.Sequence("mission", memory=True, children=[takeoff, priorities])


def make_small_log(path: Path) -> None:
    """Write the reference run to ``path``."""
    metadata = {"mission": MISSION_TEXT, "mission_name": "small_run", "seed": 7, "command_line": COMMAND_LINE}
    with World(seed=7) as world, Recorder(path, metadata, record_images=True) as rec:
        _add_objects(world)
        rec.log_scene(world)
        rec.log_event(0.0, "run_start", mission="small_run", seed=7)
        root, tracker = _tree(), TreeTracker()
        image = np.zeros((6, 8, 3), dtype=np.uint8)
        image[:, :4] = (255, 0, 0)
        for tick in range(10):
            t = round(tick * TICK_S, 9)
            root.tick_once()
            status = tracker.status(root)
            if status is not None:
                rec.log_tree(t, status)
            rec.log_robot_poses(
                t,
                {
                    "carrier": ([0.5 * t, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]),
                    "uav": ([0.5 * t, 0.0, 0.3 + t], [0.0, 0.0, math.sin(t / 2), math.cos(t / 2)]),
                },
                {  # onboard estimates drifting 1 cm/s ahead of the truth
                    "carrier": ([0.51 * t, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]),
                    "uav": ([0.51 * t, 0.0, 0.3 + t], [0.0, 0.0, math.sin(t / 2), math.cos(t / 2)]),
                },
            )
            rec.log_metric(t, "battery", round(1.0 - 0.05 * tick, 6), robot="uav")
            if tick == 2:
                rec.log_event(t, "state_change", node="takeoff", robot="uav", previous="RUNNING", current="SUCCESS")
                rec.log_event(
                    t, "outcome", node="takeoff", skill="takeoff", robot="uav", status="SUCCESS", message="airborne"
                )
            if tick == 4:
                rec.log_event(t, "operator", command="dock", source="script", why="corridor ahead")
            if tick == 6:
                rec.log_event(t, "preemption", preempted="explore", by="dock", why="battery_below 0.75", robot="uav")
                rec.log_image(t, "uav/camera", image, format="png")
                rec.log_text(t, "warning", "battery low: docking")
        rec.log_event(0.9, "run_end", outcome="success", sim_time=0.9)
        rec.close("success")


def main(out_dir: Path = HERE) -> None:
    """Regenerate ``small_run.mcap`` and ``small_run.timeline.txt`` in ``out_dir``."""
    log_path = out_dir / "small_run.mcap"
    make_small_log(log_path)
    (out_dir / "small_run.timeline.txt").write_text(format_timeline(read_log(log_path)))


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE)
