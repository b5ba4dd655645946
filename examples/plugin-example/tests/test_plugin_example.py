"""The example's skill: its algorithm alone, then in its mission, read back from the log and replayed."""

from pathlib import Path

import numpy as np
from marsupial_plugin_example.hover import horizontal_drift

from marsupial.trees.against import assert_replays
from marsupial.trees.replay import read_log
from marsupial.trees.runner import run_mission

MISSION = Path(__file__).resolve().parents[1] / "mission.yaml"


def test_horizontal_drift_ignores_height():
    assert horizontal_drift(np.array([1.0, 2.0, 1.2]), np.array([4.0, 6.0, 0.2])) == 5.0


def test_metered_hover_holds_the_uav_and_replays(tmp_path):
    log_path = tmp_path / "plugin.mcap"
    result = run_mission(MISSION, log_path=log_path, progress=False, until=30, record_inputs=True)
    assert result.outcome == "success"
    log = read_log(log_path)
    t, drift = log.metric("hover_drift", robot="uav")
    assert len(t) >= 19 and drift.max() < 0.3  # 2 s of hovering at 10 Hz, held in place
    _, height = log.metric("hover_sonar_range", robot="uav")
    assert 1.0 < np.median(height) < 1.5  # the sonar sees the floor about 1.2 m below
    assert_replays(log_path, MISSION)  # the skills answer the recorded inputs with the commands logged
