"""The campaign pages of the landing and docking benchmarks' campaigns (``marsupial report CAMPAIGN_DIR``).

    python benchmarks/campaign_reports.py [--trials 4] [--workers N] [--runs DIR] [--pages docs/results/campaigns]

Runs, through the campaign runner with every log kept, the campaigns the
benchmarks are made of at a size one machine runs in minutes:

- ``landing_circular`` and ``landing_linear`` (``benchmarks/landing.py`` §4.2.1,
  our controller, sensing at its default), ``--trials`` seeds each;
- the docking encounters of ``benchmarks/uav_docking.py`` (its quick grid: four
  random UAV starts near the meeting point and one carrier speed), ``--trials``
  trials in all (``--trials`` / 4 seeds per start, at least one).

Then writes each campaign's page and its trials' run reports to
``--pages/<campaign>/`` (``report.html``, ``reports/*.html``) and prints a
table of the success rates. ``docs/results/campaigns.md`` links the pages.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from rich.console import Console
from rich.table import Table

if not __package__:  # run as a file (python benchmarks/<name>.py): the benchmarks package from the repository
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from benchmarks.uav_docking import ENCOUNTER, encounter_grid
from marsupial.trees.campaign import CampaignSpec, run_campaigns
from marsupial.trees.report import write_report

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_PAGES = ROOT / "docs" / "results" / "campaigns"


def campaign_specs(trials: int, runs: Path) -> dict[str, CampaignSpec]:
    """Campaign name -> its campaign (every log kept), in ``runs/<name>``."""
    return {
        "landing_circular": CampaignSpec("landing_circular", trials, runs / "landing_circular", keep_logs="all"),
        "landing_linear": CampaignSpec("landing_linear", trials, runs / "landing_linear", keep_logs="all"),
        "docking_encounters": CampaignSpec(str(ENCOUNTER), max(1, trials // 4), runs / "docking_encounters",
                                           vary=encounter_grid(quick=True), keep_logs="all"),
    }


def main(argv: list[str] | None = None) -> None:
    """Run the campaigns (their trials in one pool), write their pages, print the success rates."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=4, help="seeds per campaign (per combination for docking)")
    parser.add_argument("--workers", type=int, default=None, help="parallel trials (default: every core)")
    parser.add_argument("--runs", type=Path, default=None, help="folder of the campaigns and logs (default: temporary)")
    parser.add_argument("--pages", type=Path, default=DEFAULT_PAGES, help="where the pages go")
    args = parser.parse_args(argv)
    table = Table(title="benchmark campaigns", title_justify="left")
    for column in ("campaign", "trials", "success", "95% CI", "outcomes", "page"):
        table.add_column(column)
    with tempfile.TemporaryDirectory() as tmp:
        specs = campaign_specs(args.trials, args.runs or Path(tmp))
        summaries = run_campaigns(list(specs.values()), workers=args.workers)
        for (name, spec), summary in zip(specs.items(), summaries, strict=True):
            page = write_report(spec.out, args.pages / name / "report.html")
            low, high = summary["success_rate_ci95"]
            table.add_row(name, str(summary["trials"]), f"{summary['success_rate']:.0%}", f"[{low:.0%}, {high:.0%}]",
                          ", ".join(f"{k} {n}" for k, n in summary["outcomes"].items()), str(page))
    Console().print(table)


if __name__ == "__main__":
    main()
