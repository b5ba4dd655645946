"""Section 3 of ``benchmarks/aperture.py``: insertion trials through tight apertures, scored from their logs.

Each trial is one run of ``benchmarks/missions/aperture_insertion.yaml`` through the campaign runner, for one
shape class (``world.disturbances.aperture_fit.shape``) with the MMS starting in front of that aperture
(``team.mms.pose`` x, then ``pose_spread``: the base placement noise); the seed draws the clearance c of the
Tello in the reshaped opening within the mission's range (1–3 cm) and the start pose. The shapes run on the same
seeds, so each seed gives every shape the same clearance and the same start offset.

From each MCAP log: *inserted* (``insert_scout`` succeeded: Phases I–II done, the MAV past the wall), *launched*
(``scout_takeoff`` succeeded: the MAV, let go at the launch pose, climbed off the apparatus), the rim contacts the
referee recorded on truth (``rim_contact`` events: part, wall piece, the skill stage they came in), and, for a
trial that fell short, the first node that failed and its message (``insertion_failed`` reasons included). A
trial succeeds when the MAV was inserted and launched and the run had no rim contact. The world's truth for each
trial (the fitted opening, its scale k and the MAV's clearance measured again) is rebuilt from the mission and
the seed (:func:`fit_truth`). Target: ≥ 95 of 100 trials, with 0 rim contacts.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

from benchmarks.bench_common import campaign_spec, campaigns
from marsupial.api.config import Disturbances
from marsupial.trees.campaign import wilson_interval
from marsupial.trees.mission import load_mission
from marsupial.trees.replay import read_log
from marsupial.world import World
from marsupial.world.apertures import aperture_outline
from marsupial.world.disturbances import apply_disturbances

HERE = Path(__file__).resolve().parent
MISSION = HERE / "missions" / "aperture_insertion.yaml"
SHAPES = ("orthogonal", "collapsed", "amoeba", "u")
TARGET_SUCCESSES = 0.95  # inserted and launched in ≥ 95 of 100 trials, with 0 rim contacts (the acceptance)
BANDS_CM = ((1.0, 1.5), (1.5, 2.0), (2.0, 2.5), (2.5, 3.0))  # clearance bands of the tables (cm)
STAGES = ("grasped", "phase1", "phase2", "phase3", "launched", "cleared", "stowed")
"""Phase events of ``insert_scout`` and ``launch_scout`` in their order: a rim contact is put in the last one begun."""
STAGE_NAMES = {
    None: "before the grasp",
    "grasped": "lift off the holster",
    "phase1": "Phase I: free motion, then the entry onto the plane",
    "phase2": "Phase II slip",
    "phase3": "Phase III turn",
    "launched": "waiting for the climb",
    "cleared": "retreat to the holster",
    "stowed": "back to the viewing pose",
}


def start_x(shape: str) -> float:
    """x (m) of the centre of aperture ``shape``'s bounding box in ``collapsed_mockup``: the MMS starts before it."""
    x0, _, x1, _ = aperture_outline(shape).bounds
    return round((x0 + x1) / 2.0, 3)


def overrides_for(shape: str, mission: Path = MISSION) -> dict[str, str]:
    """The ``--set`` values of one shape's campaign: the shape class and the start pose in front of it."""
    pose = load_mission(mission).spec.team["mms"].pose
    assert pose is not None, "the insertion mission gives the MMS a start pose"
    return {"world.disturbances.aperture_fit.shape": shape, "team.mms.pose": json.dumps([start_x(shape), *pose[1:]])}


def fit_truth(shape: str, seed: int, mission: Path = MISSION) -> dict[str, Any]:
    """The tight aperture of ``mission``'s world for ``shape`` at ``seed``: the same seeded draws as the run.

    Builds the scene and its ``aperture_fit`` only (no robots): scoring's truth.
    """
    spec = load_mission(mission, overrides_for(shape, mission)).spec.world
    with World(scene=spec.scene, seed=seed) as world:
        made = apply_disturbances(world, Disturbances(aperture_fit=spec.disturbances.aperture_fit)).aperture_fit
    assert made is not None
    x0, z0, x1, z1 = made.opening.bounds
    return {
        "clearance_cm": round(made.clearance * 100, 3),
        "measured_cm": round(made.fit.clearance * 100, 3),
        "scale": round(made.scale, 4),
        "opening_cm": [round((x1 - x0) * 100, 1), round((z1 - z0) * 100, 1)],
        "mav_angle_deg": round(math.degrees(made.fit.angle) % 360.0, 1),
    }


