"""How fast the world runs: physics steps/s, camera ms/frame, estimator µs/update and real-time factor.

    python benchmarks/world_speed.py [--quick] [--out benchmarks/out/world_speed.json] [--profile]

Four measurements in the ``open_field`` scene with the robots of the
Palafox and Narváez set-ups, and the default mission's profile, in a single thread:

1. Physics steps per wall second of ``World.step`` with a hovering ``bebop2``
   and a driving ``summit_xl`` (controllers, drag, battery), next to bare
   ``pybullet.stepSimulation`` on the same bodies for reference (gravity
   off there, so that the bebop2 floats as if hovering instead of landing).
2. Camera milliseconds per frame (``Camera.measure``: render + depth, floor
   fill, colour conversion) at 320×240 and 640×480 for realistic views: the
   ``ardrone2`` vertical camera over the ``summit_xl`` landing platform, the
   ``bebop2`` front camera behind the ``summit_xl``, and the
   ``mobile_manipulator`` eye-in-hand camera under a hovering ``bebop2``;
   the TinyRenderer share is timed separately.
3. Onboard estimators: wall µs per ``update`` call (median) and per
   simulated second, timed inside a run — the ``bebop2``'s
   ``FlightEstimator`` (120 Hz, including the IMU sample and the flow, sonar
   and barometer samples it triggers), the ``summit_xl``'s ``WheelOdometry``
   (called every physics step, integrating at 48 Hz) and a
   ``mobile_manipulator``'s ``MapLocalization`` (odometry + 5 Hz map fixes),
   next to the ``Autopilot`` update for scale.
4. Real-time factor (simulated s / wall s) of a run in which the ``bebop2``
   follows a slowly moving set-point on its own estimate and the
   ``summit_xl`` drives a circle, controlled at 30 Hz, (a) without cameras
   and (b) reading the bebop2's 320×240 front camera (noise, drops, latency
   on, as by default) at 30 Hz, every frame. Targets: ≥ 50× and ≥ 3×.

Other processes slow a wall-clock benchmark down, never up: every figure is
the best of several repetitions (``--quick``: fewer and shorter).

5. Where the default mission's time goes (``benchmarks/profile_breakdown.py``):
   the engine's share (pybullet's ``stepSimulation``, ``getCameraImage``,
   ``rayTestBatch``) of a timed run, and the Python time by module of a
   cProfile run; with ``--quick`` its first 60 simulated seconds.

``--profile`` adds the top functions (cProfile, by own time) of both runs of 4.
Prints a table and writes everything as JSON. Wall-clock timing lives here
only: the world itself never reads the clock.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import math
import pstats
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pybullet

if not __package__:  # run as a file (python benchmarks/<name>.py): the benchmarks package from the repository
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from benchmarks.bench_common import best_seconds, machine_info, print_tables, write_report
from benchmarks.profile_breakdown import QUICK_UNTIL_S, breakdown, breakdown_sections
from marsupial.api.model import Intrinsics
from marsupial.trees.cli import DEFAULT_MISSION
from marsupial.world import World
from marsupial.world.sensors.base import SensorConfig
from marsupial.world.sensors.camera import Camera

TARGET_RTF_WITHOUT_CAMERA = 50.0
TARGET_RTF_WITH_CAMERA = 3.0
CONTROL_HZ = 30.0  # rate at which the scripted controllers command the robots
DEFAULT_OUT = Path(__file__).resolve().parent / "out" / "world_speed.json"


# ------------------------------------------------------------------ helpers
def single_threaded() -> str:
    """Keep the benchmark on one core's worth of work; returns a description for the report.

    pybullet DIRECT and the world's Python run in one thread; OpenCV would
    spread a colour conversion over threads, so it is limited to one. The
    process is not pinned to a core: on a shared machine the scheduler then
    moves it to whichever core is free.
    """
    cv2.setNumThreads(1)
    return "single thread (pybullet DIRECT, cv2.setNumThreads(1)), not pinned"



def field_with_pair(seed: int = 0) -> World:
    """``open_field`` with a bebop2 hovering at 1.5 m and a summit_xl 4 m ahead of it."""
    world = World("open_field", seed=seed)
    world.add_robot("bebop2", "uav", pose=[0.0, 0.0, 1.5, 0.0])
    world.add_robot("summit_xl", "ugv", pose=[4.0, 0.0, 0.0])
    return world


# ------------------------------------------------------------------ physics
def bench_physics(quick: bool) -> dict[str, Any]:
    """Physics steps per wall second: World.step with controllers, and bare stepSimulation."""
    steps = 2400
    with field_with_pair() as world:
        world.robot("ugv").drive(0.5, 0.05)
        world.step(1.0)  # let the controllers settle
        world_s = best_seconds(lambda: world.step(steps / world.clock.physics_hz), 3 if quick else 10)
    with field_with_pair() as world:
        cid = world.client_id
        pybullet.setGravity(0.0, 0.0, 0.0, physicsClientId=cid)

        def bare() -> None:
            for _ in range(steps):
                pybullet.stepSimulation(physicsClientId=cid)

        bare_s = best_seconds(bare, 3 if quick else 10)
    return {
        "steps": steps,
        "world_steps_per_s": steps / world_s,
        "world_us_per_step": 1e6 * world_s / steps,
        "bare_pybullet_steps_per_s": steps / bare_s,
        "bare_pybullet_us_per_step": 1e6 * bare_s / steps,
    }


# ------------------------------------------------------------------ cameras
def _camera_like(camera: Camera, width: int, height: int) -> Camera:
    """A camera on the same robot, link and mount as ``camera`` at another resolution (same vertical FOV)."""
    i = camera.intrinsics
    return Camera(
        camera.robot, f"bench_{width}x{height}", Intrinsics(width, height, i.fov_v_deg, i.near, i.far),
        SensorConfig(rate_hz=camera.config.rate_hz), link=camera.link, offset=tuple(camera.offset),
        R_link_optical=camera.R_link_optical,
    )


def _camera_views() -> list[tuple[str, World, Camera]]:
    """(view, world, camera) of the realistic views; every world is closed by the caller."""
    views = []
    world = World("open_field")
    world.add_robot("summit_xl", "ugv", pose=[0.0, 0.0, 0.0])
    uav = world.add_robot("ardrone2", "uav", pose=[0.3, -0.2, 4.0, 0.4])  # Palafox: tracking at 4 m
    views.append(("ardrone2 vertical camera, summit_xl platform 3.6 m below", world, uav.sensor("uav/bottom_camera")))
    world = World("open_field")
    world.add_robot("summit_xl", "ugv", pose=[3.0, 0.0, 0.0])
    uav = world.add_robot("bebop2", "uav", pose=[0.0, 0.0, 1.2, 0.0])
    views.append(("bebop2 front camera, summit_xl 3 m ahead", world, uav.sensor("uav/front_camera")))
    world = World("open_field")
    carrier = world.add_robot("mobile_manipulator", "carrier", pose=[0.0, 0.0, 0.0], arm_pose="docking_ready")
    p_part_a, _ = carrier.link_pose("part_a")
    world.add_robot("bebop2", "uav", pose=[p_part_a[0] - 0.11, p_part_a[1], p_part_a[2] + 0.9, 0.0])
    views.append(("mobile_manipulator eye-in-hand, bebop2 0.9 m above", world, carrier.eye_in_hand))
    return views


def bare_render(camera: Camera) -> Callable[[], Any]:
    """A call rendering ``camera``'s present view with TinyRenderer alone (no depth, floor or colour work)."""
    position, R = camera.optical_pose()
    view = pybullet.computeViewMatrix(list(position), list(position + R[:, 2]), list(-R[:, 1]))
    i, projection, cid = camera.intrinsics, camera.intrinsics.projection_matrix(), camera.world.client_id
    return lambda: pybullet.getCameraImage(
        i.width, i.height, view, projection, renderer=pybullet.ER_TINY_RENDERER,
        flags=pybullet.ER_NO_SEGMENTATION_MASK, physicsClientId=cid,
    )


