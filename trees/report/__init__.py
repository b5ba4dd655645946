"""HTML reports of runs and campaigns (``marsupial report``): one self-contained page each.

:func:`write_report` takes a run log (``.mcap``) or a campaign folder (the
``--out`` of ``marsupial campaign``) and writes the page: no scripts, no
network, figures as inline SVG (matplotlib), text escaped by jinja2's
autoescape. Figures are static rather than plotly's interactive ones: a page
stays small (tens of kB instead of the 3.5 MB plotly bundle per page), opens
offline and in any viewer, and runs no code from the log. See
``docs/reports.md``.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import jinja2

import marsupial

from ..replay import LogError, read_log

__all__ = ["render", "render_run", "write_report"]

_ENV = jinja2.Environment(
    loader=jinja2.PackageLoader("marsupial.trees.report", "templates"),
    autoescape=True,  # every value from a log or a mission is text, never markup
    undefined=jinja2.StrictUndefined,
    trim_blocks=True,
    lstrip_blocks=True,
)


def render(template: str, context: Mapping[str, Any]) -> str:
    """Render one of the report templates (``run.html.j2``, ``campaign.html.j2``) with ``context``."""
    return _ENV.get_template(template).render(generator_version=marsupial.__version__, **context)


def render_run(log_path: str | Path, links: Mapping[str, str] | None = None) -> str:
    """The HTML report of one run log; :class:`LogError` if it is not a readable marsupial log."""
    from .run import run_context

    log = read_log(log_path)
    if "mission" not in log.metadata:
        raise LogError(f"{log_path}: no marsupial metadata (mission, seed): not a marsupial run log")
    return render("run.html.j2", run_context(log, links))


def write_report(source: str | Path, out: str | Path | None = None) -> Path:
    """Write the report of ``source`` (a ``.mcap`` log or a campaign folder) and return the page's path.

    Default output: ``<log>.html`` next to a log; ``<folder>/report.html`` for a
    campaign (whose trials' reports go to ``<folder>/reports/``).
    """
    source = Path(source)
    if source.is_dir():
        from .campaign import write_campaign_report

        return write_campaign_report(source, Path(out) if out is not None else source / "report.html")
    target = Path(out) if out is not None else source.with_suffix(".html")
    html = render_run(source)
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(html, encoding="utf-8")
    return target
