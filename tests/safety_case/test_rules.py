"""The traffic-rule library: each rule instantiated on a hazard node and judged on hand-made
tick sequences (one event per contact, the crossing tick of a red light, a stop before a stop
line), and its errors."""

from __future__ import annotations

import pytest

from casewatch.evaluator.core import Evaluator
from casewatch.safety_case.contracts import RULES, library
from casewatch.safety_case.loader import load_text
from casewatch.spec.compiler import compile_case

HEAD = """\
module: {name: rules}
monitor: {channels: [lav, tfuse], merge_gap: 1s}
G1:
  text: the ego obeys the traffic rules
  supportedBy: [Sn1]
Sn1: {text: the monitors ran}
CSn1:
  text: the rule
  challenges: G1
"""


def events(hazard: str, ticks: list[dict[str, float | None]]) -> list[tuple[float, float]]:
    """(start, end) of each hazard event over `ticks` (0.1 s apart)."""
    result = load_text(HEAD + f"  hazard: {hazard}\n", "rules.yaml")
    assert result.case is not None, [f.format() for f in result.findings]
    spec, findings = compile_case(result.case)
    assert spec is not None, [f.format() for f in findings]
    ev = Evaluator(result.case, spec)
    for i, values in enumerate(ticks):
        ev.step(round(0.1 * i, 6), values)
    ev.finish()
    return [(e.start, e.end) for e in ev.episodes]


def test_red_light_is_the_crossing_tick_under_red():
    # the stop line is crossed between ticks 2 and 3 (red) and between 7 and 8 (green)
    dist = [3.0, 2.0, 0.5, -0.5, -1.5, 3.0, 1.0, 0.2, -0.8, -2.0]
    state = [3, 3, 3, 3, 3, 1, 1, 1, 1, 1]
    ticks = [{"tl_state": s, "tl_distance": d} for s, d in zip(state, dist, strict=True)]
    assert events("{use: red_light}", ticks) == [(0.3, 0.3)]


def test_a_stop_sign_passed_without_stopping_and_one_passed_after_a_stop():
    # first line: approached at 5 m/s, never below 0.1 m/s, passed at tick 4; second: stopped
    # (0.05 m/s) 2 m before the line at tick 12, passed at tick 15
    speed = [5, 5, 5, 5, 5, 5, 5, 3, 2, 1, 0.5, 0.2, 0.05, 1, 2, 3, 4]
    dist = [4, 3.5, 3, 1, -0.5, -1, 20, 12, 8, 5, 3, 2.2, 2, 1.5, 0.4, -0.3, -1]
    ticks = [{"vehicle_speed": v, "stop_distance": d} for v, d in zip(speed, dist, strict=True)]
    assert events("{use: stop_sign}", ticks) == [(0.4, 0.4)]


def test_one_collision_event_per_contact():
    # contact 1 lasts three ticks, a gap of one tick, then contact 2 (merge_gap 0 for the rule)
    at_fault = [0, 1, 1, 1, 0, 1, 0, 0]
    ticks = [{"collision_at_fault": c} for c in at_fault]
    assert events("{use: collision}", ticks) == [(0.1, 0.3), (0.5, 0.5)]
    # a victim is no at-fault collision
    ticks = [{"collision_at_fault": 0, "collision_victim": 1}] * 3
    assert events("{use: collision}", ticks) == []
    assert events("{use: collision_victim}", ticks) == [(0.0, 0.2)]


def test_speeding_bands_last_half_a_second():
    # limit 10 m/s: 10.5 (light) for 6 ticks, 12.5 (heavy) for 6 ticks, 10.5 for 2 ticks
    speed = [10.0] + [10.5] * 6 + [12.5] * 6 + [10.5] * 2 + [9.0] * 12
    ticks = [{"vehicle_speed": v, "speed_limit": 10.0} for v in speed]
    # each excursion is its own event (merge_gap 0); the second light one lasts 0.2 s: dropped
    assert events("{use: speeding_light}", ticks) == [(0.1, 0.6)]
    assert events("{use: speeding_heavy}", ticks) == [(0.7, 1.2)]
    assert events("{use: speeding_heavy, params: {heavy: 0.3}}", ticks) == []


