"""Reports in a real browser: headless Chromium (the system one, driven by playwright) renders the run and the
campaign page without console errors, the map and the timeline are visible, and a node named
``<script>alert(1)</script>`` is shown as text and never runs. The usar_docking report draws the two docking
times as two markers with the unit on the axis, and guards that never held with no FAILURE bar. Screenshots
(pages at a 1280 × 900 viewport, figures at their own size) are saved in the test's folder.

Needs ``chromium`` on the PATH (Debian: ``apt-get install chromium``; ``.ci/run`` installs it) and the
``playwright`` package (the test extra); without them the tests are skipped, saying which is missing.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner
from report_fixtures import HOSTILE, SCRIPT_NODE, fake_campaign, usar_docking_twice

from marsupial.trees.cli import cli
from marsupial.trees.report import write_report

playwright = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install '.[test]')")
CHROMIUM = next(filter(None, map(shutil.which, ("chromium", "chromium-browser", "google-chrome"))), None)
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on PATH (apt-get install chromium)")


@pytest.fixture(scope="module")
def browser():
    with playwright.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield chromium
        chromium.close()


def open_page(browser, page_path: Path, screenshot: Path):
    """Load ``page_path``; returns (page, console errors and page errors, dialogs opened)."""
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    problems: list[str] = []
    dialogs: list[str] = []
    page.on("console", lambda m: problems.append(f"{m.type}: {m.text}") if m.type in ("error", "warning") else None)
    page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
    page.on("requestfailed", lambda r: problems.append(f"failed request: {r.url}"))
    page.on("dialog", lambda d: (dialogs.append(d.message), d.dismiss()))
    page.goto(page_path.resolve().as_uri())
    page.wait_for_load_state("load")
    page.screenshot(path=str(screenshot), full_page=True)
    assert screenshot.stat().st_size > 10_000
    return page, problems, dialogs


def visible_box(page, selector: str) -> dict:
    element = page.locator(selector)
    assert element.count() == 1 and element.is_visible(), selector
    box = element.bounding_box()
    assert box is not None and box["width"] > 300 and box["height"] > 100, (selector, box)
    return box


@pytest.mark.slow
def test_first_run_and_its_report_render_in_chromium(browser, tmp_path, monkeypatch):
    """What a new user does: ``marsupial run`` (logs by default, prints the report command), then that command."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "hostile.yaml").write_text(HOSTILE)
    ran = CliRunner().invoke(cli, ["run", "hostile.yaml", "-q"])
    assert ran.exit_code == 0, ran.output
    command = ran.output.splitlines()[-1].removeprefix("report: ").split()
    assert command[:2] == ["marsupial", "report"] and Path(command[2]).parent == Path("runs")
    reported = CliRunner().invoke(cli, command[1:])
    assert reported.exit_code == 0, reported.output
    page_path = Path(reported.output.strip().removeprefix("report: "))
    page, problems, dialogs = open_page(browser, page_path, tmp_path / "run.png")
    assert problems == [] and dialogs == []
    visible_box(page, "#map svg")
    timeline = visible_box(page, "#timeline svg")
    assert timeline["height"] > 7 * 15  # one row per node (7 nodes)
    assert page.locator("script").count() == 0
    label = page.locator("#timeline svg text", has_text=SCRIPT_NODE)  # the node's row label, shown as text
    assert label.count() == 1 and label.is_visible() and label.text_content().strip() == SCRIPT_NODE
    assert SCRIPT_NODE in page.locator("#events").inner_text()
    assert "<img src=x onerror=alert(2)>" in page.locator("header").inner_text()
    assert page.locator("#outcome").inner_text() == "success"


@pytest.mark.slow
def test_campaign_report_renders_in_chromium(browser, tmp_path):
    page_path = write_report(fake_campaign(tmp_path / "campaign"))
    page, problems, dialogs = open_page(browser, page_path, tmp_path / "campaign.png")
    assert problems == [] and dialogs == []
    assert page.locator("#success-ci").inner_text() == "[30 %, 95 %]"
    visible_box(page, "#outcomes svg")
    page.locator("a", has_text="run report").click()
    page.wait_for_load_state("load")
    assert page.url.endswith("reports/trial_0003_seed_3.html")
    visible_box(page, "#map svg")
    visible_box(page, "#timeline svg")


@pytest.fixture(scope="module")
def usar_report(tmp_path_factory) -> Path:
    return write_report(usar_docking_twice(tmp_path_factory.mktemp("usar")))


def timeline_row(page, name: str) -> int:
    """The timeline row index of the node called ``name`` (its label group ``timeline-label<row>``)."""
    labels = page.locator('#timeline svg g[id^="timeline-label"]')
    rows = [labels.nth(i) for i in range(labels.count()) if labels.nth(i).text_content().strip() == name]
    assert len(rows) == 1, name
    return int(rows[0].get_attribute("id").removeprefix("timeline-label"))


def test_usar_docking_report_draws_what_happened(browser, usar_report, tmp_path):
    page, problems, dialogs = open_page(browser, usar_report, tmp_path / "usar_docking.png")
    assert problems == [] and dialogs == []
    docking = page.locator("#metric-docking_time")
    docking.screenshot(path=str(tmp_path / "docking_time.png"))
    assert docking.locator("svg text", has_text="docking_time (s)").count() == 1  # the unit on the value axis
    assert docking.locator("svg text", has_text="time from the start of tracking to the lock").count() == 1
    markers = docking.locator('g[id="metric-docking_time-0"]')
    assert markers.locator("use").count() == 2 and markers.locator(":scope > path").count() == 0  # no joining line
    assert page.locator('#metric-battery_soc svg text', has_text="battery_soc (fraction 0–1)").count() == 1
    timeline = page.locator("#timeline figure").first
    timeline.screenshot(path=str(tmp_path / "timeline.png"))
    for guard in ("when battery_below(0.2, robot=uav)", "battery_below@uav", "when area_explored(1.0)"):
        row = timeline_row(page, guard)  # never held: drawn neutral, never as a failure
        assert page.locator(f'#timeline svg g[id="timeline-row{row}-failure"]').count() == 0, guard
        assert page.locator(f'#timeline svg g[id="timeline-row{row}-not_holding"]').count() == 1, guard
    assert page.locator("#timeline svg text", has_text="end: time_limit").count() == 1
    milestones = page.locator("#summary tr.milestones").inner_text()
    assert milestones.count("docked at") == 2 and milestones.count("stored at") == 2
    assert (tmp_path / "docking_time.png").stat().st_size > 5_000
