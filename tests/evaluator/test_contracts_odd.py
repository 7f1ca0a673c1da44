"""Contracts and ODDs in the evaluator: what an assumption that fails, a tick outside the ODD
and a condition not reported do to verdicts, statuses, tallies and results."""

from __future__ import annotations

import json

import pytest

from casewatch import api
from casewatch.evaluator.core import Evaluator
from casewatch.evaluator.odd_analysis import accepted_odd, cluster_rate, t95, wilson
from casewatch.evaluator.odd_check import OddCheck
from casewatch.evaluator.session import RunOptions, evaluate_stream
from casewatch.monitor.parse import FrameDefect, parse_frame, parse_header
from casewatch.safety_case.loader import load_text
from casewatch.safety_case.odd import flatten_conditions, odd_to_data, parse_odd
from casewatch.spec.compiler import compile_case
from tests.evaluator.streams import ego

CASE = """\
module: {name: t}
monitor:
  channels: [lav, tfuse]
  period: 0.1s
  merge_gap: 0s
  signals: {lane_offset: offset, lane_width: width, speed: speed}
G1:
  text: top
  inContextOf: [C1]
  supportedBy: [G2, G3]
C1:
  text: the domain
  odd: {attributes: {environment.weather: [clear, rain], speed: {max: 30}}}
G2:
  text: lane keeping
  supportedBy: [Sn1]
Sn1:
  text: in the lane where the lane is wide enough
  contract: {assume: "lane_width > 3", guarantee: "abs(lane_offset) < 0.5"}
G3:
  text: slow enough (in the ODD's scope too, below G1)
  supportedBy: [Sn2]
Sn2:
  text: slow enough
  spi: {stl: "speed < 25"}
"""


def evaluator_for(text: str) -> Evaluator:
    result = load_text(text, "case.yaml")
    assert result.case is not None, [f.format() for f in result.findings]
    spec, findings = compile_case(result.case)
    assert spec is not None, [f.format() for f in findings]
    return Evaluator(result.case, spec)


def rows(*specs: tuple[float, float, float]) -> list[dict[str, float]]:
    return [{"lane_offset": o, "lane_width": w, "speed": v} for o, w, v in specs]


CLEAR = {"environment.weather": "clear"}
FOG = {"environment.weather": "fog"}


def run(ev: Evaluator, values: list[dict], conditions: list[dict]) -> list[dict[str, str]]:
    out = [
        ev.step(round(0.1 * i, 6), v, c)
        for i, (v, c) in enumerate(zip(values, conditions, strict=True))
    ]
    ev.finish()
    return out


def test_a_contract_is_judged_only_where_its_assumption_holds():
    ev = evaluator_for(CASE)
    values = rows((0.2, 3.5, 10), (0.8, 3.5, 10), (0.8, 2.5, 10), (0.2, 2.5, 10), (0.9, 3.5, 10))
    statuses = run(ev, values, [CLEAR] * 5)
    assert [s["Sn1"] for s in statuses] == [
        "satisfied",
        "violated",
        "outside-assumption",
        "outside-assumption",
        "violated",
    ]
    # the goal above says what its support says: no pass where the contract was not judged
    assert [s["G2"] for s in statuses] == [
        "satisfied",
        "undermined",
        "outside-assumption",
        "outside-assumption",
        "undermined",
    ]
    (stats,) = [f for f in ev.formula_stats() if f.id == "Sn1"]
    assert (
        stats.ticks_evaluated,
        stats.ticks_violated,
        stats.ticks_outside_assumption,
        stats.ticks_no_data,
    ) == (3, 2, 2, 0)
    assert stats.assumption == "lane_width > 3"
    # two episodes (merge_gap 0): the ticks outside the assumption are not violations
    assert [(e.start, e.end) for e in ev.episodes if e.node_id == "Sn1"] == [(0.1, 0.1), (0.4, 0.4)]


def test_an_assumption_without_data_is_no_data_not_a_pass():
    ev = evaluator_for(CASE)
    values = [{"lane_offset": 0.1, "lane_width": None, "speed": 10.0}]
    (status,) = run(ev, values, [CLEAR])
    assert status["Sn1"] == "no-data"
    assert ev.data_gaps[0].missing == ["lane_width"]


