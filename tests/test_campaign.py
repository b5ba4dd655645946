"""Campaigns: Wilson interval, trial plan, output files, resuming, the progress bar, and the same per-trial results
one after another, in parallel and on Ray."""

import csv
import json
import shutil
import tempfile
from pathlib import Path

import pytest
from rich.console import Console

from marsupial.trees.campaign import CampaignSpec, plan_trials, run_campaign, run_campaigns, run_trials, wilson_interval
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
    assert [(t.index, t.seed, t.varied["limit"]) for t in plan] == [  # seed by seed: more trials keep these numbers
        (0, 10, "1"), (1, 10, "2"), (2, 11, "1"), (3, 11, "2"), (4, 12, "1"), (5, 12, "2")]
    with pytest.raises(MissionError, match="limt"):
        plan_trials(mission, 1, vary={"limt": ["1"]})


def campaign(mission, out, backend):
    return run_campaign(mission, 2, out, base_seed=3, vary={"limit": ["0.5", "30"]}, workers=2, backend=backend)


@pytest.mark.slow
def test_local_campaign_writes_trials_and_summary(mission, tmp_path):
    out = tmp_path / "local"
    summary = campaign(mission, out, "local")
    trials = json.loads((out / "trials.json").read_text())
    assert [(t["seed"], t["params"]["limit"], t["outcome"]) for t in trials] == [
        (3, "0.5", "failure"), (3, "30", "success"), (4, "0.5", "failure"), (4, "30", "success")]
    assert summary["success_rate"] == 0.5
    assert all(t["cpu_time"] > 0.0 for t in trials)  # each trial's own CPU seconds, for the benchmarks' RTF
    assert summary["success_rate_ci95"] == pytest.approx(list(wilson_interval(2, 4)))
    assert [g["success_rate"] for g in summary["groups"]] == [0.0, 1.0]
    assert json.loads((out / "summary.json").read_text()) == summary
    rows = list(csv.DictReader((out / "trials.csv").open()))
    assert [r["outcome"] for r in rows] == ["failure", "success", "failure", "success"]
    assert "param:limit" in rows[0] and "metric:battery_soc[uav]" in rows[0]
    kept = sorted(p.name for p in (out / "logs").iterdir())  # failing trials keep their log
    assert kept == ["trial_0000_seed_3.mcap", "trial_0002_seed_4.mcap"]


@pytest.mark.slow
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


RESULT_KEYS = ("trial", "seed", "params", "outcome", "success", "sim_time", "ticks", "metrics", "message")
ENCOUNTER = Path(__file__).resolve().parents[1] / "benchmarks" / "missions" / "docking_encounter.yaml"


def results(records):
    """What a trial's run decides (everything but its wall and CPU seconds and where its log went)."""
    return [{k: r[k] for k in RESULT_KEYS} for r in records]


@pytest.mark.slow
def test_parallel_trials_give_the_results_of_a_serial_run(tmp_path):
    # 2 seeds x 2 carrier speeds of the docking encounter, 4 s each (cameras, noise, the UAV's estimate): one after
    # another in this process, then 2 at a time in spawned processes, in completion order
    vary = {"carrier_speed": ["0.1", "0.4"]}
    plan = plan_trials(str(ENCOUNTER), 2, base_seed=5, vary=vary, until=4.0, log_dir=tmp_path / "logs")
    serial = run_trials(plan, workers=1)
    parallel = run_trials(plan, workers=2)
    assert results(parallel) == results(serial)
    assert [r["trial"] for r in serial] == [0, 1, 2, 3]
    assert len({json.dumps(r["metrics"], sort_keys=True) for r in serial}) == 4  # each trial ran a run of its own
    assert all(r["outcome"] == "time_limit" and r["sim_time"] == pytest.approx(4.0) for r in serial)


def test_progress_bar_counts_trials_and_shows_the_eta(mission):
    console = Console(force_terminal=True, record=True, width=120)
    records = run_trials(plan_trials(mission, 2, vary={"limit": ["0.5"]}), workers=1, console=console, label="camp")
    shown = console.export_text()
    assert [r["outcome"] for r in records] == ["failure", "failure"]
    assert "camp (local, 2 failed)" in shown and "2/2" in shown and "ETA" in shown


def test_resume_reads_back_finished_trials_and_runs_only_the_new_ones(mission, tmp_path):
    out = tmp_path / "c"
    first = run_campaign(mission, 1, out, vary={"limit": ["0.5", "30"]}, workers=1, keep_logs="all")
    before = json.loads((out / "trials.json").read_text())
    with open(out / "finished.jsonl", "a") as journal:
        journal.write('{"plan": {"trial": 2, "mis')  # a line cut off by an interruption
    more = run_campaign(mission, 2, out, vary={"limit": ["0.5", "30"]}, workers=1, keep_logs="all", resume=True)
    after = json.loads((out / "trials.json").read_text())
    assert (first["resumed_trials"], more["resumed_trials"], more["trials"]) == (0, 2, 4)
    assert after[:2] == before  # read back as they were (wall times included)
    assert [(r["seed"], r["params"]["limit"]) for r in after[2:]] == [(1, "0.5"), (1, "30")]
    assert all(Path(r["log"]).is_file() for r in after)
    # a longer limit than a run needed gives the same run; another override or a shorter limit does not
    assert run_campaign(mission, 2, out, vary={"limit": ["0.5", "30"]}, workers=1, keep_logs="all", until=20.0,
                        resume=True)["resumed_trials"] == 4
    assert run_campaign(mission, 2, out, vary={"limit": ["0.5", "30"]}, workers=1, keep_logs="all", until=1.0,
                        resume=True)["resumed_trials"] == 2  # the limit 0.5 trials failed before 1 s
    assert run_campaign(mission, 2, out, overrides={"world.seed": "1"}, vary={"limit": ["0.5", "30"]}, workers=1,
                        resume=True)["resumed_trials"] == 0


def test_resume_runs_again_a_trial_whose_log_was_not_kept(mission, tmp_path):
    out = tmp_path / "c"
    run_campaign(mission, 1, out, vary={"limit": ["0.5", "30"]}, workers=1, keep_logs="failed")
    # the success's log was not kept: a campaign keeping every log runs that trial again
    again = run_campaign(mission, 1, out, vary={"limit": ["0.5", "30"]}, workers=1, keep_logs="all", resume=True)
    assert again["resumed_trials"] == 1


def test_campaigns_of_one_run_need_folders_of_their_own(mission, tmp_path):
    spec = CampaignSpec(mission, 1, tmp_path / "c")
    with pytest.raises(MissionError, match="same folder"):
        run_campaigns([spec, CampaignSpec(mission, 2, tmp_path / "c" / ".." / "c")])
    assert not (tmp_path / "c").exists()  # refused before anything was written


def test_campaign_command_ends_with_the_report_command(mission, tmp_path):
    from click.testing import CliRunner

    from marsupial.trees.cli import cli

    out = tmp_path / "my campaign"
    result = CliRunner().invoke(cli, ["campaign", mission, "--trials", "1", "--workers", "1", "--out", str(out),
                                      "--until", "2"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1] == f"report: marsupial report '{out}'"
    assert (out / "summary.json").is_file()
