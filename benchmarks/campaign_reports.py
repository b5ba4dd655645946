"""The campaign pages of the landing and docking benchmarks' campaigns (``marsupial report CAMPAIGN_DIR``).

    python benchmarks/campaign_reports.py [--trials 4] [--workers 2] [--runs DIR] [--pages docs/results/campaigns]

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

from marsupial.trees.campaign import run_campaign
from marsupial.trees.report import write_report

sys.path.insert(0, str(Path(__file__).resolve().parent))
from uav_docking import ENCOUNTER, encounter_grid  # noqa: E402 (the docking benchmark's encounter grid)

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_PAGES = ROOT / "docs" / "results" / "campaigns"


def campaigns(trials: int) -> dict[str, dict]:
    """Campaign name -> ``run_campaign`` arguments."""
    return {
        "landing_circular": {"mission": "landing_circular", "trials": trials},
        "landing_linear": {"mission": "landing_linear", "trials": trials},
        "docking_encounters": {"mission": str(ENCOUNTER), "trials": max(1, trials // 4),
                               "vary": encounter_grid(quick=True)},
    }


def main(argv: list[str] | None = None) -> None:
    """Run the campaigns, write their pages, print the success rates."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=4, help="seeds per campaign (per combination for docking)")
    parser.add_argument("--workers", type=int, default=2, help="parallel trials (default 2)")
    parser.add_argument("--runs", type=Path, default=None, help="folder of the campaigns and logs (default: temporary)")
    parser.add_argument("--pages", type=Path, default=DEFAULT_PAGES, help="where the pages go")
    args = parser.parse_args(argv)
    table = Table(title="benchmark campaigns", title_justify="left")
    for column in ("campaign", "trials", "success", "95% CI", "outcomes", "page"):
        table.add_column(column)
    with tempfile.TemporaryDirectory() as tmp:
        runs = args.runs or Path(tmp)
        for name, spec in campaigns(args.trials).items():
            summary = run_campaign(spec["mission"], spec["trials"], runs / name, vary=spec.get("vary"),
                                   workers=args.workers, keep_logs="all")
            page = write_report(runs / name, args.pages / name / "report.html")
            low, high = summary["success_rate_ci95"]
            table.add_row(name, str(summary["trials"]), f"{summary['success_rate']:.0%}", f"[{low:.0%}, {high:.0%}]",
                          ", ".join(f"{k} {n}" for k, n in summary["outcomes"].items()), str(page))
    Console().print(table)


if __name__ == "__main__":
    main()
