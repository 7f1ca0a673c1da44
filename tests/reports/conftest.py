"""Fixtures: hand-made results shaped like a run of the reference safety case."""

from __future__ import annotations

from pathlib import Path

import pytest

from casewatch.evaluator.result import RunResult
from tools.sample import sample_result

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def reference_result() -> RunResult:
    """Three minutes of the reference case with violations, hazard events, gaps and labels."""
    return sample_result()


@pytest.fixture(scope="session")
def hostile_result() -> RunResult:
    """The same run with markup, quotes, ampersands and control characters in every text."""
    return sample_result(hostile=True)


@pytest.fixture(scope="session")
def real_run_result() -> RunResult:
    """The reference case judged on a bundled SUMO drive, with its labels (about 4 s)."""
    from casewatch import api
    from casewatch.evaluator.session import RunOptions, evaluate_stream

    data = REPO / "examples" / "data"
    case, spec = api.prepare(REPO / "examples" / "reference-case.yaml")
    options = RunOptions(labels=data / "highway-tailgated.labels.jsonl")
    return evaluate_stream(case, spec, data / "highway-tailgated.jsonl.gz", options)
