"""Every metric parameter has finite, documented bounds; values outside them are CW012."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from casewatch.safety_case.loader import load_case_text
from casewatch.safety_case.model import MetricParams
from casewatch.safety_case.schema import bounds_text

DOC = Path(__file__).resolve().parents[2] / "docs" / "safety-case-language.md"
PARAMS = list(MetricParams.model_fields)


def case_with(metrics: str, period: str = "0.1s") -> str:
    # the metrics value sits on line 5, from column 12
    return (
        "module: {name: m}\nmonitor:\n  channels: [a, b]\n"
        f"  period: {period}\n  metrics: {metrics}\nG1: {{text: t, undeveloped: true}}\n"
    )


def cw012(metrics: str, period: str = "0.1s") -> list:
    value, findings = load_case_text(case_with(metrics, period))
    assert value is None
    return [f for f in findings if f.code == "CW012"]


@pytest.mark.parametrize("name", PARAMS)
def test_every_parameter_declares_a_lower_and_an_upper_bound(name: str) -> None:
    text = bounds_text(name)
    assert "?" not in text, f"metrics.{name} needs Field(gt|ge=..., lt|le=...): {text}"


@pytest.mark.parametrize("name", PARAMS)
def test_docs_table_shows_the_declared_bounds(name: str) -> None:
    field = MetricParams.model_fields[name]
    expected = bounds_text(name) + (" (integer)" if field.annotation is int else "")
    rows = re.findall(rf"^\| `{name}` \| [^|]+ \| ([^|]+) \|", DOC.read_text(), re.M)
    assert rows == [expected]


@pytest.mark.parametrize("name", PARAMS)
@pytest.mark.parametrize("raw", [".inf", "-.inf", ".nan", "1.0e+5000", "1000000000000", "true"])
def test_absurd_values_are_cw012_at_the_value(name: str, raw: str) -> None:
    (finding,) = cw012(f"{{{name}: {raw}}}")
    assert (finding.line, finding.col) == (5, 15 + len(name))
    assert f"`metrics.{name}` must be a number" in finding.message


@pytest.mark.parametrize(
    ("metrics", "bounds"),
    [
        ("{max_gap: .inf}", "(0, 60]"),
        ("{els_window: 1000000000000}", "[2, 10000]"),
        ("{pairing_gate: 1e5000}", "(0, 100]"),
    ],
)
def test_issue_23_examples_are_refused_with_their_bounds(metrics: str, bounds: str) -> None:
    (finding,) = cw012(metrics)
    assert f"must be a number in {bounds}" in finding.message and finding.line == 5


def test_max_gap_shorter_than_the_period_is_refused() -> None:
    (finding,) = cw012("{max_gap: 0.2}", period="0.5s")
    assert "shorter than the period (0.5 s)" in finding.message and finding.line == 5
    value, findings = load_case_text(case_with("{max_gap: 0.5}", period="0.5s"))
    assert value is not None and findings == []


def test_plain_number_text_is_still_a_number() -> None:
    # YAML 1.1 reads 1e-1 (no dot) as text; it is the number every reader means
    value, findings = load_case_text(case_with("{max_gap: 2e-1}"))
    assert findings == [] and value is not None and value.monitor.metrics.max_gap == 0.2
