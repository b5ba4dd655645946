"""Logs and campaign folders the report tests share: a real run whose mission text is hostile HTML, a fake campaign."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import marsupial.missions
from marsupial.trees.campaign import summarize
from marsupial.trees.runner import run_mission

DATA = Path(__file__).resolve().parent / "data"
SMALL_LOG = DATA / "small_run.mcap"
SCRIPT_NODE = "<script>alert(1)</script>"

#: node names, description and operator reason that would be markup (or mathtext) if not escaped
HOSTILE = """\
mission: hostile_names
description: "A <b>bold</b> claim & a $x^2$ formula: <img src=x onerror=alert(2)>"
team:
  uav: {robot: bebop2, pose: [0, 0, 1.0, 0]}
operator:
  - {at: 0.5, say: land, why: "<i>operator</i> says so"}
run: {tick_hz: 10, until: 10}
tree:
  sequence:
    - priorities:
        - when: {operator: land}
          do: {skill: hover, robot: uav, name: "<script>alert(1)</script>", params: {seconds: 0.3}}
        - do: {skill: hover, robot: uav, name: "cost $5 and $6", params: {seconds: 5}}
    - {skill: wait, name: "settle & rest", params: {seconds: 0.2}}
"""


def hostile_log(folder: Path) -> Path:
    """Run the hostile mission (1 s of simulated time) and return its log."""
    mission = folder / "hostile.yaml"
    mission.write_text(HOSTILE)
    log = folder / "hostile.mcap"
    result = run_mission(str(mission), log_path=log, progress=False)
    assert result.outcome == "success", result.message
    return log


#: usar_docking's operator script made short: two dockings within a minute of simulated time
TWO_DOCKINGS = """\
operator:
  - {at: 2.0, say: deploy, why: survey the hall}
  - {at: 12.0, say: dock, why: first docking}
  - {at: 30.0, say: deploy, why: survey again}
  - {at: 40.0, say: dock, why: second docking}
"""


def usar_docking_twice(folder: Path) -> Path:
    """usar_docking with the UAV deployed and docked twice in 60 s of simulated time; returns its log."""
    text = (Path(marsupial.missions.__file__).parent / "usar_docking.yaml").read_text()
    mission = folder / "usar_docking.yaml"
    mission.write_text(re.sub(r"^operator:.*?\n(?=params:)", TWO_DOCKINGS, text, count=1, flags=re.S | re.M))
    log = folder / "usar_docking.mcap"
    result = run_mission(str(mission), log_path=log, progress=False, until=60)
    assert result.outcome == "time_limit", result.message
    return log


def fake_campaign(folder: Path) -> Path:
    """A campaign folder of four trials (3 successes, 1 time limit whose log is the small reference log)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "logs").mkdir(exist_ok=True)
    kept = folder / "logs" / "trial_0003_seed_3.mcap"
    shutil.copy(SMALL_LOG, kept)
    records = [
        {"trial": i, "seed": i, "params": {}, "outcome": "success" if i < 3 else "time_limit", "success": i < 3,
         "sim_time": 10.0 + i, "ticks": 100, "wall_time": 1.0, "metrics": {"landing_error": 0.05 * (i + 1)},
         "message": "", "log": str(kept) if i == 3 else None}
        for i in range(4)
    ]
    summary = {"mission": "fake <mission>", "backend": "local", "workers": 1, "base_seed": 0, "set": {}, "vary": {},
               "until": None, **summarize(records), "groups": []}
    (folder / "trials.json").write_text(json.dumps(records))
    (folder / "summary.json").write_text(json.dumps(summary))
    return folder