def test_markings_indicator_and_lights():
    ticks = [
        {"marking": m, "indicator": i}
        for m, i in [(0, 0), (1, 0), (1, 0), (0, 0), (1, 1), (2, 1), (3, 0), (0, 0)]
    ]
    assert events("{use: broken_no_indicator}", ticks) == [(0.1, 0.2)]
    assert events("{use: solid_line}", ticks) == [(0.5, 0.5)]
    assert events("{use: double_solid}", ticks) == [(0.6, 0.6)]
    night = (
        [{"night": 1, "fog": 0, "low_beam": 0, "vehicle_speed": 5}] * 6
        + [{"night": 1, "fog": 0, "low_beam": 1, "vehicle_speed": 5}] * 4
        + [{"night": 0, "fog": 0, "low_beam": 0, "vehicle_speed": 5}] * 4
    )
    assert events("{use: no_headlights}", night) == [(0.0, 0.5)]


def test_low_beam_in_fog():
    # table A.3 "No beams" and sec. 6.2.2: in fog, as at night, the low beam must be on.
    # Fog by day without the low beam for 0.6 s (6 ticks), then with it: one event 0-0.5 s;
    # standing (0.3 m/s, below `moving` 0.5) without it is none
    fog = (
        [{"night": 0, "fog": 1, "low_beam": 0, "vehicle_speed": 5}] * 6
        + [{"night": 0, "fog": 1, "low_beam": 1, "vehicle_speed": 5}] * 4
        + [{"night": 0, "fog": 1, "low_beam": 0, "vehicle_speed": 0.3}] * 6
    )
    assert events("{use: no_headlights}", fog) == [(0.0, 0.5)]


def test_the_indicator_must_point_the_way_of_a_broken_line_crossing():
    # crossing_side 1 left, 2 right (world.crossing), the indicator's codes. Ticks: a broken
    # line crossed to the left with the left indicator (fine), to the right with the left one
    # (wrong: an event), to the right with none (broken_no_indicator's, not this rule's).
    # crossing_side is a built-in world signal: nothing to declare
    ticks = [
        {"marking": m, "indicator": i, "crossing_side": c}
        for m, i, c in [(0, 0, 0), (1, 1, 1), (0, 1, 0), (1, 1, 2), (1, 1, 2), (0, 0, 0), (1, 0, 2)]
    ]
    result = load_text(HEAD + "  hazard: {use: broken_wrong_indicator}\n", "rules.yaml")
    assert result.case is not None, [f.format() for f in result.findings]
    spec, _ = compile_case(result.case)
    ev = Evaluator(result.case, spec)
    for i, values in enumerate(ticks):
        ev.step(round(0.1 * i, 6), values)
    ev.finish()
    assert [(e.start, e.end) for e in ev.episodes] == [(0.3, 0.4)]
    assert events("{use: broken_no_indicator}", ticks) == [(0.6, 0.6)]
    # declaring it as a stream signal, as cases did before it was built in, names the clash
    head = HEAD.replace("merge_gap: 1s}", "merge_gap: 1s, signals: {crossing_side: side}}")
    declared = load_text(head + "  hazard: {use: broken_wrong_indicator}\n", "rules.yaml")
    assert declared.case is None
    assert any("'crossing_side' has the name of a built-in" in f.message for f in declared.findings)


def test_fog_lights_in_fog():
    # fog, moving, no fog lights for 0.7 s, then with them; clear weather without: none
    ticks = (
        [{"fog": 1, "fog_lights": 0, "vehicle_speed": 5}] * 7
        + [{"fog": 1, "fog_lights": 1, "vehicle_speed": 5}] * 3
        + [{"fog": 0, "fog_lights": 0, "vehicle_speed": 5}] * 6
    )
    assert events("{use: no_fog_lights}", ticks) == [(0.0, 0.6)]


def test_the_penalties_are_table_a3():
    """Table A.3 of the CARLA safety-monitor thesis, copied by hand: (not speeding, speeding)."""
    table = {
        "speeding_light": [1, 1],
        "speeding_heavy": [3, 3],
        "red_light": [50, 100],
        "stop_sign": [40, 80],
        "solid_line": [20, 60],
        "double_solid": [40, 100],
        "broken_no_indicator": [10, 30],
        "broken_wrong_indicator": [10, 30],
        "no_headlights": [30, 30],
        "no_fog_lights": [10, 10],
        "collision_victim": [0, 0],
    }
    rules = library(RULES)
    assert {name: rules[name].data["penalty"] for name in table} == table
    assert rules["collision"].data["penalty_by_party"] == {
        "pedestrian": [600, 1200],
        "vehicle": [250, 500],
        "two_wheeler": [400, 800],
        "object": [150, 300],
    }