def test_outside_the_odd_no_claim_is_made_but_violations_stay():
    ev = evaluator_for(CASE)
    values = rows((0.2, 3.5, 10), (0.2, 3.5, 10), (0.2, 3.5, 28), (0.2, 3.5, 31), (0.2, 3.5, 10))
    conditions = [CLEAR, FOG, CLEAR, CLEAR, {}]
    statuses = run(ev, values, conditions)
    assert [s["C1"] for s in statuses] == [
        "satisfied",
        "outside-odd",
        "satisfied",
        "outside-odd",
        "no-data",
    ]
    # fog: nothing in the scope is claimed; speed 28 violates Sn2 inside the ODD; speed 31 is
    # outside the ODD's range, and the violation stays a violation there; nothing reported:
    # no data, not a pass
    assert [s["Sn1"] for s in statuses] == [
        "satisfied",
        "outside-odd",
        "satisfied",
        "outside-odd",
        "no-data",
    ]
    assert [s["Sn2"] for s in statuses] == [
        "satisfied",
        "outside-odd",
        "violated",
        "violated",
        "no-data",
    ]
    assert [s["G1"] for s in statuses] == [
        "satisfied",
        "outside-odd",
        "undermined",
        "undermined",
        "no-data",
    ]
    (summary,) = ev.odd_summaries()
    assert (summary.inside, summary.outside, summary.unknown) == (2, 2, 1)
    assert summary.outside_by == {"environment.weather": 1, "speed": 1}
    assert summary.unknown_by == {"environment.weather": 1}


def test_the_odd_scope_is_the_subtree_of_the_goals_naming_it():
    text = """\
module: {name: t}
monitor: {channels: [a, b], signals: {x: x}}
G1:
  text: top
  supportedBy: [G2, G3]
G2:
  text: claimed in the ODD
  inContextOf: [C1]
  supportedBy: [Sn1]
C1:
  text: highway only
  odd: {attributes: {road.type: [highway]}}
Sn1: {text: e1, spi: {stl: "x > 0"}}
G3:
  text: claimed anywhere
  supportedBy: [Sn2]
Sn2: {text: e2, spi: {stl: "x > 0"}}
"""
    ev = evaluator_for(text)
    (status,) = run(ev, [{"x": 1.0}], [{"road.type": "urban"}])
    assert (status["Sn1"], status["G2"], status["Sn2"], status["G3"]) == (
        "outside-odd",
        "outside-odd",
        "satisfied",
        "satisfied",
    )
    assert status["G1"] == "outside-odd"  # its support is not all satisfied


def test_condition_tallies_and_spans():
    ev = evaluator_for(CASE)
    clear, fog = dict(CLEAR), dict(FOG)  # the session hands one mapping per change
    values = rows((0.2, 3.5, 10), (0.8, 3.5, 10), (0.2, 2.5, 10), (0.2, 3.5, 10), (0.2, 3.5, 10))
    run(ev, values, [clear, clear, fog, fog, clear])
    stats = {c.attributes["environment.weather"]: c for c in ev.condition_stats()}
    assert stats["clear"].ticks == 3 and stats["fog"].ticks == 2
    assert stats["clear"].spans == [[0.0, 0.1], [0.4, 0.4]]
    assert stats["fog"].spans == [[0.2, 0.3]]
    sn1 = stats["clear"].formulas["Sn1"]
    assert (sn1.evaluated, sn1.violated, sn1.outside_assumption, sn1.no_data) == (3, 1, 0, 0)
    sn1 = stats["fog"].formulas["Sn1"]
    assert (sn1.evaluated, sn1.violated, sn1.outside_assumption, sn1.no_data) == (1, 0, 1, 0)


def test_odd_check_values_ranges_and_combinations():
    spec = parse_odd(
        {
            "attributes": {
                "road.type": ["highway", "urban"],
                "road.lanes": {"min": 2, "max": 3},
                "temporary.roadworks": [False],
            },
            "combinations": [{"road.type": "highway", "road.lanes": 3}, {"road.type": "urban"}],
        }
    )
    check = OddCheck("C1", spec)

    def judge(**kw: object) -> str:
        cond = {k.replace("__", "."): v for k, v in kw.items()}
        return check.judge(cond, {})

    ok = {"temporary__roadworks": False}
    assert judge(road__type="highway", road__lanes=3.0, **ok) == "inside"
    assert judge(road__type="highway", road__lanes=2.0, **ok) == "outside"  # no combination
    assert judge(road__type="urban", road__lanes=2.0, **ok) == "inside"
    assert judge(road__type="urban", road__lanes=4.0, **ok) == "outside"  # beyond the range
    assert judge(road__type="rural", road__lanes=2.0, **ok) == "outside"
    assert judge(road__type="urban", road__lanes=2.0, temporary__roadworks=True) == "outside"
    assert judge(road__type="urban", road__lanes=2.0, temporary__roadworks=0.0) == "outside"
    assert judge(road__type="urban", **ok) == "unknown"


