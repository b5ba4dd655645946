"""Micro-scout deployment through apertures of Arora & Papachristos, side by side with the paper: Table I, ranking.

    python benchmarks/aperture.py [--quick] [--workers N] [--runs DIR] [--scans 50] [--repeats 20] [--trials 100]
                                  [--seeds 10] [--only insertion|mission]
                                  [--out benchmarks/out/aperture.json] [--report docs/results/aperture.md]

Sections (each a function filling one key of the results; the JSON and the
page follow the same order):

1. ``table_i`` — Table I (§IV-E): CPU time of the profile analysis
   (``profile_analysis``, Algorithm 1) per aperture shape class, on one core
   (``time.thread_time``), best and median of ``--repeats`` calls, on two
   masks of each real opening of ``collapsed_mockup``: the exact opening
   rasterised at the pixel size of the MMS's eye-in-hand camera 0.6 m from
   the wall, and the contour its detection (§IV-B) finds in three depth
   frames rendered from there. Paper: 0.88 / 0.97 / 1.10 / 1.13 s; target
   ≤ 0.1 s per shape (median, exact mask).
2. ``ranking`` — detection ranking with decoys (§IV-B/C, Fig. 5 b–d):
   ``--scans`` (50) seeded runs of ``benchmarks/missions/aperture_ranking.yaml``
   through the campaign runner: the MMS's start pose drawn within the
   approach area, a shallow recess and two holes too small for the MAV cut
   into each wide wall segment (``world.disturbances.decoys``, seeded), one
   ``aperture_scan``. A scan succeeds when its first-ranked candidate (event
   ``ranked``) has its centre within 0.1 m of the centre of a real aperture
   (zones tagged ``aperture``), not a decoy (tag ``decoy``). Target: ≥ 95 %,
   reported with its Wilson 95 % interval.
3. ``insertion`` — ``--trials`` (100) insertion trials through tight apertures (§IV-E/F,
   :mod:`aperture_insertion`): ``benchmarks/missions/aperture_insertion.yaml``, a quarter per shape class,
   the Tello's clearance in the reshaped opening drawn in 1–3 cm (``world.disturbances.aperture_fit``) and the
   MMS's start pose around the aperture (``pose_spread``); inserted, launched, rim contacts and the reasons
   of failures, per shape and per clearance band, from the logs. Target: ≥ 95/100 with 0 rim contacts.
4. ``mission`` — ``missions/aperture_scouts.yaml`` over ``--seeds`` (10) seeds, both objects found
   (:mod:`aperture_mission`). Target: ≥ 9/10.

Figures (``docs/results/img/aperture_*.png``): like Fig. 4 (I_binary, I_canny,
C_a, a valid configuration and a rejected one per shape) and like Fig. 5
(the decoy wall as the camera sees it, one scan's detections and ranking, the
first-ranked candidates of every scan). ``--quick``: 6 scans, 5 repeats.
``--runs DIR`` keeps the campaign and its logs and reads back the seeds already
run with the same plan. ``--only insertion`` (``--only mission``) runs that section alone and merges
it into the existing page (its section and its row of the targets) and JSON,
leaving the other sections as they are (hand-written notes included). Prints
the targets; exits with 1 when one is missed.
"""

from __future__ import annotations

import json
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np

if not __package__:  # run as a file (python benchmarks/<name>.py): the benchmarks package from the repository
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from benchmarks.aperture_insertion import INSERTION_HEADING, insertion_lines, insertion_trials, plot_insertion
from benchmarks.aperture_insertion import verdict as insertion_verdict
from benchmarks.aperture_mission import MISSION_HEADING, mission_lines, mission_seeds
from benchmarks.aperture_mission import verdict as mission_verdict
from benchmarks.bench_common import (
    campaign,
    campaign_arguments,
    command_line,
    conclude,
    machine_info,
    print_tables,
    print_targets,
    targets_lines,
    write_report,
)
from benchmarks.page_merge import merge_section, merge_target_row
from marsupial.api.config import Disturbances
from marsupial.skills.aperture import DetectionParams, ProfileParams, detect_apertures, mav_contour, profile_analysis
from marsupial.skills.aperture.detection import ApertureCandidate, eye_in_hand_frame
from marsupial.skills.aperture.profile import LaunchConfiguration
from marsupial.skills.aperture.scan import LEVEL_POSE
from marsupial.tools.rig import live_view
from marsupial.trees.campaign import WILSON_Z, wilson_interval
from marsupial.trees.mission import load_mission
from marsupial.trees.replay import RunLog, read_log
from marsupial.world import World
from marsupial.world.apertures import aperture_outline, rasterised
from marsupial.world.disturbances import apply_disturbances
from marsupial.world.robots.mms import CAMERA_INTRINSICS
from marsupial.world.scene import Zone

