"""`RunOptions`: declared once, plain values (they pickle to workers), checked when built."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

from casewatch.evaluator.options import FAIL_ON, STL_ENGINES, OptionsError, RunOptions
from casewatch.evaluator.policy import FAIL_ON as POLICIES
from casewatch.evaluator.stl_engines import ENGINES


def test_paths_become_text_and_the_value_round_trips_through_pickle():
    options = RunOptions(labels=Path("a/b.labels.jsonl"), topics=Path("t.yaml"), strict=True)
    assert (options.labels, options.topics) == ("a/b.labels.jsonl", "t.yaml")
    assert options.labels_path == Path("a/b.labels.jsonl")
    assert pickle.loads(pickle.dumps(options)) == options


def test_recorded_holds_every_field_and_differs_when_one_does():
    options = RunOptions(labels="x.jsonl", max_no_data=0.1, fail_on="hazard", stl_engine="numpy")
    assert options.recorded() == {
        "labels": "x.jsonl",
        "strict": False,
        "max_no_data": 0.1,
        "fail_on": "hazard",
        "topics": None,
        "stl_engine": "numpy",
        "series_points": 1000,
    }
    assert RunOptions().recorded() != RunOptions(max_no_data=0.01).recorded()


def test_auto_labels_are_resolved_per_stream_before_judging():
    fleet = RunOptions(labels="auto")
    with pytest.raises(OptionsError, match="resolve it per stream"):
        _ = fleet.labels_path
    assert fleet.with_labels(None).labels_path is None
    assert fleet.with_labels(Path("/d/a.labels.jsonl")).labels == "/d/a.labels.jsonl"


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("stl_engine", "fast", "unknown STL engine 'fast'"),
        ("fail_on", "sometimes", "unknown --fail-on 'sometimes'"),
        ("max_no_data", 1.5, "expected a share from 0 to 1"),
        ("max_no_data", float("nan"), "expected a share from 0 to 1"),
    ],
)
def test_values_no_run_can_use_are_refused_when_built(field, value, message):
    with pytest.raises(OptionsError, match=message):
        RunOptions(**{field: value})


def test_the_choices_are_the_engines_and_policies_themselves():
    assert ("auto", *ENGINES) == STL_ENGINES  # auto picks one of them per source
    assert FAIL_ON == POLICIES
