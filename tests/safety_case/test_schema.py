"""Threshold and duration parsing."""

from __future__ import annotations

import pytest
from pydantic_core import PydanticCustomError

from casewatch.safety_case.model import Threshold
from casewatch.safety_case.schema import parse_duration, parse_threshold


@pytest.mark.parametrize(
    ("raw", "op", "value"),
    [(">= 0.6", ">=", 0.6), ("<=0.05", "<=", 0.05), ("> -1e-3", ">", -0.001), ("< .5", "<", 0.5)],
)
def test_thresholds(raw: str, op: str, value: float) -> None:
    assert parse_threshold(raw) == Threshold(op=op, value=value)


@pytest.mark.parametrize(
    "raw", ["0.6", "=> 0.6", "== 1", ">= x", ">= nan", 0.6, None, ">= 1e999", ">= 1_0", ">= \u0661"]
)
def test_bad_thresholds(raw: object) -> None:
    with pytest.raises(PydanticCustomError) as info:
        parse_threshold(raw)
    assert info.value.type == "malformed_threshold"


def test_threshold_with_digit_separators_says_so() -> None:
    with pytest.raises(PydanticCustomError, match="without '_' digit separators"):
        parse_threshold(">= 1_0")


@pytest.mark.parametrize(
    ("raw", "seconds"),
    [
        ("0.5s", 0.5),
        ("300ms", 0.3),
        ("1min", 60.0),
        ("2", 2.0),
        (2, 2.0),
        (0.25, 0.25),
        ("1.5 s", 1.5),
        ("1h", 3600.0),
    ],
)
def test_durations(raw: object, seconds: float) -> None:
    assert parse_duration(raw) == pytest.approx(seconds)


@pytest.mark.parametrize(
    "raw", ["-1s", -2, "fast", True, None, "1 sec", [], "inf", float("nan"), "1e300s", "25h"]
)
def test_bad_durations(raw: object) -> None:
    with pytest.raises(PydanticCustomError) as info:
        parse_duration(raw)
    assert info.value.type == "malformed_duration"