def bench_cameras(quick: bool) -> list[dict[str, Any]]:
    """ms per frame of Camera.measure at 320×240 and 640×480, with the TinyRenderer share."""
    frames = 30 if quick else 150
    rows = []
    for view, world, own in _camera_views():
        with world:
            world.step(0.5)
            for width, height in ((320, 240), (640, 480)):
                i = own.intrinsics
                camera = own if (i.width, i.height) == (width, height) else _camera_like(own, width, height)
                camera.measure()  # warm up the renderer's buffers
                render = bare_render(camera)
                # frame by frame, a measure and a bare render of the same view: their difference is
                # the work after the render (robust to load as a median of paired differences)
                pairs = [(best_seconds(camera.measure, 1), best_seconds(render, 1)) for _ in range(frames)]
                measure_s = min(m for m, _ in pairs)
                render_s = min(r for _, r in pairs)
                post_s = float(np.median([m - r for m, r in pairs]))
                frame = camera.measure()
                floor_rgb = np.array(world.scene.floor.rgb, dtype=np.uint8)
                drawn = (frame.depth < 0.999 * camera.intrinsics.far) & (frame.rgb != floor_rgb).any(axis=2)
                rows.append({
                    "view": view,
                    "resolution": f"{width}x{height}",
                    "ms_per_frame": 1e3 * measure_s,
                    "render_ms": 1e3 * render_s,
                    "post_ms": 1e3 * post_s,
                    "robot_pixels_percent": 100.0 * float(drawn.mean()),
                })
    return rows


