"""`evaluator.diff`: unpaired episodes judged against labels, and never 'fixed' without them."""

from __future__ import annotations

from casewatch.evaluator.diff import diff_runs, is_empty, regressions, totals
from casewatch.evaluator.result import LabelInterval, RunResult
from casewatch.reports.diff import render_diff_html, render_diff_md
from tools.sample import sample_result


def with_csn2(run: RunResult, spans: list[tuple[float, float]]) -> RunResult:
    """`run` with CSn2's events replaced by `spans` (the rest kept)."""
    model = next(e for e in run.episodes if e.node_id == "CSn2")
    events = [model.model_copy(update={"start": s, "end": e, "t_worst": s}) for s, e in spans]
    kept = [e for e in run.episodes if e.node_id != "CSn2"]
    return run.model_copy(update={"episodes": sorted(kept + events, key=lambda e: e.start)})


def csn2(d: dict) -> dict:
    return next(row for row in d["nodes"] if row["formula"] == "CSn2")


def spans(items: list[dict]) -> list[tuple[float, float]]:
    return [(s["start"], s["end"]) for s in items]


A = with_csn2(sample_result(), [(92.0, 96.2), (118.9, 121.7), (129.0, 130.0)])
#: 92.0-96.2 finds L0 in A; 118.9-121.7 and 129.0-130.0 find nothing (false alarms in A)
LABELS = [
    LabelInterval(node_id="CSn2", start=93.0, end=95.0),
    LabelInterval(node_id="CSn2", start=140.0, end=145.0),
]
#: B loses 92.0-96.2 (L0 no longer found) and 118.9-121.7, keeps 129.0-130.0, finds L1 at
#: 141-143 and raises a new false alarm at 160-161
B = with_csn2(A, [(129.0, 130.0), (141.0, 143.0), (160.0, 161.0)])


def test_with_labels_a_vanished_detection_is_lost_and_only_a_false_alarm_is_fixed():
    row = csn2(diff_runs(A, B, "drive", LABELS))
    assert row["labelled"] is True
    assert spans(row["lost"]) == [(92.0, 96.2)]
    assert row["lost"][0]["label"] == {"start": 93.0, "end": 95.0}
    assert spans(row["fixed"]) == [(118.9, 121.7)]
    assert spans(row["new_detection"]) == [(141.0, 143.0)]
    assert spans(row["new"]) == [(160.0, 161.0)]
    assert row["gone"] == [] and row["moved"] == []
    d = diff_runs(A, B, "drive", LABELS)
    assert regressions([d], "any") == 2  # the new false alarm and the lost detection
    assert regressions([d], "hazard") == 2 and regressions([d], "spi") == 0
    assert totals(d)["lost"] == 1 and not is_empty(d)


def test_without_labels_nothing_vanished_is_fixed():
    d = diff_runs(A, B, "drive", None)
    row = csn2(d)
    assert row["labelled"] is False
    assert spans(row["gone"]) == [(92.0, 96.2), (118.9, 121.7)]
    assert spans(row["new"]) == [(141.0, 143.0), (160.0, 161.0)]
    assert row["fixed"] == row["lost"] == row["new_detection"] == []
    assert regressions([d], "any") == 2
    # SPIs are never judged against labels: an SPI episode that vanishes is gone
    sn = next(e for e in A.episodes if e.kind == "spi")
    b = A.model_copy(update={"episodes": [e for e in A.episodes if e is not sn]})
    rows = diff_runs(A, b, "drive", LABELS)["nodes"]
    row = next(r for r in rows if r["formula"] == sn.formula_id)
    assert row["labelled"] is False and spans(row["gone"]) == [(sn.start, sn.end)]
    assert row["fixed"] == []


def test_a_label_found_by_another_episode_is_moved_not_lost():
    labels = [LabelInterval(node_id="CSn2", start=110.0, end=135.0)]
    b = with_csn2(A, [(92.0, 96.2), (125.0, 127.0)])  # 118.9-121.7 and 129-130 replaced
    row = csn2(diff_runs(A, b, "drive", labels))
    # A matched the label with 118.9-121.7 (or 129-130); B finds it with 125-127: moved
    assert row["lost"] == [] and row["new_detection"] == []
    assert sorted(s["run"] for s in row["moved"]) == ["a", "b"]
    assert (125.0, 127.0) in spans(row["moved"])
    assert len(row["fixed"]) == 1  # the other of A's two, which matched no label
    assert row["new"] == []


def test_pages_colour_regressions_red_and_gone_neutral():
    d = {**diff_runs(A, B, "drive", LABELS), "labels": "labels.jsonl"}
    report = {
        "a": "A",
        "b": "B",
        "fail_on": "any",
        "regressions": 2,
        "only_a": [],
        "only_b": [],
        "logs": [d],
    }
    html = render_diff_html(report)
    assert '<li class="bad">lost detection CSn2: 92.0-96.2 s' in html
    assert '<li class="good">fixed CSn2: 118.9-121.7 s' in html
    assert '<li class="good">new detection CSn2: 141.0-143.0 s' in html
    assert '<li class="bad">new CSn2: 160.0-161.0 s' in html
    assert "&#34;" not in html.split("</style>")[0]  # the stylesheet is not escaped
    md = render_diff_md(report)
    assert "- lost detection CSn2: 92.0-96.2 s (worst" in md and "label 93.0-95.0 s" in md
    unlabelled = {**diff_runs(A, B, "drive", None), "labels": "neither run was judged with labels"}
    html = render_diff_html({**report, "logs": [unlabelled]})
    assert '<li class="neutral">gone CSn2: 92.0-96.2 s' in html
    body = html.split("</dl>")[1]
    assert '<td class="good"' not in body and '<li class="good"' not in body  # nothing green
    assert '<th>B</th><th class="bad">new</th><th class="neutral">gone</th>' in body