def _stage_at(t: float, stages: list[tuple[float, str]]) -> str | None:
    """The last insertion/launch stage begun at or before ``t`` (s), ``None`` before the grasp."""
    begun = [name for when, name in stages if when <= t]
    return begun[-1] if begun else None


def score_trial(record: dict[str, Any], shape: str) -> dict[str, Any]:
    """One trial's scores from its log (module docstring) and its world's truth."""
    log = read_log(record["log"])
    outcomes = log.events_of("outcome")
    status = {e["skill"]: e["status"] for e in outcomes if e.get("skill")}
    phases = [e for e in log.events_of("state_change") if e.get("phase")]
    stages = [(e["t"], e["phase"]) for e in phases if e["phase"] in STAGES and e.get("skill") != "scout_takeoff"]
    touches = [
        {"t": round(e["t"], 2), "part": e["part"], "wall": e["wall"], "stage": STAGE_NAMES[_stage_at(e["t"], stages)]}
        for e in log.events_of("rim_contact")
    ]
    failed = next((e for e in outcomes if e["status"] == "FAILURE"), None)
    reasons = [e["reason"] for e in phases if e["phase"] == "insertion_failed"]
    plan = next((e for e in phases if e["phase"] == "insertion_plan"), None)
    profile = next((e for e in phases if e["phase"] == "profile"), None)
    row: dict[str, Any] = {
        "shape": shape,
        "seed": record["seed"],
        "outcome": record["outcome"],
        "sim_time": record["sim_time"],
        "wall_time": record["wall_time"],
        **fit_truth(shape, record["seed"]),
        "inserted": status.get("insert_scout") == "SUCCESS",
        "launched": status.get("scout_takeoff") == "SUCCESS",
        "stowed": status.get("launch_scout") == "SUCCESS",
        "rim_contacts": len(touches),
        "touches": touches[:5],
        "configurations": profile.get("configurations") if profile else None,
        "plans": profile.get("feasible") if profile else None,
        "plan_tried": plan.get("tried") if plan else None,
        "failed": f"{failed['skill']}: {failed['message']}" if failed else None,
        "reasons": reasons,
    }
    if record["outcome"] == "error":  # the run raised: the campaign runner keeps its message
        row["failed"] = f"run error in the {STAGE_NAMES[_stage_at(record['sim_time'], stages)]}: {record['message']}"
    elif failed is None and not row["launched"]:
        row["failed"] = f"time limit at {record['sim_time']:.0f} s"
    row["success"] = row["inserted"] and row["launched"] and row["rim_contacts"] == 0
    return row


NO_PLAN = re.compile(r"(insert_scout: none of )\d+( launch plans has collision-free Phases I-III) \((.*)\)")
"""``insert_scout``'s failure with its tally of why each plan was refused (``entry mav: rim 10, …``)."""


