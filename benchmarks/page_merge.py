"""Regenerating one section of a results page: the rest of the page, hand-written notes included, kept as it is.

The scripts run as ``python benchmarks/<name>.py``, so this module is found next to them.
"""

from __future__ import annotations

from collections.abc import Sequence

from benchmarks.bench_common import targets_lines


def merge_section(page: str, heading: str, lines: Sequence[str], before: str | None = None) -> str:
    """``page`` (Markdown) with the section that starts at the line ``heading`` replaced by ``lines`` (up to the next
    ``## `` heading), or, if it has none, ``lines`` inserted before the line ``before`` (else at the end): one
    section regenerated, the rest of the page (hand-written notes included) kept as it is."""
    rows = page.splitlines()
    new = [*lines, ""]
    if heading in rows:
        start = rows.index(heading)
        end = next((i for i in range(start + 1, len(rows)) if rows[i].startswith("## ")), len(rows))
        rows[start:end] = new
    elif before is not None and before in rows:
        at = rows.index(before)
        rows[at:at] = new
    else:
        rows += ["", *new]
    return "\n".join(rows).rstrip("\n") + "\n"


def merge_target_row(page: str, label: str, met: bool, measured: str) -> str:
    """``page`` with the row of target ``label`` in its "Targets" table (:func:`targets_lines`) replaced, or added
    at the table's end; the table is made when the page has none."""
    row = f"| {label} | {measured} | {'yes' if met else '**no**'} |"
    rows = page.splitlines()
    if "## Targets" not in rows:
        return merge_section(page, "## Targets", targets_lines({"t": label}, {"t": (met, measured)}))
    start = rows.index("## Targets")
    table = [i for i in range(start, len(rows)) if rows[i].startswith("|")]
    table = [i for k, i in enumerate(table) if i == table[0] + k]  # the first table after the heading
    mine = [i for i in table if rows[i].startswith(f"| {label} |")]
    if mine:
        rows[mine[0]] = row
    else:
        rows.insert(table[-1] + 1, row)
    return "\n".join(rows) + "\n"