# --------------------------------------------------------------- estimators
def _timed(owner: Any, method: str, times: list[float]) -> None:
    """Replace ``owner.method`` by a wrapper appending each call's wall time (s) to ``times``."""
    original = getattr(owner, method)

    def timed(*args: Any, **kwargs: Any) -> Any:
        start = time.perf_counter()
        result = original(*args, **kwargs)
        times.append(time.perf_counter() - start)
        return result

    setattr(owner, method, timed)


def bench_estimators(quick: bool) -> list[dict[str, Any]]:
    """Wall µs per update (median) and per simulated second of the onboard estimators, timed in a run."""
    seconds = 10.0 if quick else 30.0
    with field_with_pair() as world:
        uav, ugv = world.robot("uav"), world.robot("ugv")
        carrier = world.add_robot("mobile_manipulator", "carrier", pose=[-3.0, 0.0, 0.0], localization="map")
        timed = {
            "FlightEstimator.update (bebop2, 120 Hz)": (uav.estimator, "update"),
            "Autopilot.update (bebop2, 120 Hz; for scale)": (uav.autopilot, "update"),
            "WheelOdometry.update (summit_xl, every step, 48 Hz samples)": (ugv.estimator, "update"),
            "MapLocalization.update (mobile_manipulator, odometry + 5 Hz fixes)": (carrier.estimator, "update"),
        }
        times: dict[str, list[float]] = {label: [] for label in timed}
        for label, (owner, method) in timed.items():
            _timed(owner, method, times[label])
        ugv.drive(0.5, 0.05)
        carrier.drive(0.5, -0.05)
        tick = 1.0 / CONTROL_HZ
        while world.now < seconds - 1e-9:
            t = world.now
            uav.command_velocity(0.5 * math.cos(0.3 * t), 0.5 * math.sin(0.3 * t), 0.0, frame="world")
            world.step(tick)
        return [
            {
                "estimator": label,
                "calls_per_sim_s": len(samples) / world.now,
                "median_us_per_call": 1e6 * float(np.median(samples)),
                "us_per_sim_s": 1e6 * float(np.sum(samples)) / world.now,
            }
            for label, samples in times.items()
        ]


# ---------------------------------------------------------------- real time
def fly_and_drive(seconds: float, read_camera: bool, profile: cProfile.Profile | None = None) -> dict[str, Any]:
    """Real-time factor of ``seconds`` of the bebop2 following a moving set-point and the summit_xl circling."""
    with field_with_pair() as world:
        uav, ugv = world.robot("uav"), world.robot("ugv")
        camera = uav.sensor("uav/front_camera")
        ugv.drive(0.5, 0.05)  # Palafox's circular track: 10 m radius commanded
        tick = 1.0 / CONTROL_HZ
        if profile is not None:
            profile.enable()
        start = time.perf_counter()
        while world.now < seconds - 1e-9:
            t = world.now
            # set-point circling 2 m around the origin once every 31 s, bobbing ±0.3 m, tracked on the
            # UAV's own estimate (odom frame, as "world" commands are)
            target = np.array([2.0 * math.cos(0.2 * t), 2.0 * math.sin(0.2 * t), 1.5 + 0.3 * math.sin(0.1 * t)])
            position = uav.estimator.estimate().position
            v = np.clip(1.0 * (target - position), -1.0, 1.0)
            uav.command_velocity(*v, frame="world")
            if read_camera:
                camera.read()
            world.step(tick)
        wall = time.perf_counter() - start
        if profile is not None:
            profile.disable()
        return {
            "sim_s": world.now,
            "wall_s": wall,
            "real_time_factor": world.now / wall,
            "frames_rendered": camera.samples_taken,
            "us_per_physics_step": 1e6 * wall / world.clock.steps,
            "uav_tracking_error_m": float(np.linalg.norm(uav.estimator.estimate().position - target)),
            "uav_estimate_error_m": float(np.linalg.norm(uav.estimator.estimate().position - uav.pose()[0])),
        }