def reasons_of(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Why the trials that fell short did: each reason (numbers of the message made ``N``, the plans refused
    by ``insert_scout`` summed over its trials) with its trials per shape, most frequent first."""
    found: dict[str, dict[str, Any]] = {}
    for r in rows:
        if r["success"]:
            continue
        refused: dict[str, int] = {}
        if r["failed"] is None:
            why = f"rim contact ({', '.join(sorted({t['stage'] for t in r['touches']}))})"
        elif (match := NO_PLAN.match(r["failed"])) is not None:
            why = f"{match[1]}the{match[2]}"
            for part in match[3].split(", "):
                name, _, count = part.rpartition(" ")
                refused[name] = int(count)
        else:
            why = re.sub(r"-?\d+(\.\d+)?", "N", re.sub(r"\(-?[\d.]+(, -?[\d.]+)+\)", "(x, y, z)", r["failed"]))
        entry = found.setdefault(why, {"reason": why, "trials": 0, "shapes": {}, "plans_refused": {}})
        entry["trials"] += 1
        entry["shapes"][r["shape"]] = entry["shapes"].get(r["shape"], 0) + 1
        for name, count in refused.items():
            entry["plans_refused"][name] = entry["plans_refused"].get(name, 0) + count
    return sorted(found.values(), key=lambda e: -e["trials"])


def _tally(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Counts over ``rows``: trials, inserted, launched, without rim contact, successes, rim contacts."""
    return {
        "trials": len(rows),
        "inserted": sum(r["inserted"] for r in rows),
        "launched": sum(r["launched"] for r in rows),
        "clean": sum(r["rim_contacts"] == 0 for r in rows),
        "successes": sum(r["success"] for r in rows),
        "rim_contacts": sum(r["rim_contacts"] for r in rows),
    }


def band_of(clearance_cm: float) -> str:
    """The label of the band of :data:`BANDS_CM` holding ``clearance_cm`` (the last band's top included)."""
    for low, high in BANDS_CM:
        if low <= clearance_cm < high or (high == BANDS_CM[-1][1] and clearance_cm <= high):
            return f"{low:g}–{high:g} cm"
    return "outside 1–3 cm"


def insertion_trials(runs: Path, trials: int, workers: int) -> dict[str, Any]:
    """Section 3: ``trials`` insertion trials spread evenly over the shape classes, scored from their logs."""
    per_shape = math.ceil(trials / len(SHAPES))
    mms = load_mission(MISSION).spec.team["mms"]
    rows, wall = [], 0.0
    specs = [campaign_spec(str(MISSION), per_shape, runs / "insertion" / shape, overrides=overrides_for(shape))
             for shape in SHAPES]
    campaigns(specs, workers)  # the trials of every shape class in one pool
    for shape, spec in zip(SHAPES, specs, strict=True):
        records = json.loads((spec.out / "trials.json").read_text())
        wall += sum(r["wall_time"] for r in records)
        rows += [score_trial(r, shape) for r in records]
    total = _tally(rows)
    fit = load_mission(MISSION).spec.world.disturbances.aperture_fit
    assert fit is not None, f"{MISSION} has no aperture_fit entry"
    return {
        "mission": str(MISSION.relative_to(HERE.parent)),
        "start": mms.pose,
        "pose_spread": mms.pose_spread,
        "clearance_range_m": list(fit.clearance_range),
        "per_shape": per_shape,
        **total,
        "rate": total["successes"] / len(rows) if rows else 0.0,
        "wilson95": wilson_interval(total["successes"], len(rows)),
        "runs_wall_s": wall,
        "by_shape": {s: _tally([r for r in rows if r["shape"] == s]) for s in SHAPES},
        "by_band": {
            band_of(low): _tally([r for r in rows if band_of(r["clearance_cm"]) == band_of(low)]) for low, _ in BANDS_CM
        },
        "reasons": reasons_of(rows),
        "worst_fit_error_mm": max((abs(r["measured_cm"] - r["clearance_cm"]) * 10 for r in rows), default=0.0),
        "rows": rows,
    }


def verdict(ins: dict[str, Any]) -> tuple[bool, str]:
    """Whether enough trials inserted and launched with no rim contact in any trial, and what was measured."""
    lo, hi = ins["wilson95"]
    met = ins["rate"] >= TARGET_SUCCESSES and ins["trials"] >= 100 and ins["rim_contacts"] == 0
    return met, (
        f"{ins['successes']}/{ins['trials']} inserted and launched without rim contact (Wilson 95 % "
        f"{lo:.1%}–{hi:.1%}); {ins['rim_contacts']} rim contacts in all"
    )


def _row(name: str, t: dict[str, Any]) -> str:
    return (
        f"| {name} | {t['trials']} | {t['inserted']} | {t['launched']} | {t['clean']} | **{t['successes']}** | "
        f"{t['rim_contacts']} |"
    )


def insertion_lines(ins: dict[str, Any], figure: str | None = None) -> list[str]:
    """The page's section on the insertion trials (its own ``##`` heading: it can be rendered alone or merged)."""
    header = [
        "| | trials | inserted | launched | no rim contact | all three | rim contacts |",
        "|---|---|---|---|---|---|---|",
    ]
    lo, hi = ins["wilson95"]
    lines = [INSERTION_HEADING, ""]
    if "command" in ins:
        lines += [
            f"Generated by `{ins['command']}` on {ins['date']} (load average {ins['load']} at the start); "
            "this section alone: `python benchmarks/aperture.py --only insertion --workers 1 --runs DIR`.",
            "",
        ]
    (low, high), (dx, dy, dyaw) = (100 * v for v in ins["clearance_range_m"]), ins["pose_spread"]
    lines += [
        f"{ins['trials']} trials of `{ins['mission']}`, {ins['per_shape']} per shape class, seeds 0–"
        f"{ins['per_shape'] - 1} for each. In each the world reshapes one aperture of `collapsed_mockup` "
        "(`world.disturbances.aperture_fit`, docs/world.md §7) into its shape class's outline scaled so that the "
        f"Tello's fronto-parallel outline fits with a clearance c drawn uniformly in {low:g}–{high:g} cm (the "
        "largest margin it can keep from the rim at its best angle and place) and closes the other three; the MMS "
        f"starts {-ins['start'][1]:g} m before that aperture, moved by up to ±{dx:g} m in x, ±{dy:g} m in y and "
        f"±{dyaw:g} rad (`team.mms.pose_spread`), then scans, approaches, analyses and deploys one scout. The "
        "same seeds give "
        "every shape the same c and start offset. A trial counts when `insert_scout` and `scout_takeoff` "
        "succeeded and the referee recorded no rim contact (arm, apparatus or held MAV against the wall, on "
        "truth) in the whole run, the arm's retreat included.",
        "",
        f"- Inserted and launched with no rim contact: **{ins['successes']}/{ins['trials']} = {ins['rate']:.1%}** "
        f"(Wilson 95 % {lo:.1%}–{hi:.1%}); target ≥ 95/100 with 0 rim contacts. Rim contacts in all: "
        f"**{ins['rim_contacts']}**.",
        f"- The fitted openings measured again: clearance within {ins['worst_fit_error_mm']:.2f} mm of the drawn c "
        "in every trial.",
        f"- The runs took {ins['runs_wall_s'] / 60:.1f} min of wall time in all "
        f"({ins['runs_wall_s'] / max(ins['trials'], 1):.1f} s a trial).",
        "",
        "Per shape class:",
        "",
        *header,
        *(_row(s, t) for s, t in ins["by_shape"].items()),
        _row("all", ins),
        "",
        "Per clearance band (c drawn):",
        "",
        *header,
        *(_row(b, t) for b, t in ins["by_band"].items()),
    ]
    if ins["reasons"]:
        lines += [
            "",
            "Why trials fell short (the first node that failed and its message, numbers as N; for `insert_scout` "
            "the launch plans it refused, and why, summed over those trials; from the logs):",
            "",
            "| trials | per shape | reason | launch plans refused |",
            "|---|---|---|---|",
            *(f"| {e['trials']} | {', '.join(f'{s} {n}' for s, n in sorted(e['shapes'].items()))} | {e['reason']} | "
              f"{', '.join(f'{k} {n}' for k, n in sorted(e['plans_refused'].items(), key=lambda kv: -kv[1])) or '–'} |"
              for e in ins["reasons"]),
        ]
    if figure is not None:
        lines += ["", f"![insertion trials]({figure})"]
    return lines


INSERTION_HEADING = "## Insertion through tight apertures"


def plot_insertion(ins: dict[str, Any], img: Path, pyplot: Any, save: Any) -> str:
    """The fitted opening of each shape at 1 and 3 cm with the Tello at its best pose, and every trial's outcome
    against its clearance."""
    from shapely import affinity
    from shapely.geometry import Polygon

    from marsupial.api.silhouette import mav_silhouette

    plt = pyplot()
    fig = plt.figure(figsize=(12, 7.5))
    grid = fig.add_gridspec(2, len(SHAPES), height_ratios=[1, 1.1])
    outline = mav_silhouette()
    mav = Polygon(list(zip(outline[:, 0], -outline[:, 1], strict=True)))
    for col, shape in enumerate(SHAPES):
        ax = fig.add_subplot(grid[0, col])
        for clearance, colour in ((0.01, "tab:red"), (0.03, "tab:blue")):
            with World(scene="collapsed_mockup", seed=0) as world:
                made = apply_disturbances(
                    world, {"aperture_fit": {"shape": shape, "clearance": clearance}}
                ).aperture_fit
            assert made is not None
            for part in getattr(made.opening, "geoms", [made.opening]):
                ax.plot(*part.exterior.xy, color=colour, lw=1.2)
            placed = affinity.translate(
                affinity.rotate(mav, made.fit.angle, origin=(0, 0), use_radians=True), *made.fit.centre
            )
            ax.fill(*placed.exterior.xy, color=colour, alpha=0.35, lw=0)
        ax.set_aspect("equal")
        ax.set_title(f"{shape}: c = 1 cm (red), 3 cm (blue)", fontsize=9)
        ax.set_xlabel("x [m]", fontsize=8)
        ax.tick_params(labelsize=7)
    ax = fig.add_subplot(grid[1, :])
    colours = {"success": "tab:green", "rim": "tab:orange", "failed": "tab:red"}
    for r in ins["rows"]:
        kind = "success" if r["success"] else ("rim" if r["inserted"] and r["launched"] else "failed")
        ax.plot(
            r["clearance_cm"],
            SHAPES.index(r["shape"]) + (r["seed"] % 5 - 2) * 0.06,
            "o",
            color=colours[kind],
            ms=5,
            alpha=0.8,
        )
    ax.set_yticks(range(len(SHAPES)), SHAPES)
    ax.set_xlabel("clearance c of C_m (the Tello in its cradle) in the opening [cm]")
    ax.set_title(
        "each trial: green inserted and launched without rim contact, orange with rim contacts, red short", fontsize=9
    )
    fig.tight_layout()
    return str(save(fig, img, "insertion"))
