"""The benchmarks package: it imports without path edits and runs as a module or as a file; its campaigns go through
the shared campaign runner with every log kept and read back what they ran; the profile breakdown's accounting."""

import importlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks import bench_common, profile_breakdown
from marsupial.world.world import PHYSICS_HZ

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p.stem for p in (ROOT / "benchmarks").glob("*.py") if "__main__" in p.read_text())
MISSION = """\
mission: bench
team:
  uav: {robot: bebop2, pose: [0, 0, 1.0, 0]}
params:
  limit: 30
tree:
  timeout: {skill: goto, robot: uav, params: {target: [3, 0, 1.0], speed: 2.0}}
  seconds: ${limit}
"""
ENCOUNTER = ROOT / "benchmarks" / "missions" / "docking_encounter.yaml"


@pytest.mark.slow
def test_every_benchmark_imports_as_a_module_of_the_package():
    assert {"campaign_speed", "landing", "uav_docking", "ugv_docking", "aperture", "world_speed"} <= set(SCRIPTS)
    for name in SCRIPTS:
        assert importlib.import_module(f"benchmarks.{name}").main.__doc__


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS)
def test_a_benchmark_runs_as_a_file_from_anywhere(script, tmp_path):
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / f"{script}.py"), "--help"], cwd=tmp_path,
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert f"usage: {script}.py" in result.stdout


@pytest.mark.slow
def test_a_benchmark_runs_as_a_module_from_the_root():
    result = subprocess.run([sys.executable, "-m", "benchmarks.campaign_speed", "--help"], cwd=ROOT,
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert "usage: campaign_speed.py" in result.stdout


def test_benchmark_campaigns_keep_every_log_and_read_back_what_they_ran(tmp_path):
    mission = tmp_path / "bench.yaml"
    mission.write_text(MISSION)
    specs = [bench_common.campaign_spec(str(mission), 1, tmp_path / "a", vary={"limit": [0.5, 30]}),
             bench_common.campaign_spec(str(mission), 2, tmp_path / "b", overrides={"limit": 30}, base_seed=4)]
    first = bench_common.campaigns(specs, workers=1)
    assert [(s["trials"], s["successes"], s["resumed_trials"]) for s in first] == [(2, 1, 0), (2, 2, 0)]
    records = [json.loads((tmp_path / folder / "trials.json").read_text()) for folder in "ab"]
    assert [(r["seed"], r["params"]) for r in records[0]] == [(0, {"limit": "0.5"}), (0, {"limit": "30"})]
    assert [r["seed"] for r in records[1]] == [4, 5]
    assert all(Path(r["log"]).is_file() for rs in records for r in rs)  # the figures are computed from the logs
    again = bench_common.campaigns(specs, workers=1)
    assert [s["resumed_trials"] for s in again] == [2, 2]
    assert [json.loads((tmp_path / folder / "trials.json").read_text()) for folder in "ab"] == records


@pytest.mark.slow
def test_the_profile_breakdown_accounts_for_the_engine_and_the_modules():
    report = profile_breakdown.breakdown(str(ENCOUNTER), 2.0)  # cameras, LiDAR, sonar and flow rays, physics
    timed, profiled = report["timed"], report["profiled"]
    for run in (timed, profiled):
        assert run["engine"]["stepSimulation"]["calls"] == round(2.0 * PHYSICS_HZ)
        assert all(run["engine"][name]["calls"] > 0 for name in profile_breakdown.ENGINE_CALLS)
        assert run["engine_s"] == pytest.approx(sum(e["s"] for e in run["engine"].values()))
        assert 0.0 < run["engine_share"] < 1.0
    assert {k: v["calls"] for k, v in timed["engine"].items()} == {k: v["calls"] for k, v in profiled["engine"].items()}
    rows = profiled["python_by_module"]
    assert [r["s"] for r in rows[:-1]] == sorted((r["s"] for r in rows[:-1]), reverse=True)
    assert any(r["module"] == "marsupial.world.world" for r in rows)
    assert sum(r["s"] for r in rows) == pytest.approx(profiled["python_s"])
    assert profiled["engine_s"] + profiled["pybullet_other_s"] + profiled["python_s"] == pytest.approx(
        profiled["profiled_s"], rel=0.02)
    sections = profile_breakdown.breakdown_sections(report)
    assert [len(rows) for _, _, rows in sections] == [7, len(rows)]


def test_a_results_page_quotes_its_command_without_the_folders_of_the_machine():
    from benchmarks.bench_common import command_line

    shown = command_line("landing.py", ["--runs", "runs/landing", "--workers", "2", "--out", "/tmp/x.json",
                                        "--report=/home/me/page.md", "--sweep"])
    assert shown == "python benchmarks/landing.py --runs RUNS --workers 2 --out OUT --report=REPORT --sweep"