HERE = Path(__file__).resolve().parent
MISSION = HERE / "missions" / "aperture_ranking.yaml"
DEFAULT_OUT = HERE / "out" / "aperture.json"
DEFAULT_REPORT = HERE.parent / "docs" / "results" / "aperture.md"

SHAPES = ("orthogonal", "collapsed", "amoeba", "u")
SHAPE_NAMES = {"orthogonal": "orthogonal (fully convex)", "collapsed": "collapsed (light concave)",
               "amoeba": "amoeba (concave)", "u": "U-shaped (highly concave)"}
PAPER_TABLE_I_S = {"orthogonal": 0.88, "collapsed": 0.97, "amoeba": 1.10, "u": 1.13}  # Table I, average [s]
TABLE_I_TARGET_S = 0.1
RANKING_TARGET = 0.95
CENTRE_TOLERANCE_M = 0.1  # a first-ranked centre this close to a real aperture's centre is that aperture
STANDOFF_M = 0.6  # camera to wall face for Table I's detected masks and Fig. 4
OVERVIEW_STANDOFF_M = 2.6  # camera to wall for Fig. 5's view of the whole decoy wall
WALL_FACE_Y = -0.05  # collapsed_mockup's aperture wall face toward the approach side
CAMERA_AHEAD_M = 1.057  # the camera ahead of the MMS's footprint at LEVEL_POSE
REPORT_TITLE = "# Micro-scout deployment through apertures (Arora & Papachristos): results"
TARGETS = {
    "table_i": f"Table I: profile analysis ≤ {TABLE_I_TARGET_S} s per shape class (median, one core)",
    "ranking": f"true aperture ranked first in ≥ {RANKING_TARGET:.0%} of randomized scans with decoys",
    "insertion": "insertion through tight apertures: ≥ 95/100 trials inserted and launched, 0 rim contacts",
    "mission": "aperture_scouts: both objects found in ≥ 9/10 seeds",
}


# ------------------------------------------------------------ 1. Table I
def facing_frames(world: World, x: float, standoff: float, count: int, robot: str = "mms") -> list[Any]:
    """``count`` posed depth frames of an MMS standing with its camera level ``standoff`` m from the wall at ``x``.

    The MMS is added to ``world``; frames are posed through its onboard interface, as ``aperture_scan`` does.
    """
    mms = world.add_robot("mms", robot, pose=[x, WALL_FACE_Y - standoff - CAMERA_AHEAD_M, math.pi / 2],
                          arm_q=LEVEL_POSE, mavs=False)
    onboard = live_view(mms.world, mms.name)
    onboard.set_joint_targets(LEVEL_POSE)
    camera = onboard.sensor("camera")
    world.step(0.3)
    frames, last = [], -1.0
    while len(frames) < count:
        reading = camera.read()
        if reading is not None and reading.stamp > last:
            last = reading.stamp
            frames.append((eye_in_hand_frame(onboard, reading.data.depth, reading.data.K, onboard.joint_positions()),
                           reading.data.rgb))
        world.step(1.0 / 30.0)
    return frames


def detected(shape: str, params: DetectionParams) -> ApertureCandidate | None:
    """The candidate the detection finds in front of opening ``shape`` from :data:`STANDOFF_M` (the largest)."""
    with World(scene="collapsed_mockup", seed=5) as world:
        frames = [f for f, _ in facing_frames(world, aperture_outline(shape).centroid.x, STANDOFF_M,
                                              params.n_frames)]
    candidates = detect_apertures(frames, params)
    return candidates[0] if candidates else None


def time_profile(mask: np.ndarray, c_m: np.ndarray, repeats: int, params: ProfileParams) -> dict[str, Any]:
    """CPU seconds (best, median) of ``profile_analysis`` on ``mask`` over ``repeats`` calls, and what it found."""
    times = []
    for _ in range(repeats):
        start = time.thread_time()
        valid = profile_analysis(mask, c_m, params)
        times.append(time.thread_time() - start)
    return {"image_px": list(mask.shape[::-1]), "best_s": min(times), "median_s": statistics.median(times),
            "found": len(valid), "from_sliding": sum(1 for v in valid if v.shift_px != 0)}


def table_i(repeats: int) -> tuple[dict[str, Any], dict[str, ApertureCandidate | None]]:
    """Section 1: the profile analysis timed per shape class on the exact and the detected masks.

    Returns the results (JSON-ready) and the detected candidates (for Fig. 4).
    """
    params, detection = ProfileParams(), DetectionParams(n_frames=3)
    K = CAMERA_INTRINSICS.K
    rows, candidates = [], {}
    for shape in SHAPES:
        mask, _ = rasterised(aperture_outline(shape), STANDOFF_M / K[0, 0])
        row = {"shape": shape, "paper_s": PAPER_TABLE_I_S[shape],
               "exact": time_profile(mask, mav_contour(STANDOFF_M, K), repeats, params)}
        found = candidates[shape] = detected(shape, detection)
        if found is not None:
            c_m = mav_contour(found.view.plane_depth, found.view.K)
            row["detected"] = time_profile(found.mask(), c_m, repeats, params)
        rows.append(row)
    worst = max(r["exact"]["median_s"] for r in rows)
    return {"standoff_m": STANDOFF_M, "repeats": repeats, "params": vars(params), "target_s": TABLE_I_TARGET_S,
            "shapes": rows, "worst_median_s": worst}, candidates


