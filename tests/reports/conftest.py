"""Fixtures: hand-made results shaped like a run of the reference safety case."""

from __future__ import annotations

import pytest

from evaluator.result import RunResult
from reports.sample import sample_result


@pytest.fixture(scope="session")
def reference_result() -> RunResult:
    """Three minutes of the reference case with violations, hazard events, gaps and labels."""
    return sample_result()


@pytest.fixture(scope="session")
def hostile_result() -> RunResult:
    """The same run with markup, quotes, ampersands and control characters in every text."""
    return sample_result(hostile=True)
