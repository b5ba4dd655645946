"""Campaigns: Wilson interval, trial plan, output files, same per-trial outcomes on the local and Ray backends."""

import csv
import json
import shutil
import tempfile
from pathlib import Path

import pytest

from marsupial.trees.campaign import plan_trials, run_campaign, wilson_interval
from marsupial.trees.errors import MissionError

MISSION = """\
mission: camp
team:
  uav: {robot: bebop2, pose: [0, 0, 1.0, 0]}
params:
  limit: 30
tree:
  timeout: {skill: goto, robot: uav, params: {target: [3, 0, 1.0], speed: 2.0}}
  seconds: ${limit}
"""


@pytest.fixture
def mission(tmp_path):
    path = tmp_path / "camp.yaml"
    path.write_text(MISSION)
    return str(path)


def test_wilson_interval_matches_known_values():
    assert wilson_interval(5, 10) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    assert wilson_interval(0, 4) == pytest.approx((0.0, 0.4899), abs=1e-4)
    assert wilson_interval(4, 4) == pytest.approx((0.5101, 1.0), abs=1e-4)
    assert wilson_interval(0, 0) == (0.0, 1.0)


def test_plan_pairs_seeds_across_combinations(mission):
    plan = plan_trials(mission, 3, base_seed=10, overrides={"world.seed": "1"}, vary={"limit": ["1", "2"]})
    assert [(t.index, t.seed, t.varied["limit"]) for t in plan] == [
        (0, 10, "1"), (1, 11, "1"), (2, 12, "1"), (3, 10, "2"), (4, 11, "2"), (5, 12, "2")]
    with pytest.raises(MissionError, match="limt"):
        plan_trials(mission, 1, vary={"limt": ["1"]})


def campaign(mission, out, backend):
    return run_campaign(mission, 2, out, base_seed=3, vary={"limit": ["0.5", "30"]}, workers=2, backend=backend)


def test_local_campaign_writes_trials_and_summary(mission, tmp_path):
    out = tmp_path / "local"
    summary = campaign(mission, out, "local")
    trials = json.loads((out / "trials.json").read_text())
    assert [(t["seed"], t["params"]["limit"], t["outcome"]) for t in trials] == [
        (3, "0.5", "failure"), (4, "0.5", "failure"), (3, "30", "success"), (4, "30", "success")]
    assert summary["success_rate"] == 0.5
    assert all(t["cpu_time"] > 0.0 for t in trials)  # each trial's own CPU seconds, for the benchmarks' RTF
    assert summary["success_rate_ci95"] == pytest.approx(list(wilson_interval(2, 4)))
    assert [g["success_rate"] for g in summary["groups"]] == [0.0, 1.0]
    assert json.loads((out / "summary.json").read_text()) == summary
    rows = list(csv.DictReader((out / "trials.csv").open()))
    assert [r["outcome"] for r in rows] == ["failure", "failure", "success", "success"]
    assert "param:limit" in rows[0] and "metric:battery_soc[uav]" in rows[0]
    kept = sorted(p.name for p in (out / "logs").iterdir())  # failing trials keep their log
    assert kept == ["trial_0000_seed_3.mcap", "trial_0001_seed_4.mcap"]


def test_local_and_ray_backends_give_the_same_outcomes(mission, tmp_path):
    pytest.importorskip("ray", reason="Ray is an optional extra: pip install 'marsupial[ray]'")
    local = tmp_path / "local"
    campaign(mission, local, "local")
    out = Path(tempfile.mkdtemp(prefix="mc", dir="/tmp"))  # Ray's socket paths must stay short
    try:
        campaign(mission, out, "ray")
        assert (out / "ray").is_dir()  # Ray's session files stay inside the campaign folder
        keys = ("trial", "seed", "params", "outcome", "sim_time", "ticks", "metrics")
        on_ray = [{k: t[k] for k in keys} for t in json.loads((out / "trials.json").read_text())]
    finally:
        shutil.rmtree(out, ignore_errors=True)
    locally = [{k: t[k] for k in keys} for t in json.loads((local / "trials.json").read_text())]
    assert on_ray == locally


def test_ray_needs_a_short_output_path(mission, tmp_path):
    with pytest.raises(MissionError, match="socket paths"):
        run_campaign(mission, 1, tmp_path / ("x" * 60), backend="ray")


def test_campaign_command_ends_with_the_report_command(mission, tmp_path):
    from click.testing import CliRunner

    from marsupial.trees.cli import cli

    out = tmp_path / "my campaign"
    result = CliRunner().invoke(cli, ["campaign", mission, "--trials", "1", "--workers", "1", "--out", str(out),
                                      "--until", "2"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1] == f"report: marsupial report '{out}'"
    assert (out / "summary.json").is_file()
