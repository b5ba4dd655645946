"""Suite-wide checks: tests leave nothing in the repository (default run logs go to ``runs/``)."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO_RUNS = Path(__file__).resolve().parents[1] / "runs"


@pytest.fixture(autouse=True, scope="session")
def no_logs_in_the_repository():
    """Fail the session if a test wrote a default log into the repository's ``runs/`` folder."""
    before = set(REPO_RUNS.glob("*")) if REPO_RUNS.is_dir() else set()
    yield
    after = set(REPO_RUNS.glob("*")) if REPO_RUNS.is_dir() else set()
    assert after <= before, f"tests wrote run logs into the repository: {sorted(map(str, after - before))}"
