"""Section 4 of ``benchmarks/aperture.py``: the ``aperture_scouts`` mission over seeds, scored from its logs.

Each seed is one run of ``missions/aperture_scouts.yaml`` through the campaign runner. From its MCAP log:
whether each scout's run ended with an ``object_found`` event of its class (scout 1 the fire extinguisher,
scout 2 the chair), when, the rim contacts the referee recorded (``rim_contacts``, truth), and how each scout
run ended otherwise (the last outcome of its subtree's nodes, e.g. the low-battery landing). Target: both
objects found in ≥ 9 of 10 seeds.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from benchmarks.bench_common import campaign_spec, campaigns
from marsupial.trees.campaign import CampaignSpec
from marsupial.trees.replay import read_log

MISSION = "aperture_scouts"
SCOUTS = {"scout_1": "fire_extinguisher", "scout_2": "chair"}
MISSION_HEADING = "## The mission `aperture_scouts` over seeds"
TARGET_BOTH = 0.9  # both objects found in ≥ 9 of 10 seeds (the acceptance)
PAPER_SCOUT = {"scout_height": "null", "scout_stuck_time": "null"}
"""The scouts as §IV-G has them: at their launch height, no stuck rule (the mission's two departures off)."""


def score_run(record: dict[str, Any]) -> dict[str, Any]:
    """One seed's scores from its log: per scout found or not (and when), rim contacts, the run's end."""
    log = read_log(record["log"])
    found = {e["robot"]: e for e in log.events_of("state_change") if e.get("phase") == "object_found"}
    launched = {e["scout"]: e["t"] for e in log.events_of("state_change") if e.get("phase") == "launched"}
    _, rim = log.metric("rim_contacts", robot="mms")
    row: dict[str, Any] = {"seed": record["seed"], "outcome": record["outcome"], "sim_time": record["sim_time"],
                           "rim_contacts": int(rim[-1]) if rim.size else 0}
    for scout, wanted in SCOUTS.items():
        event = found.get(scout)
        ok = event is not None and event.get("object_class") == wanted
        ends = [e for e in log.events_of("outcome") if e.get("robot") == scout]
        row[scout] = {"found": ok, "t_found": round(event["t"], 1) if ok else None,
                      "launched": round(launched[scout], 1) if scout in launched else None,
                      "flight_to_find": round(event["t"] - launched[scout], 1) if ok and scout in launched else None,
                      "ended": f"{ends[-1]['node']}: {ends[-1]['message'][:80]}" if ends else "never ran"}
    row["both"] = all(row[s]["found"] for s in SCOUTS)
    return row


def mission_seeds(runs: Path, seeds: int, workers: int) -> dict[str, Any]:
    """``seeds`` runs of the mission (seeds 0 … seeds−1), each scored from its log, and the same seeds with the
    paper's scout policy (:data:`PAPER_SCOUT`, under ``paper_scout``); all the trials in one pool of ``workers``."""
    specs = [campaign_spec(MISSION, seeds, runs / "mission"),
             campaign_spec(MISSION, seeds, runs / "mission_paper_scout", overrides=PAPER_SCOUT)]
    campaigns(specs, workers)
    ours, paper = (_scores(spec) for spec in specs)
    return {**ours, "paper_scout": paper}


def _scores(spec: CampaignSpec) -> dict[str, Any]:
    """One campaign of the mission scored from its logs: both objects found, per scout, rim contacts, each seed."""
    rows = [score_run(r) for r in json.loads((spec.out / "trials.json").read_text())]
    both = sum(r["both"] for r in rows)
    return {"mission": f"missions/{MISSION}.yaml", "set": spec.overrides, "seeds": len(rows), "both_found": both,
            "rate": both / len(rows) if rows else 0.0, "found": {s: sum(r[s]["found"] for r in rows) for s in SCOUTS},
            "rim_contacts": sum(r["rim_contacts"] for r in rows), "rows": rows}


def verdict(ms: dict[str, Any]) -> tuple[bool, str]:
    """Whether both objects were found in enough seeds, and what was measured."""
    return (ms["rate"] >= TARGET_BOTH,
            f"{ms['both_found']}/{ms['seeds']} seeds (extinguisher {ms['found']['scout_1']}, chair "
            f"{ms['found']['scout_2']}); {ms['rim_contacts']} rim contacts")


def mission_lines(ms: dict[str, Any]) -> list[str]:
    """The page's section on the mission over seeds."""
    lines = [
        MISSION_HEADING,
        "",
        f"{ms['seeds']} seeds of `{ms['mission']}` (default sensing, team link and noise; the world's seed varies "
        "the sensor noise, the odometry and the link's drops). Both objects found in "
        f"**{ms['both_found']}/{ms['seeds']}** seeds; rim contacts over all runs: **{ms['rim_contacts']}**.",
        "",
        "| seed | scout 1 → extinguisher (s after launch) | scout 2 → chair (s after launch) | rim contacts | "
        "sim time (s) |",
        "|---|---|---|---|---|",
    ]
    for r in ms["rows"]:
        cells = []
        for scout in SCOUTS:
            s = r[scout]
            cells.append(f"found, {s['flight_to_find']} s" if s["found"] else f"**not found** ({s['ended']})")
        lines.append(f"| {r['seed']} | {cells[0]} | {cells[1]} | {r['rim_contacts']} | {r['sim_time']:.0f} |")
    paper = ms.get("paper_scout")
    if paper is not None:
        sets = " ".join(f"--set {k}={v}" for k, v in paper["set"].items())
        lines += ["", "The same seeds with the scouts as §IV-G has them (`" + sets + "`: at their launch height, "
                  f"≈1.1 m, and no stuck rule): both objects in **{paper['both_found']}/{paper['seeds']}** seeds "
                  f"(extinguisher {paper['found']['scout_1']}, chair {paper['found']['scout_2']}); rim contacts "
                  f"{paper['rim_contacts']}.", "",
                  "| seed | scout 1 (paper's policy) | scout 2 (paper's policy) |", "|---|---|---|"]
        for r in paper["rows"]:
            cells = [f"found, {r[s]['flight_to_find']} s" if r[s]["found"] else f"**not found** ({r[s]['ended']})"
                     for s in SCOUTS]
            lines.append(f"| {r['seed']} | {cells[0]} | {cells[1]} |")
    return lines