# ------------------------------------------------------------ 2. ranking
def wall_truth(seed: int, mission: Path = MISSION) -> dict[str, list[Zone]]:
    """The real apertures and the decoys of ``mission``'s world at ``seed`` (zones tagged ``aperture``, ``decoy``).

    Builds the scene and its decoys only (the same seeded draws as the run; no robots): scoring's truth.
    """
    spec = load_mission(mission).spec.world
    with World(scene=spec.scene, seed=seed) as world:
        apply_disturbances(world, Disturbances(decoys=spec.disturbances.decoys))
        return {"aperture": world.scene.zones_tagged("aperture"), "decoy": world.scene.zones_tagged("decoy")}


def classify(centre: list[float] | None, truth: dict[str, list[Zone]]) -> tuple[str, str]:
    """What a candidate centre (world m) is: ``("aperture", label)``, ``("decoy", label)`` or ``("other", "")``.

    An aperture when within :data:`CENTRE_TOLERANCE_M` of a real aperture's centre; a decoy when within that of a
    decoy's opening (its zone).
    """
    if centre is None:
        return "none", ""
    p = np.asarray(centre, dtype=float)
    for zone in truth["aperture"]:
        if np.linalg.norm(p - zone.center) <= CENTRE_TOLERANCE_M:
            return "aperture", zone.label
    for zone in truth["decoy"]:
        if zone.distance(p) <= CENTRE_TOLERANCE_M:
            return "decoy", zone.label
    return "other", ""


def _rounded(values: Any) -> list[float]:
    return [round(float(v), 3) for v in values]


def score_scan(record: dict[str, Any]) -> dict[str, Any]:
    """One scan's log read back: its start pose (truth), every window's candidates, the ranking and its verdict."""
    log: RunLog = read_log(record["log"])
    scan = [e for e in log.events_of("state_change") if e.get("skill") == "aperture_scan"]
    ranked = next((e["apertures"] for e in scan if e.get("phase") == "ranked"), [])
    windows = [e["candidates"] for e in scan if e.get("phase") == "scan_pose"]
    truth = wall_truth(record["seed"])
    t, xyz, q = log.poses("mms", orientation=True)
    first = ranked[0]["centre"] if ranked else None
    kind, label = classify(first, truth)
    seen = {classify(c, truth) for window in windows for c in window}
    return {
        "seed": record["seed"], "outcome": record["outcome"], "log": record["log"],
        "start": [*_rounded(xyz[0][:2]), round(2.0 * math.atan2(float(q[0][2]), float(q[0][3])), 3)],
        "first": first, "first_kind": kind, "first_label": label, "success": kind == "aperture",
        "ranked": [{**r, "kind": classify(r["centre"], truth)[0], "label": classify(r["centre"], truth)[1]}
                   for r in ranked],
        "windows": windows,
        "decoys": [{"label": z.label, "kind": z.tags[1], "lo": _rounded(z.lo), "hi": _rounded(z.hi)}
                   for z in truth["decoy"]],
        "decoys_detected": sorted(lab for k, lab in seen if k == "decoy"),
        "apertures_detected": sorted(lab for k, lab in seen if k == "aperture"),
        "others_detected": sum(1 for window in windows for c in window if classify(c, truth)[0] == "other"),
        "margin": _margin(ranked, truth),
    }


def _margin(ranked: list[dict[str, Any]], truth: dict[str, list[Zone]]) -> float | None:
    """Best real aperture's score less the best other candidate's (log-odds); ``None`` when one side is missing."""
    scores = {"aperture": [], "else": []}  # type: dict[str, list[float]]
    for r in ranked:
        if r["score"] is not None:
            scores["aperture" if classify(r["centre"], truth)[0] == "aperture" else "else"].append(r["score"])
    return round(max(scores["aperture"]) - max(scores["else"]), 3) if scores["aperture"] and scores["else"] else None