def test_conditions_in_streams_are_checked():
    assert flatten_conditions({"road": {"type": "highway", "lanes": 3}}) == {
        "road.type": "highway",
        "road.lanes": 3.0,
    }
    header = parse_header({"header": {"meta": {"odd": {"environment": {"weather": "rain"}}}}})
    assert header.conditions == {"environment.weather": "rain"}
    bad = parse_header({"header": {"period": 0.2, "meta": {"odd": {"wether": {"rain": True}}}}})
    assert bad.period == 0.2 and bad.conditions == {}  # the rest of the header stands
    assert bad.conditions_problem.startswith("header.meta.odd.wether: unknown layer")
    frame = {"t": 0.0, "channels": {}, "odd": {"environment": {"weather": "fog"}}}
    assert parse_frame(frame).odd == {"environment.weather": "fog"}
    with pytest.raises(FrameDefect, match=r"odd.environment.weather: expected a text"):
        parse_frame({**frame, "odd": {"environment": {"weather": ["fog"]}}})


def stream_line(i: int) -> dict:
    t = round(0.1 * i, 6)
    frame: dict = {
        "t": t,
        "signals": {"lane_offset": 0.6 if 10 <= i < 15 else 0.1, "lane_width": 3.5, "speed": 10.0},
        "channels": {
            c: {"ego": ego(10.0 * t, 0.0), "plan": [], "objects": []} for c in ("lav", "tfuse")
        },
    }
    if i == 20:
        frame["odd"] = {"environment": {"weather": "fog"}}
    return frame


@pytest.mark.parametrize("engine", ["rtamt", "numpy", "both"])
def test_a_run_reports_conditions_and_the_odd(tmp_path, engine):
    case = tmp_path / "case.yaml"
    case.write_text(CASE)
    stream = tmp_path / "s.jsonl"
    header = {
        "header": {
            "channels": ["lav", "tfuse"],
            "period": 0.1,
            "meta": {"odd": {"environment": {"weather": "clear"}}},
        }
    }
    stream.write_text(
        "".join(json.dumps(x) + "\n" for x in [header, *(stream_line(i) for i in range(30))])
    )
    c, spec = api.prepare(case)
    result = evaluate_stream(c, spec, stream, RunOptions(stl_engine=engine))
    by = {s.attributes["environment.weather"]: s for s in result.conditions}
    assert (by["clear"].ticks, by["fog"].ticks) == (20, 10)
    assert by["clear"].formulas["Sn1"].violated == 5 and by["fog"].formulas["Sn1"].violated == 0
    assert by["fog"].spans == [[2.0, 2.9]]
    (odd,) = result.odd
    assert (odd.inside, odd.outside, odd.unknown) == (20, 10, 0)
    (g1,) = [s for s in result.status if s.node_id == "G1"]
    assert g1.ticks == {"satisfied": 15, "undermined": 5, "outside-odd": 10}
    # the result round-trips through JSON
    assert type(result).model_validate_json(result.model_dump_json()) == result


def test_wilson_and_cluster_intervals_hand_computed():
    lo, hi = wilson(0, 10)  # z = 1.96: (0 + z^2/20 +- z sqrt(z^2/400)) / (1 + z^2/10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    # three runs, 0, 2 and 4 of 10 ticks: r = 0.2; residuals 4 + 0 + 4 = 8;
    # se = sqrt(3/2 * 8) / 30 = 0.11547; t(2) = 4.303: 0.2 +- 0.4969
    rate, low, high, how = cluster_rate([0, 2, 4], [10, 10, 10])
    assert (rate, low, how) == (pytest.approx(0.2), 0.0, "runs")
    assert high == pytest.approx(0.2 + 4.303 * (12**0.5) / 30, abs=1e-6)
    assert cluster_rate([1], [4])[3] == "ticks" and cluster_rate([0], [0])[0] is None
    assert t95(2) == 4.303 and t95(1000) == pytest.approx(1.96, abs=1e-3)


