"""Fault labels: the file format, its errors, and the detection rule (evaluator.faults)."""

from __future__ import annotations

from pathlib import Path

import pytest

from casewatch.evaluator.faults import (
    DETECTION_SLACK,
    FAMILY_SIGNALS,
    FaultLabel,
    FaultLabelsError,
    detected,
    fault_labels_path,
    read_fault_labels,
)


def test_reads_a_fault_labels_file(tmp_path: Path) -> None:
    path = tmp_path / "drive.fault-labels.jsonl"
    path.write_text(
        '{"fault": "object_drop", "start": 41.2, "end": 44.7, "channel": "tfuse", "vehicle": 3}\n'
        "\n"
        '{"fault": "phantom", "start": 60, "end": 61.9, "channel": "lav"}\n'
    )
    faults = read_fault_labels(path)
    assert faults == [
        FaultLabel("object_drop", 41.2, 44.7, "tfuse", 1),
        FaultLabel("phantom", 60.0, 61.9, "lav", 3),
    ]
    assert faults[0].signals == FAMILY_SIGNALS["object_drop"] == ("lone_age",)


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ('{"fault": "gremlin", "start": 1, "end": 2, "channel": "a"}', "'fault' must be one of"),
        (
            '{"fault": "phantom", "start": "1", "end": 2, "channel": "a"}',
            "'start' must be a number",
        ),
        ('{"fault": "phantom", "start": 3, "end": 2, "channel": "a"}', "'end' (2.0) is before"),
        ('{"fault": "phantom", "start": 1, "end": 2}', "'channel' must name"),
        ("[1, 2]", "expected an object"),
        ("{oops", "not valid JSON (Expecting property name"),
    ],
)
def test_bad_lines_name_file_line_and_key(tmp_path: Path, line: str, message: str) -> None:
    path = tmp_path / "x.fault-labels.jsonl"
    path.write_text('{"fault": "phantom", "start": 1, "end": 2, "channel": "a"}\n' + line + "\n")
    with pytest.raises(FaultLabelsError) as err:
        read_fault_labels(path)
    assert f"{path}:2: " in str(err.value)
    assert message in str(err.value)


def test_sibling_path() -> None:
    assert fault_labels_path(Path("d/run.jsonl.gz")) == Path("d/run.fault-labels.jsonl")
    assert fault_labels_path(Path("d/run.labels.jsonl")) == Path("d/run.fault-labels.jsonl")


def test_detection_needs_overlap_and_no_alarm_without_the_fault() -> None:
    fault = FaultLabel("phantom", 10.0, 12.0, "a", 1)
    assert DETECTION_SLACK == 2.0
    # an episode starting 1.5 s after the fault ended (persistence delays it): detected
    assert detected([(13.5, 14.0)], [], fault)
    # 2.1 s after: too late to be this fault's
    assert not detected([(14.1, 15.0)], [], fault)
    # an episode before the fault that ends inside it: detected
    assert detected([(8.0, 10.0)], None, fault)
    # the drive without the fault had an alarm there anyway: not a detection
    assert not detected([(10.5, 11.0)], [(11.5, 12.5)], fault)
    # ... one elsewhere does not matter
    assert detected([(10.5, 11.0)], [(30.0, 31.0)], fault)


def test_a_bound_that_is_no_finite_number_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "x.fault-labels.jsonl"
    path.write_text('{"fault": "phantom", "start": NaN, "end": 2, "channel": "a"}\n')
    with pytest.raises(FaultLabelsError, match=r":1: 'start' must be a finite number"):
        read_fault_labels(path)