def ranking(runs: Path, scans: int, workers: int) -> dict[str, Any]:
    """Section 2: ``scans`` seeded decoy scans through the campaign runner, scored from their logs."""
    out = runs / "ranking"
    summary = campaign(str(MISSION), scans, out, workers=workers)
    records = json.loads((out / "trials.json").read_text())
    rows = [score_scan(r) for r in records]
    k, n = sum(r["success"] for r in rows), len(rows)
    counts: dict[str, int] = {}
    for r in rows:
        key = r["first_label"] or r["first_kind"]
        counts[key] = counts.get(key, 0) + 1
    decoy_labels = [d["label"] for r in rows for d in r["decoys"]]
    hole_areas = [(d["hi"][0] - d["lo"][0]) * (d["hi"][2] - d["lo"][2]) for r in rows for d in r["decoys"]
                  if d["label"] in r["decoys_detected"] and d["kind"] == "hole"]
    K = CAMERA_INTRINSICS.K
    mav_area = float(cv2.contourArea(mav_contour(1.0, K).astype(np.float32))) / K[0, 0] ** 2  # px² at 1 m → m²
    detected_decoys = [lab for r in rows for lab in r["decoys_detected"]]
    return {
        "mission": str(MISSION.relative_to(HERE.parent)), "scans": n, "successes": k,
        "rate": k / n if n else 0.0, "wilson95": wilson_interval(k, n), "first_ranked": counts,
        "run_outcomes": summary["outcomes"], "runs_wall_s": sum(r["wall_time"] for r in records),
        "decoys_cut": {kind: sum(lab.startswith(f"decoy_{kind}") for lab in decoy_labels)
                       for kind in ("recess", "hole")},
        "decoys_detected": {kind: sum(lab.startswith(f"decoy_{kind}") for lab in detected_decoys)
                            for kind in ("recess", "hole")},
        "decoys_ranked": sum(1 for r in rows for a in r["ranked"] if a["kind"] == "decoy"),
        "median_candidates_ranked": statistics.median(len(r["ranked"]) for r in rows) if rows else 0,
        "smallest_hole_detected_m2": min(hole_areas, default=None), "mav_area_m2": mav_area,
        "closest": min(((r["margin"], r["seed"]) for r in rows if r["margin"] is not None), default=None),
        "rows": rows,
    }


# ------------------------------------------------------------ verdicts and tables
def verdicts(results: dict[str, Any]) -> dict[str, tuple[bool, str]]:
    """Each target: met, and what was measured."""
    t1, rk = results["table_i"], results["ranking"]
    lo, hi = rk["wilson95"]
    return {
        "table_i": (t1["worst_median_s"] <= TABLE_I_TARGET_S,
                    "medians " + " / ".join(f"{r['exact']['median_s'] * 1e3:.1f}" for r in t1["shapes"]) + " ms"),
        "ranking": (rk["rate"] >= RANKING_TARGET,
                    f"{rk['successes']}/{rk['scans']} = {rk['rate']:.1%} (Wilson 95 % {lo:.1%}–{hi:.1%})"),
        "insertion": insertion_verdict(results["insertion"]),
        "mission": mission_verdict(results["mission"]),
    }


def _ms(timing: dict[str, Any] | None) -> str:
    return f"{timing['median_s'] * 1e3:.1f} ms ({timing['best_s'] * 1e3:.1f})" if timing else "not detected"


def table_i_rows(t1: dict[str, Any]) -> list[tuple[str, ...]]:
    """Table I side by side: shape, paper, exact mask (median, best), detected mask, configurations found."""
    return [(SHAPE_NAMES[r["shape"]], f"{r['paper_s']:.2f} s", _ms(r["exact"]), _ms(r.get("detected")),
             f"{r['exact']['found']} ({r['exact']['from_sliding']})",
             f"{r['detected']['found']} ({r['detected']['from_sliding']})" if "detected" in r else "–")
            for r in t1["shapes"]]


TABLE_I_HEADER = ("shape class", "paper Table I", "exact mask: median (best)", "detected mask: median (best)",
                  "V exact (sliding)", "V detected (sliding)")