def test_the_accepted_odd_is_a_product_or_its_combinations():
    def report(cells: list[tuple[str, str, bool]]) -> dict:
        return {
            "by": ["environment.weather", "environment.light"],
            "cells": [
                {"conditions": {"environment.weather": w, "environment.light": li}, "accepted": a}
                for w, li, a in cells
            ],
        }

    product = accepted_odd(
        report([("clear", "day", True), ("rain", "day", True), ("fog", "day", False)])
    )
    assert (
        product.attributes
        == {"environment.weather": ["clear", "rain"], "environment.light": ["day"]}
        and product.combinations == []
    )
    partial = accepted_odd(
        report(
            [
                ("clear", "day", True),
                ("clear", "night", True),
                ("rain", "day", True),
                ("rain", "night", False),
            ]
        )
    )
    assert len(partial.combinations) == 3
    assert parse_odd(odd_to_data(partial)) == partial  # what casewatch odd writes reads back
    assert accepted_odd(report([("fog", "day", False)])) is None


def test_leaving_and_reentering_the_odd_are_events():
    from casewatch.commands.run import event_line
    from casewatch.evaluator.eventlog import event_record
    from casewatch.evaluator.result import OddChange

    result = load_text(CASE, "case.yaml")
    spec, _ = compile_case(result.case)
    seen: list = []
    ev = Evaluator(result.case, spec, on_event=seen.append)
    values = rows(*[(0.1, 3.5, 10)] * 5)
    clear, fog = dict(CLEAR), dict(FOG)
    run(ev, values, [clear, fog, fog, {}, clear])
    changes = [e for e in seen if isinstance(e, OddChange)]
    assert [(e.t, e.state, e.because) for e in changes] == [
        (0.1, "outside", "environment.weather"),
        (0.3, "unknown", "environment.weather"),
        (0.4, "inside", None),
    ]
    assert event_line(changes[0]) == (
        "ODD      C1  OUTSIDE the ODD from 0.1 s (environment.weather)"
    )
    assert event_record(changes[2])["event"] == "odd_change"


@pytest.mark.parametrize("engine", ["rtamt", "numpy", "both"])
def test_an_assumption_restarts_after_a_stream_gap(tmp_path, engine):
    """`once[0:1s](lane_width > 3)` must not reach across a gap in the frames: after it, the
    narrow lane is outside the assumption at once, with every engine."""
    case = tmp_path / "case.yaml"
    case.write_text(
        CASE.replace(
            'contract: {assume: "lane_width > 3"',
            'contract: {assume: "once[0:1s] (lane_width > 3)"',
        )
    )
    stream = tmp_path / "s.jsonl"
    lines = []
    for i in [*range(10), *range(20, 30)]:  # frames at 0.0-0.9 s and 2.0-2.9 s
        frame = stream_line(i)
        frame.pop("odd", None)
        frame["signals"]["lane_width"] = 3.5 if i < 10 else 2.5
        lines.append(json.dumps(frame))
    stream.write_text("\n".join(lines) + "\n")
    c, spec = api.prepare(case)
    result = evaluate_stream(c, spec, stream, RunOptions(stl_engine=engine))
    (sn1,) = [f for f in result.formulas if f.id == "Sn1"]
    assert (sn1.ticks_evaluated, sn1.ticks_outside_assumption) == (10, 10)


def test_unreadable_conditions_are_a_defect_and_report_nothing(tmp_path):
    from casewatch.monitor.reader import StreamReader

    stream = tmp_path / "s.jsonl"
    header = {
        "header": {
            "channels": ["lav", "tfuse"],
            "period": 0.1,
            "meta": {"odd": {"environment": {"weather": ["fog"]}}},
        }
    }
    stream.write_text(
        "".join(json.dumps(x) + "\n" for x in [header, *(stream_line(i) for i in range(3))])
    )
    reader = StreamReader(stream)
    assert len(list(reader)) == 3
    (defect,) = reader.defects
    assert (defect.line, defect.kind) == (1, "bad-header")
    assert "header.meta.odd.environment.weather: expected a text" in defect.message
    assert reader.header.channels == ["lav", "tfuse"] and reader.header.conditions == {}