def test_every_rule_names_its_source():
    for rule in library(RULES).values():
        assert rule.source, rule.name


def test_unknown_rules_and_parameters():
    result = load_text(HEAD + "  hazard: {use: red_lite}\n", "rules.yaml")
    (f,) = [f for f in result.findings if f.code == "CW008"]
    assert "no rule 'red_lite' in the traffic-rules library; did you mean 'red_light'" in f.message
    assert (f.line, f.col) == (10, 17)
    result = load_text(HEAD + "  hazard: {use: stop_sign, params: {zone: 0}}\n", "rules.yaml")
    assert "must lie in [0.5, 50] m" in result.findings[0].message
    result = load_text(HEAD + '  hazard: {use: red_light, when: "x > 1"}\n', "rules.yaml")
    assert result.findings[0].code == "CW018"


def test_every_rule_has_its_penalties():
    for rule in library(RULES).values():
        data = rule.data
        assert ("penalty" in data) != ("penalty_by_party" in data), rule.name
        assert ("carla" in data) != ("carla_by_party" in data), rule.name
        pairs = data.get("penalty_by_party", {"": data.get("penalty")}).values()
        assert all(len(p) == 2 and 0 <= p[0] <= p[1] for p in pairs), rule.name


def test_the_traffic_rules_module_is_included_by_name(tmp_path):
    """`module.uses: [traffic-rules]` brings every rule under G_traffic_rules, expanded with
    the using case's monitor (the module has none of its own)."""
    from casewatch import api

    case = tmp_path / "case.yaml"
    case.write_text(
        "module: {name: drive, uses: [traffic-rules]}\n"
        "monitor: {channels: [lav, tfuse], period: 50ms}\n"
        "G1:\n  text: The ego drives safely\n  supportedBy: [G_traffic_rules]\n"
    )
    c, spec = api.prepare(case)
    rules = {f.rule for f in spec.formulas}
    # every rule of the library, broken_wrong_indicator too (crossing_side is built in)
    assert rules == set(library(RULES)) and len(rules) == 12
    assert all(f.node_id == f"CSn_{f.rule}" for f in spec.formulas)
    assert c.nodes["CSn_red_light"].challenges == ["G_traffic_rules"]
    # stop_sign's `once[0:30]` is counted at the case's 50 ms period
    assert next(f for f in spec.formulas if f.rule == "stop_sign").horizon == pytest.approx(30.0)
    # a file of that name next to the case wins over the shipped module
    (tmp_path / "traffic-rules").write_text("G_traffic_rules: {text: local, undeveloped: true}\n")
    c, spec = api.prepare(case)
    assert c.nodes["G_traffic_rules"].text == "local" and spec.formulas == []


@pytest.mark.parametrize(
    ("scoring", "code", "words"),
    [
        (
            "{gamma: 1.5}",
            "CW012",
            "`scoring.gamma` should be less than or equal to 1, got the number 1.5",
        ),
        ("{alpha: 2}", "CW012", "`scoring.alpha` should be less than or equal to 1"),
        ("{d: 2000}", "CW012", "`scoring.d` should be less than or equal to 1000"),
        ("{stops: [12, -3]}", "CW012", "`scoring.stops[1]` should be greater than or equal to 0"),
        ("{c: 100}", "CW013", "unknown key 'c'"),
    ],
)
def test_scoring_parameters_are_bounded_as_the_thesis_bounds_them(scoring, code, words):
    text = HEAD.replace(
        "monitor: {channels: [lav, tfuse], merge_gap: 1s}",
        f"monitor: {{channels: [lav, tfuse], scoring: {scoring}}}",
    )
    result = load_text(text + "  hazard: {use: red_light}\n", "rules.yaml")
    assert result.case is None
    found = [f for f in result.findings if f.code == code]
    assert found and words in found[0].message, [f.format() for f in result.findings]
    assert found[0].line == 2
