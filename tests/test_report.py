"""HTML reports: what a run page and a campaign page contain, that mission text stays text, and the CLI around them
(default logs in runs/, the printed report command, marsupial.run)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner
from report_fixtures import SCRIPT_NODE, SMALL_LOG, fake_campaign, hostile_log

import marsupial
from marsupial.trees.cli import cli
from marsupial.trees.replay import read_log
from marsupial.trees.report import render_run, write_report

GOOD = """\
mission: good
team:
  uav: {robot: bebop2, pose: [0, 0, 1.0, 0]}
params: {duration: 0.5}
tree:
  sequence:
    - {skill: hover, robot: uav, params: {seconds: "${duration}"}}
"""


def invoke(*args: object):
    return CliRunner().invoke(cli, [str(a) for a in args], env={"COLUMNS": "200"})


def section(html: str, name: str) -> str:
    """The text of ``<section id="name">`` … ``</section>``."""
    match = re.search(rf'<section id="{name}">(.*?)</section>', html, re.S)
    assert match, f"no section {name}"
    return match.group(1)


@pytest.fixture(scope="module")
def hostile(tmp_path_factory) -> Path:
    return hostile_log(tmp_path_factory.mktemp("hostile"))


def test_run_report_shows_every_part_of_the_small_log(tmp_path):
    page = write_report(SMALL_LOG, tmp_path / "small.html")
    html = page.read_text()
    log = read_log(SMALL_LOG)
    assert "<script" not in html  # a static page: no code at all
    assert 'id="outcome">success<' in html
    summary = section(html, "summary")
    assert "small_run" in html and ">7<" in summary and "0.90 s" in summary
    assert "carrier, uav" in summary  # both robots
    map_svg = section(html, "map")
    assert map_svg.count("<svg") == 1 and "carrier true" in map_svg and "carrier estimate" in map_svg
    assert "uav true" in map_svg
    timeline = section(html, "timeline")
    assert timeline.count("<svg") == 1
    for name in log.tree_snapshots[-1].names.values():
        assert name in timeline
    assert "preempted" in timeline  # the legend of the preemption marker
    events = section(html, "events")
    assert events.count("<tr") == len(log.events) + 1
    assert "battery_below 0.75" in events  # the preemption's reason
    metrics = section(html, "metrics")
    assert "battery" in metrics and "<svg" in metrics
    images = section(html, "images")
    assert images.count('src="data:image/png;base64,') == 1  # the one frame of /uav/camera/image


def test_timeline_intervals_follow_the_tree_snapshots():
    from marsupial.trees.report.run import tree_rows

    log = read_log(SMALL_LOG)
    rows = {row["name"]: row for row in tree_rows(log.tree_snapshots, log.sim_time)}
    explore = rows["explore"]["intervals"]
    preemption = log.events_of("preemption")[0]
    assert explore[0][2] == "RUNNING" and explore[0][1] == pytest.approx(preemption["t"])  # runs until preempted
    assert rows["dock"]["intervals"][0][0] == pytest.approx(preemption["t"])  # dock takes over then
    assert rows["takeoff"]["intervals"][-1][2] == "SUCCESS"


def test_mission_text_is_shown_never_run(hostile, tmp_path):
    html = render_run(hostile)
    assert "<script" not in html and "<img src=x" not in html and "<b>bold" not in html and "<i>operator" not in html
    escaped = "&lt;script&gt;alert(1)&lt;/script&gt;"
    assert escaped in section(html, "timeline")  # the node's row label, as SVG text
    assert escaped in section(html, "events")
    assert "&lt;b&gt;bold&lt;/b&gt; claim &amp; a $x^2$ formula" in html
    assert "cost $5 and $6" in section(html, "timeline")  # no mathtext either
    assert "&lt;i&gt;operator&lt;/i&gt; says so" in section(html, "events")
    assert 'class="operator"' in section(html, "events")
    preempted = read_log(hostile).events_of("preemption")
    assert [e["by"] for e in preempted] == [SCRIPT_NODE]


def test_campaign_report_links_every_kept_trial(tmp_path):
    folder = fake_campaign(tmp_path / "campaign")
    page = write_report(folder)
    assert page == folder / "report.html"
    html = page.read_text()
    assert "<script" not in html and "fake &lt;mission&gt;" in html
    assert re.search(r'id="success-rate">75 %<', html)
    assert 'id="success-ci">[30 %, 95 %]<' in html  # Wilson 95 % interval of 3 of 4
    assert "time_limit" in section(html, "outcomes") and "<svg" in section(html, "outcomes")
    distributions = section(html, "distributions")
    assert "simulated time (s) (n=4)" in distributions and "landing_error (n=4)" in distributions
    links = re.findall(r'href="([^"]+)">run report<', html)
    assert links == ["reports/trial_0003_seed_3.html"]
    trial_page = (folder / links[0]).read_text()
    assert 'href="../report.html"' in trial_page and "small_run" in trial_page


def test_campaign_folder_moved_keeps_its_links(tmp_path):
    folder = fake_campaign(tmp_path / "before")
    moved = shutil.move(str(folder), tmp_path / "after")
    page = write_report(moved, tmp_path / "pages" / "campaign.html")
    assert re.findall(r'href="([^"]+)">run report<', page.read_text()) == ["reports/trial_0003_seed_3.html"]
    assert (tmp_path / "pages" / "reports" / "trial_0003_seed_3.html").is_file()


def test_report_command_writes_next_to_the_log_or_to_output(tmp_path):
    log = tmp_path / "run.mcap"
    shutil.copy(SMALL_LOG, log)
    result = invoke("report", log)
    assert result.exit_code == 0, result.output
    assert result.output.strip() == f"report: {tmp_path / 'run.html'}" and (tmp_path / "run.html").is_file()
    result = invoke("report", log, "-o", tmp_path / "out" / "page.html")
    assert result.exit_code == 0 and (tmp_path / "out" / "page.html").is_file()


@pytest.mark.parametrize("case", ["missing", "not_mcap", "not_campaign"])
def test_report_of_bad_input_exits_2_with_one_line(tmp_path, case):
    source = {"missing": tmp_path / "absent.mcap", "not_mcap": tmp_path / "text.mcap", "not_campaign": tmp_path}[case]
    if case == "not_mcap":
        source.write_text("hello")
    result = invoke("report", source)
    assert result.exit_code == 2
    expected = {"missing": "no such log file", "not_mcap": "not an MCAP file", "not_campaign": "not a campaign folder"}
    assert expected[case] in result.output and "Traceback" not in result.output


def test_first_run_logs_to_runs_and_prints_the_report_command(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "good.yaml").write_text(GOOD)
    result = invoke("run", "good.yaml", "-q")
    assert result.exit_code == 0, result.output
    (log,) = (tmp_path / "runs").glob("*.mcap")
    assert re.fullmatch(r"good-\d{8}T\d{6}Z\.mcap", log.name)
    relative = log.relative_to(tmp_path)
    assert result.output.splitlines()[-2:] == [f"log: {relative}", f"report: marsupial report {relative}"]
    assert read_log(log).outcome == "success"
    assert invoke("report", relative).exit_code == 0 and log.with_suffix(".html").is_file()
    second = invoke("run", "good.yaml", "-q")  # the same second: a new name, nothing overwritten
    assert second.exit_code == 0 and len(list((tmp_path / "runs").glob("*.mcap"))) == 2


def test_no_log_writes_nothing_and_log_excludes_no_log(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "good.yaml").write_text(GOOD)
    result = invoke("run", "good.yaml", "-q", "--no-log")
    assert result.exit_code == 0 and "log:" not in result.output and not (tmp_path / "runs").exists()
    both = invoke("run", "good.yaml", "--no-log", "--log", "x.mcap")
    assert both.exit_code == 2 and "--log and --no-log exclude each other" in both.output
    assert invoke("run", "good.yaml", "--port", "9000").exit_code == 2  # --port without --live
    slow = invoke("run", "good.yaml", "--speed", "0")
    assert slow.exit_code == 2 and "is not a speed" in slow.output


def test_python_api_runs_with_overrides_and_returns_the_log(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "good.yaml").write_text(GOOD)
    result = marsupial.run("good.yaml", seed=5, set={"params.duration": 0.2})
    assert result.outcome == "success" and result.seed == 5
    assert result.log_path.parent == Path("runs") and result.log_path.is_file()
    log = marsupial.read_log(result.log_path)
    assert log.seed == 5 and json.loads(log.metadata["overrides"]) == {"params.duration": "0.2"}
    assert log.sim_time == pytest.approx(0.2, abs=0.11)
    quiet = marsupial.run("good.yaml", log=False)
    assert quiet.log_path is None and len(list(Path("runs").glob("*"))) == 1
    named = marsupial.run("good.yaml", log=tmp_path / "named.mcap")
    assert named.log_path == tmp_path / "named.mcap" and named.log_path.is_file()


def test_phases_last_until_the_next_phase_or_the_outcome():
    from marsupial.trees.report.run import phase_rows

    events = [
        {"t": 0.0, "kind": "run_start"},
        {"t": 1.0, "kind": "state_change", "node": "contact", "phase": "authorized"},
        {"t": 2.5, "kind": "state_change", "node": "contact", "phase": "approach"},
        {"t": 3.0, "kind": "state_change", "node": "land", "state": "descending"},
        {"t": 4.0, "kind": "outcome", "node": "contact", "status": "SUCCESS"},
        {"t": 4.5, "kind": "state_change", "node": "land", "status": "RUNNING"},  # no phase: changes nothing
    ]
    assert phase_rows(events, end=6.0) == [
        {"name": "contact", "intervals": [(1.0, 2.5, "authorized"), (2.5, 4.0, "approach")]},
        {"name": "land", "intervals": [(3.0, 6.0, "descending")]},
    ]