# ------------------------------------------------------------ figures
def _pyplot() -> Any:
    """matplotlib's pyplot on the Agg backend (no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, img: Path, name: str) -> str:
    """Write ``fig`` as ``img/aperture_<name>.png``, close it; returns the path."""
    img.mkdir(parents=True, exist_ok=True)
    path = img / f"aperture_{name}.png"
    fig.savefig(path, dpi=110, bbox_inches="tight")
    _pyplot().close(fig)
    return str(path)


def _crop(candidate: ApertureCandidate, pad: int = 12) -> tuple[slice, slice]:
    u0, v0 = candidate.contour_px.min(axis=0).astype(int) - pad
    u1, v1 = candidate.contour_px.max(axis=0).astype(int) + pad
    h, w = candidate.view.binary.shape
    return slice(max(v0, 0), min(v1, h)), slice(max(u0, 0), min(u1, w))


def _rejected(valid: LaunchConfiguration, c_m: np.ndarray, mask: np.ndarray) -> np.ndarray | None:
    """An invalid configuration near ``valid``: C_m^t turned by 90° about its centre and slid along its new axis
    until it leaves C_a (the first such placement), or ``None``."""
    h, w = mask.shape
    angle = valid.angle + math.pi / 2
    direction = np.array([math.cos(angle), math.sin(angle)])
    for shift in range(0, max(h, w), 2):
        centre = (valid.center_px[0] + shift * direction[0], valid.center_px[1] + shift * direction[1])
        placed = LaunchConfiguration(centre, angle, valid.pair_px, valid.score, 0.0).placed(c_m)
        u, v = np.rint(placed[:, 0]).astype(int), np.rint(placed[:, 1]).astype(int)
        inside = (u >= 0) & (u < w) & (v >= 0) & (v < h)
        if (~inside | (mask[np.clip(v, 0, h - 1), np.clip(u, 0, w - 1)] == 0)).any():
            return placed
    return None


def plot_fig4(candidates: dict[str, ApertureCandidate | None], img: Path) -> str:
    """Like Fig. 4: per shape, I_binary, I_canny, C_a, a valid configuration (all of V faint) and a rejected one."""
    plt = _pyplot()
    params = DetectionParams()
    fig, axes = plt.subplots(len(SHAPES), 5, figsize=(13, 2.6 * len(SHAPES)))
    titles = ("I_binary", "I_canny", "contour C_a", "valid C_m^t (V faint)",
              "rejected: crosses C_a")
    for row, shape in zip(axes, SHAPES, strict=True):
        candidate = candidates[shape]
        for ax, title in zip(row, titles, strict=True):
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(title, fontsize=9)
        row[0].set_ylabel(SHAPE_NAMES[shape], fontsize=9)
        if candidate is None:
            row[0].text(0.5, 0.5, "not detected", ha="center", transform=row[0].transAxes)
            continue
        rows_, cols = _crop(candidate)
        binary = candidate.view.binary
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * params.dilation_px + 1,) * 2)
        canny = cv2.Canny(cv2.dilate(binary, kernel), *params.canny_thresholds)  # as the detection does (§IV-B)
        mask = candidate.mask()
        c_m = mav_contour(candidate.view.plane_depth, candidate.view.K)
        valid = profile_analysis(mask, c_m)
        origin = np.array([cols.start, rows_.start])
        row[0].imshow(binary[rows_, cols], cmap="gray")
        row[1].imshow(canny[rows_, cols], cmap="gray")
        for ax in row[2:]:
            ax.imshow(mask[rows_, cols], cmap="Greys_r", alpha=0.35)
            closed = np.vstack((candidate.contour_px, candidate.contour_px[:1])) - origin
            ax.plot(closed[:, 0], closed[:, 1], color="tab:blue", lw=1.2)
        for config in valid[1:]:
            placed = np.vstack((config.placed(c_m), config.placed(c_m)[:1])) - origin
            row[3].plot(placed[:, 0], placed[:, 1], color="tab:green", lw=0.6, alpha=0.4)
        if valid:
            placed = valid[0].placed(c_m)
            row[3].fill(*(placed - origin).T, color="tab:green", alpha=0.8)
            bad = _rejected(valid[0], c_m, mask)
            if bad is not None:
                row[4].fill(*(bad - origin).T, color="tab:red", alpha=0.8)
        row[3].set_title(f"valid C_m^t: {len(valid)} in V", fontsize=9)
    fig.suptitle(f"Profile analysis on the detected apertures, {STANDOFF_M} m from the wall (cf. Fig. 4)")
    return _save(fig, img, "fig4_profile")


def _wall_axes(ax: Any, row: dict[str, Any]) -> None:
    """The aperture wall seen from the approach side: real openings (outlines) and the scan's decoys (x, z m)."""
    for shape in SHAPES:
        outline = aperture_outline(shape)
        for part in getattr(outline, "geoms", [outline]):  # the collapsed opening is two parts
            x, z = part.exterior.xy
            ax.fill(x, z, color="tab:blue", alpha=0.35, lw=0)
    for d in row["decoys"]:
        (x0, _, z0), (x1, _, z1) = d["lo"], d["hi"]
        colour = "tab:orange" if d["kind"] == "recess" else "tab:red"
        ax.add_patch(_pyplot().Rectangle((x0, z0), x1 - x0, z1 - z0, fill=False, ec=colour, lw=1.2))
    ax.set_xlim(-2.4, 2.4)
    ax.set_ylim(0.2, 1.5)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")


