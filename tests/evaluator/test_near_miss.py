"""Near misses (`warn:`): robustness inside the margin forms near_miss episodes, reported but
never a violation and never a change of status."""

from __future__ import annotations

import json

import pytest

from casewatch import api
from casewatch.evaluator.session import RunOptions, RunSinks, evaluate_stream
from tests.evaluator.streams import SMALL_CASE, ego


def near_frame(i: int) -> dict:
    """tfuse's ego 2 m off at 2.0-3.0 s (els 1/3: violated) and 0.4 m off at 6.0-6.9 s
    (els 1 / 1.4 = 0.714: above 0.6, inside a 0.2 margin); the speed is 10 m/s throughout."""
    t = round(i * 0.1, 6)
    x = 10.0 * t
    offset = 2.0 if 2.0 <= t <= 3.0 else 0.4 if 6.0 <= t <= 6.9 else 0.0
    return {
        "t": t,
        "signals": {"speed": 10.0},
        "channels": {
            "lav": {"ego": ego(x, 0.0), "plan": [], "objects": []},
            "tfuse": {"ego": ego(x, offset), "plan": [], "objects": []},
        },
    }


def test_near_misses_are_reported_not_violations(tmp_path):
    text = SMALL_CASE.replace('threshold: ">= 0.6"}', 'threshold: ">= 0.6", warn: 0.2}').replace(
        'hazard: {when: "speed > 20"}', 'hazard: {when: "speed > 20", warn: 15}'
    )
    case_path = tmp_path / "case.yaml"
    case_path.write_text(text)
    stream = tmp_path / "s.jsonl"
    stream.write_text("".join(json.dumps(near_frame(i)) + "\n" for i in range(100)))
    case, spec = api.prepare(case_path)
    result = evaluate_stream(
        case, spec, stream, RunOptions(), RunSinks(events_path=tmp_path / "events.jsonl")
    )
    # the violation is an episode, as without a margin
    assert [(e.node_id, e.start, e.end) for e in result.episodes] == [("Sn1", 2.0, 3.0)]
    near = {(n.node_id, n.start, n.end): n for n in result.near_misses}
    # Sn1: els 0.714 at 6.0-6.9 s, 0.114 above its threshold (inside the 0.2 margin); the
    # violation 2.0-3.0 s is no near miss. CSn1: `not (speed > 20)` holds by 20 - 10 = 10 on
    # every tick, inside its margin 15: one near miss over the whole run
    assert set(near) == {("Sn1", 6.0, 6.9), ("CSn1", 0.0, 9.9)}
    assert near[("Sn1", 6.0, 6.9)].least_robustness == pytest.approx(1 / 1.4 - 0.6)
    assert near[("CSn1", 0.0, 9.9)].least_robustness == 10.0
    # never a status change: Sn1 reads satisfied through 6.0-6.9 s, CSn1 never raises a hazard
    sn1 = next(s for s in result.status if s.node_id == "Sn1")
    assert all(iv.status == "satisfied" for iv in sn1.timeline if iv.start >= 6.0 and iv.end <= 6.9)
    assert not any(e.kind == "hazard" for e in result.episodes)
    kinds = [
        json.loads(line)["event"] for line in (tmp_path / "events.jsonl").read_text().splitlines()
    ]
    assert kinds.count("near_miss") == 2 and kinds.count("spi_episode") == 1


def test_reports_list_near_misses(tmp_path):
    from casewatch.reports.html import render_html
    from casewatch.reports.markdown import render_markdown

    text = SMALL_CASE.replace('threshold: ">= 0.6"}', 'threshold: ">= 0.6", warn: 0.2}')
    (tmp_path / "case.yaml").write_text(text)
    stream = tmp_path / "s.jsonl"
    stream.write_text("".join(json.dumps(near_frame(i)) + "\n" for i in range(100)))
    case, spec = api.prepare(tmp_path / "case.yaml")
    result = evaluate_stream(case, spec, stream)
    md = render_markdown(result)
    assert "## Near misses (1)" in md and "| Sn1 | 6.0 s | 6.9 s | 10 | 0.1143 | 0.2 |" in md
    html = render_html(result)
    assert 'id="near-misses"' in html and "0.1143" in html