def bench_real_time(quick: bool, profile: bool) -> tuple[dict[str, Any], dict[str, str]]:
    """Real-time factors without and with the camera (best run of a few), and their profiles if asked for."""
    seconds = 10.0 if quick else 60.0
    results, profiles = {}, {}
    for key, read_camera, repeats in (("without_camera", False, 8), ("with_camera_320x240_30hz", True, 2)):
        runs = [fly_and_drive(seconds, read_camera) for _ in range(1 if quick else repeats)]
        results[key] = max(runs, key=lambda run: run["real_time_factor"])
        results[key]["runs"] = len(runs)
        if profile:
            prof = cProfile.Profile()
            fly_and_drive(min(seconds, 10.0), read_camera, prof)
            out = io.StringIO()
            pstats.Stats(prof, stream=out).sort_stats("tottime").print_stats(14)
            profiles[key] = out.getvalue()
    results["without_camera"]["target"] = TARGET_RTF_WITHOUT_CAMERA
    results["with_camera_320x240_30hz"]["target"] = TARGET_RTF_WITH_CAMERA
    return results, profiles


# ------------------------------------------------------------------- report
def print_report(report: dict[str, Any]) -> None:
    """Print the results as tables (rich if installed, plain text otherwise)."""
    physics = report["physics"]
    sections = [
        (
            "Physics (open_field, bebop2 + summit_xl)",
            ["what", "steps/s", "µs/step"],
            [
                ["World.step (controllers on)", f"{physics['world_steps_per_s']:.0f}",
                 f"{physics['world_us_per_step']:.1f}"],
                ["bare pybullet.stepSimulation (gravity off)", f"{physics['bare_pybullet_steps_per_s']:.0f}",
                 f"{physics['bare_pybullet_us_per_step']:.1f}"],
            ],
        ),
        (
            "Camera.measure: best frame, TinyRenderer alone, and the work after it (median)",
            ["view", "resolution", "ms/frame", "render ms", "post ms", "robot px %"],
            [
                [r["view"], r["resolution"], f"{r['ms_per_frame']:.2f}", f"{r['render_ms']:.2f}", f"{r['post_ms']:.2f}",
                 f"{r['robot_pixels_percent']:.1f}"]
                for r in report["cameras"]
            ],
        ),
        (
            "Onboard estimators, timed inside a run (wall µs)",
            ["update", "calls / sim s", "µs / call (median)", "µs / sim s"],
            [
                [r["estimator"], f"{r['calls_per_sim_s']:.0f}", f"{r['median_us_per_call']:.1f}",
                 f"{r['us_per_sim_s']:.0f}"]
                for r in report["estimators"]
            ],
        ),
        (
            "Real-time factor (bebop2 following a set-point + summit_xl circling)",
            ["run", "sim s", "wall s", "RTF", "target", "frames", "µs/step"],
            [
                [key, f"{r['sim_s']:.0f}", f"{r['wall_s']:.2f}", f"{r['real_time_factor']:.1f}×",
                 f"≥ {r['target']:.0f}× {'ok' if r['real_time_factor'] >= r['target'] else 'MISSED'}",
                 str(r["frames_rendered"]), f"{r['us_per_physics_step']:.1f}"]
                for key, r in report["real_time"].items()
            ],
        ),
    ]
    print_tables(sections + breakdown_sections(report["profile"]), report["machine"])
    for key, text in report.get("profiles", {}).items():
        print(f"\nprofile of {key}:\n{text}")


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print the tables, write the JSON report; returns the report."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="short runs (10 s of simulation, fewer frames; 60 s of the default mission profiled)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="JSON report path")
    parser.add_argument("--profile", action="store_true", help="also print cProfile summaries of the real-time runs")
    args = parser.parse_args(argv)
    threads = single_threaded()
    report: dict[str, Any] = {
        "machine": machine_info(threads=threads, quick=args.quick),
        "physics": bench_physics(args.quick),
        "cameras": bench_cameras(args.quick),
        "estimators": bench_estimators(args.quick),
    }
    report["real_time"], profiles = bench_real_time(args.quick, args.profile)
    if profiles:
        report["profiles"] = profiles
    report["profile"] = breakdown(DEFAULT_MISSION, QUICK_UNTIL_S if args.quick else None)
    print_report(report)
    write_report(report, args.out)
    return report


if __name__ == "__main__":
    main()