def plot_fig5(rk: dict[str, Any], img: Path) -> str:
    """Like Fig. 5 b–e: the decoy wall as the MMS sees it, one scan's detections and ranking, every scan's first."""
    plt = _pyplot()
    rows = rk["rows"]
    example = next((r for r in rows if r["decoys_detected"]), rows[0])
    with World(scene="collapsed_mockup", seed=example["seed"]) as world:
        spec = load_mission(MISSION).spec.world
        apply_disturbances(world, Disturbances(decoys=spec.disturbances.decoys))
        _, rgb = facing_frames(world, 0.0, OVERVIEW_STANDOFF_M, 1)[0]
    fig, axes = plt.subplots(3, 1, figsize=(11, 12), gridspec_kw={"height_ratios": [1.3, 1, 1]})
    axes[0].imshow(rgb)
    axes[0].set_axis_off()
    kinds = [d["kind"] for d in example["decoys"]]
    axes[0].set_title(f"seed {example['seed']}: the wall from {OVERVIEW_STANDOFF_M} m, the eye-in-hand camera level "
                      f"({kinds.count('recess')} recesses, {kinds.count('hole')} small holes cut in)", fontsize=9)
    _wall_axes(axes[1], example)
    for window in example["windows"]:
        for c in window:
            axes[1].plot(c[0], c[2], "x", color="0.3", ms=5)
    for i, r in enumerate(example["ranked"]):
        if r["score"] is not None:
            axes[1].annotate(f"#{i + 1} L_a {r['score']:.2f}", (r["centre"][0], r["centre"][2]), fontsize=8,
                             xytext=(4, 6), textcoords="offset points", color="tab:green" if i == 0 else "k")
    axes[1].set_title(f"seed {example['seed']}: detections of every window (x) and the ranking (mean L_a); "
                      "blue real apertures, orange recesses, red holes", fontsize=9)
    _wall_axes(axes[2], {"decoys": [d for r in rows for d in r["decoys"]]})
    colours = {"aperture": "tab:green", "decoy": "tab:red", "other": "k", "none": "k"}
    for r in rows:
        if r["first"] is not None:
            axes[2].plot(r["first"][0], r["first"][2], "o", color=colours[r["first_kind"]], ms=5, alpha=0.7)
    axes[2].set_title(f"first-ranked centre of each of the {len(rows)} scans (green: a real aperture) over every "
                      "scan's decoys", fontsize=9)
    fig.tight_layout()
    return _save(fig, img, "fig5_ranking")


