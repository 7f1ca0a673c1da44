"""Ground-truth scoring: overlap matching, each label at most once."""

import json

import pytest

from casewatch.evaluator.ground_truth import Label, LabelsError, read_labels, score_events
from casewatch.evaluator.result import Episode

HAZARDS = {"CSn1": "Inconsistent ego localization", "CSn2": "Ego tailgating identified"}


def event(node: str, start: float, end: float) -> Episode:
    return Episode(
        formula_id=node,
        node_id=node,
        kind="hazard",
        start=start,
        end=end,
        ticks=1,
        worst_robustness=-0.1,
        t_worst=start,
        trace=[],
    )


def test_one_true_positive_one_false_positive_one_false_negative():
    events = [event("CSn2", 10.0, 12.0), event("CSn2", 30.0, 31.0)]
    labels = [Label("CSn2", 11.0, 13.0, 1), Label("Ego tailgating identified", 50.0, 52.0, 2)]
    gt = score_events(events, labels, HAZARDS, "labels.jsonl", "d")
    csn2 = next(s for s in gt.per_hazard if s.hazard == "CSn2")
    # TP = 1 (10-12 overlaps 11-13), FP = 1 (30-31), FN = 1 (50-52)
    assert (csn2.true_positives, csn2.false_positives, csn2.false_negatives) == (1, 1, 1)
    assert csn2.precision == pytest.approx(0.5) and csn2.recall == pytest.approx(0.5)
    csn1 = next(s for s in gt.per_hazard if s.hazard == "CSn1")
    assert csn1.precision is None and csn1.recall is None  # nothing detected, nothing labelled
    assert gt.overall.true_positives == 1 and gt.overall.precision == pytest.approx(0.5)


def test_events_are_marked_and_labels_kept_for_the_report():
    events = [event("CSn2", 10.0, 12.0), event("CSn2", 30.0, 31.0)]
    labels = [
        Label("CSn2", 11.0, 13.0, 1),
        Label("Ego tailgating identified", 50.0, 52.0, 2),
        Label("cut-in", 60.0, 61.0, 3),
    ]
    gt = score_events(events, labels, HAZARDS, "labels.jsonl", "d")
    assert [(m.start, m.match) for m in gt.marks] == [(10.0, "TP"), (30.0, "FP")]
    # labels resolved to hazard nodes (by id or text); the unknown one is reported apart
    assert [(lab.node_id, lab.start) for lab in gt.labels] == [("CSn2", 11.0), ("CSn2", 50.0)]
    assert gt.unmatched_label_names == ["cut-in"]


def test_each_label_is_matched_at_most_once():
    # two events overlap the same single label: one TP, one FP
    events = [event("CSn1", 0.0, 1.0), event("CSn1", 1.5, 2.0)]
    labels = [Label("CSn1", 0.5, 1.8, 1)]
    gt = score_events(events, labels, HAZARDS, "l", "d")
    s = gt.per_hazard[0]
    assert (s.true_positives, s.false_positives, s.false_negatives) == (1, 1, 0)


def test_matching_is_maximal_not_greedy():
    # greedy in time order would pair e1-l1 and leave l2 unmatched; the maximum matching
    # pairs e1-l2? no: e1 overlaps l1 and l2, e2 overlaps only l1 -> e1-l2, e2-l1: 2 TP.
    events = [event("CSn1", 0.0, 5.0), event("CSn1", 0.5, 1.0)]
    labels = [Label("CSn1", 0.0, 1.0, 1), Label("CSn1", 4.0, 6.0, 2)]
    s = score_events(events, labels, HAZARDS, "l", "d").per_hazard[0]
    assert (s.true_positives, s.false_positives, s.false_negatives) == (2, 0, 0)


def test_unknown_hazard_names_are_reported():
    gt = score_events([], [Label("flying cows", 0, 1, 1)], HAZARDS, "l", "d")
    assert gt.unmatched_label_names == ["flying cows"]


def test_read_labels_errors_name_file_and_line(tmp_path):
    path = tmp_path / "labels.jsonl"
    path.write_text(
        json.dumps({"hazard": "CSn1", "start": 1, "end": 2})
        + "\n"
        + json.dumps({"hazard": "CSn1", "start": "soon", "end": 2})
        + "\n"
    )
    with pytest.raises(LabelsError, match=r"labels.jsonl:2: 'start' must be a number"):
        read_labels(path)
    path.write_text('{"hazard": "CSn1", "start": 3, "end": 2}\n')
    with pytest.raises(LabelsError, match=r":1: 'end' \(2.0\) is before 'start'"):
        read_labels(path)
    path.write_text("{nope\n")
    with pytest.raises(LabelsError, match=r":1: not valid JSON"):
        read_labels(path)
    path.write_text("[" * 100_000 + "\n")
    with pytest.raises(LabelsError, match=r":1: JSON nested too deeply"):
        read_labels(path)


def test_read_labels_round_trip(tmp_path):
    path = tmp_path / "labels.jsonl"
    path.write_text('{"hazard": "CSn1", "start": 1, "end": 2.5, "source": "geometry"}\n\n')
    labels, digest = read_labels(path)
    assert labels == [Label("CSn1", 1.0, 2.5, 1)] and len(digest) == 64


def test_hazard_label_bounds_must_be_finite(tmp_path):
    from casewatch.evaluator.ground_truth import LabelsError, read_labels

    path = tmp_path / "d.labels.jsonl"
    path.write_text('{"hazard": "CSn1", "start": 1, "end": Infinity}\n')
    with pytest.raises(LabelsError, match=r":1: 'end' must be a finite number of seconds"):
        read_labels(path)