def plot_starts(rk: dict[str, Any], img: Path) -> str:
    """Plan view: the MMS's seeded start poses in the approach area, coloured by the scan's verdict."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot([-3.5, 3.5], [0, 0], color="0.4", lw=4)
    for shape in SHAPES:
        x = aperture_outline(shape).centroid.x
        ax.plot([x - 0.12, x + 0.12], [0, 0], color="tab:blue", lw=4)
    for r in rk["rows"]:
        x, y, yaw = r["start"]
        ax.arrow(x, y, 0.25 * math.cos(yaw), 0.25 * math.sin(yaw), head_width=0.06,
                 color="tab:green" if r["success"] else "tab:red", alpha=0.7)
    ax.add_patch(plt.Rectangle((-1.6, -3.0), 3.2, 2.95, fill=False, ls="--", ec="0.5"))
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("MMS start poses (approach area dashed; red: a scan whose first was not real)", fontsize=9)
    return _save(fig, img, "starts")


# ------------------------------------------------------------ report
def report(results: dict[str, Any], images: dict[str, str], path: Path) -> None:
    """The Markdown page: targets, Table I beside the paper, the ranking with decoys, figures, how to reproduce."""
    rel = {name: os.path.relpath(p, path.parent) for name, p in images.items()}
    machine, t1, rk = results["machine"], results["table_i"], results["ranking"]
    lo, hi = rk["wilson95"]
    lines = [
        REPORT_TITLE,
        "",
        f"Generated by `{results['command']}` on {results['date']} ({machine['cpus']} CPUs shared with other work, "
        f"load average {machine.get('load_average_1_5_15min', '?')} at the start; Python {machine['python']}). "
        "The ranking is scored from the runs' MCAP logs against the scene's truth (zones tagged `aperture` and "
        "`decoy`); the robot never reads it.",
        "",
        *targets_lines(TARGETS, verdicts(results)),
        "",
        "## Table I: profile analysis time per shape class",
        "",
        f"CPU time of `profile_analysis` (Algorithm 1) on one core, median (best) of {t1['repeats']} calls; the "
        f"MAV contour C_m and the masks at the pixel size of the eye-in-hand camera {t1['standoff_m']} m from the "
        "wall. *Exact mask*: the opening of `collapsed_mockup` rasterised from the scene; *detected mask*: the "
        "contour C_a that the detection (§IV-B) found in three rendered depth frames from there (2–3 px inside "
        "the opening). V: configurations found (at most N_v = 10), in brackets those of the sliding search.",
        "",
        "| " + " | ".join(TABLE_I_HEADER) + " |",
        "|" + "---|" * len(TABLE_I_HEADER),
        *("| " + " | ".join(row) + " |" for row in table_i_rows(t1)),
        "",
        "The paper's times are for its implementation and computer (not given); ours pairs contour points every "
        f"{t1['params']['pair_spacing_px']:g} px and tests interiors on a raster in numpy (docs/aperture.md).",
        "",
        f"![Fig. 4 like]({rel['fig4']})",
        "",
        "## Detection ranking with decoys (Fig. 5 b–d)",
        "",
        f"{rk['scans']} scans, seeds 0–{rk['scans'] - 1} of `{rk['mission']}`: the MMS starts at (0, −2.45) m facing "
        "the wall, moved by up to ±0.8 m in x, ±0.3 m in y and ±0.15 rad (`team.mms.pose_spread`), and sweeps "
        "`aperture_scan`'s five pan poses, two depth frames each. Each wide wall segment has a shallow recess "
        "(0.15–0.32 × 0.10–0.24 m, its back 0.01–0.04 m behind the face: less than d_C = 0.05 m) and two "
        "see-through holes (sides 0.03–0.09 m: the MAV fits at no angle) at seeded places "
        "(`world.disturbances.decoys`). A scan succeeds when its first-ranked candidate's centre lies within "
        f"{CENTRE_TOLERANCE_M} m of a real aperture's centre.",
        "",
        f"- True aperture ranked first: **{rk['successes']}/{rk['scans']} = {rk['rate']:.1%}** "
        f"(Wilson 95 % {lo:.1%}–{hi:.1%}); target ≥ {RANKING_TARGET:.0%}.",
        "- First-ranked: " + ", ".join(f"`{k}` {v}" for k, v in sorted(rk["first_ranked"].items())) + ".",
        f"- Decoys cut: {rk['decoys_cut']['recess']} recesses, {rk['decoys_cut']['hole']} holes; detected in some "
        f"window: {rk['decoys_detected']['recess']} recesses, {rk['decoys_detected']['hole']} holes; ranked at all: "
        f"{rk['decoys_ranked']}. Median candidates ranked per scan: {rk['median_candidates_ranked']}.",
        f"- Run outcomes: {', '.join(f'{k} {v}' for k, v in rk['run_outcomes'].items())}; the runs took "
        f"{rk['runs_wall_s'] / 60:.1f} min of wall time in all "
        f"({rk['runs_wall_s'] / max(rk['scans'], 1):.1f} s a scan).",
    ]
    if rk["closest"] is not None:
        lines.append(f"- Closest call: seed {rk['closest'][1]}, the best real aperture {rk['closest'][0]:.2f} "
                     "log-odds above the best decoy or other candidate (margin over every scan with one).")
    if rk["successes"] == rk["scans"] and lo < RANKING_TARGET:
        needed = math.ceil(RANKING_TARGET * WILSON_Z**2 / (1.0 - RANKING_TARGET))
        lines.append(f"- With no miss, the Wilson lower bound reaches {RANKING_TARGET:.0%} only from {needed} scans: "
                     f"{rk['scans']} scans show a rate ≥ {RANKING_TARGET:.0%}, not that it is above it with 95 % "
                     "confidence.")
    lines.append("- *Other* candidates lie on the wall plane at its ends, its top and bottom edges and where the "
                 "debris in front hides it. The smallest hole that was a candidate had "
                 f"{rk['smallest_hole_detected_m2'] or float('nan'):.4f} m² (C_m: {rk['mav_area_m2']:.4f} m², the "
                 "detection's area test).")
    misses = [r for r in rk["rows"] if not r["success"]]
    if misses:
        lines += ["", "Scans whose first-ranked candidate was not a real aperture (from the logs):", ""]
        for r in misses:
            first = r["ranked"][0] if r["ranked"] else None
            what = (f"`{r['first_kind']}` {r['first_label']} at {first['centre']} (L_a {first['score']}, "
                    f"{first['detections']} windows)" if first else "nothing ranked")
            lines.append(f"- seed {r['seed']}, start {r['start']}: {what}.")
    lines += [
        "",
        f"![Fig. 5 like]({rel['fig5']})",
        "",
        f"![start poses]({rel['starts']})",
        "",
        "The paper: \"scanning to detect apertures yields numerous detections, but only one (the ingress point) "
        "ranks consistently\" (Fig. 5); no rate is printed. Our mockup has four real apertures, so any of them "
        "ranked first counts.",
        "",
        *insertion_lines(results["insertion"], rel["insertion"]),
        "",
        *mission_lines(results["mission"]),
        "",
        REPRODUCING_HEADING,
        "",
        f"- This page: `{results['command']}`.",
        "- The full counts: `python benchmarks/aperture.py --workers 1 --runs DIR` (`--runs` resumes).",
        "- One scan by hand: `marsupial run benchmarks/missions/aperture_ranking.yaml --seed 3 --log scan.mcap`.",
        "- The insertion trials (or the mission's seeds) alone, merged into this page: `python benchmarks/aperture.py "
        "--only insertion --workers 1 --runs DIR` (`--only mission`).",
    ]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")


# ------------------------------------------------------------ main
REPRODUCING_HEADING = "## Reproducing"


def insertion_section(results: dict[str, Any], runs: Path, trials: int, workers: int) -> dict[str, Any]:
    """Section 3 run (:mod:`aperture_insertion`), stamped with the command, date and load it ran with."""
    ins = insertion_trials(runs, trials, workers)
    ins.update(command=results["command"], date=results["date"],
               load=results["machine"].get("load_average_1_5_15min"))
    return ins


def merge_only(results: dict[str, Any], runs: Path, trials: int, seeds: int, args: Any) -> dict[str, Any]:
    """``--only insertion`` or ``--only mission``: that section alone, merged into the page ``args.report`` (its
    section and its row of the targets; the other sections untouched) and into the JSON ``args.out``; returns the
    merged JSON."""
    key = args.only
    if key == "insertion":
        data = insertion_section(results, runs, trials, args.workers)
        image = plot_insertion(data, args.report.parent / "img", _pyplot, _save)
        heading, before = INSERTION_HEADING, MISSION_HEADING  # the sections in the order of the full page
        lines = insertion_lines(data, os.path.relpath(image, args.report.parent))
        met, measured = insertion_verdict(data)
    else:
        data = mission_seeds(runs, seeds, args.workers)
        data.update(command=results["command"], date=results["date"])
        heading, before, lines = MISSION_HEADING, REPRODUCING_HEADING, mission_lines(data)
        met, measured = mission_verdict(data)
    results[key] = data
    page = args.report.read_text() if args.report.exists() else f"{REPORT_TITLE}\n"
    page = merge_target_row(page, TARGETS[key], met, measured)
    page = merge_section(page, heading, lines, before=before)
    args.report.parent.mkdir(parents=True, exist_ok=True)
    args.report.write_text(page)
    merged = json.loads(args.out.read_text()) if args.out.exists() else {"machine": results["machine"]}
    merged[key] = data
    merged.setdefault("targets", {})[key] = {"met": met, "measured": measured}
    print_targets("aperture targets", {key: TARGETS[key]}, {key: (met, measured)}, results["machine"])
    print(f"report: {args.report}")
    write_report(merged, args.out)
    return merged


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run every section (or read back the scans finished in ``--runs``), write the JSON and the page."""
    parser = campaign_arguments(__doc__.split("\n\n")[0], "6 scans, 5 timing repeats", DEFAULT_OUT, DEFAULT_REPORT)
    parser.add_argument("--scans", type=int, default=None, help="randomized decoy scans (default 50)")
    parser.add_argument("--seeds", type=int, default=None, help="seeds of the aperture_scouts mission (default 10)")
    parser.add_argument("--repeats", type=int, default=None, help="profile-analysis calls per shape (default 20)")
    parser.add_argument("--trials", type=int, default=None, help="insertion trials over the shapes (default 100)")
    parser.add_argument("--only", choices=("insertion", "mission"), default=None,
                        help="run this section alone and merge it into the existing page and JSON")
    args = parser.parse_args(argv)
    for name in ("scans", "seeds", "repeats", "trials", "workers"):
        value = getattr(args, name)
        if value is not None and value < 1:
            parser.error(f"--{name} must be a positive integer, got {value}")
    scans = args.scans or (6 if args.quick else 50)
    seeds = args.seeds or (2 if args.quick else 10)
    repeats = args.repeats or (5 if args.quick else 20)
    trials = args.trials or (4 if args.quick else 100)
    with tempfile.TemporaryDirectory(prefix="aperture_runs_") as scratch:
        runs = args.runs or Path(scratch)
        runs.mkdir(parents=True, exist_ok=True)
        results: dict[str, Any] = {
            "command": command_line("aperture.py", argv),
            "quick": args.quick, "date": time.strftime("%Y-%m-%d"), "machine": machine_info(workers=args.workers),
        }
        if args.only is not None:
            return merge_only(results, runs, trials, seeds, args)
        results["table_i"], candidates = table_i(repeats)
        print_tables([("Table I: profile analysis, one core", TABLE_I_HEADER, table_i_rows(results["table_i"]))],
                     results["machine"])
        results["ranking"] = ranking(runs, scans, args.workers)
        results["insertion"] = insertion_section(results, runs, trials, args.workers)
        results["mission"] = mission_seeds(runs, seeds, args.workers)
        img = args.report.parent / "img"
        images = {"fig4": plot_fig4(candidates, img), "fig5": plot_fig5(results["ranking"], img),
                  "starts": plot_starts(results["ranking"], img),
                  "insertion": plot_insertion(results["insertion"], img, _pyplot, _save)}
        report(results, images, args.report)
        checks = verdicts(results)
    return conclude("aperture targets", TARGETS, checks, results, args.report, args.out)


if __name__ == "__main__":
    sys.exit(0 if all(t["met"] for t in main()["targets"].values()) else 1)
