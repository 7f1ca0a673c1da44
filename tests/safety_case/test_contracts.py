"""The contract library: each contract expanded and judged on hand-computed values, and every
way a `contract:` or an `odd:` can be wrong reported with its code and position."""

from __future__ import annotations

import math

import pytest

from monitor.situation import GAP_CAP
from safety_case.contracts import library
from safety_case.loader import load_text
from spec.compiler import compile_case
from spec.emit import build_rtamt_monitor
from spec.model import CompiledFormula

HEAD = """\
module: {name: t}
monitor:
  channels: [lidar, camera]
  period: 0.1s
  signals: {gt_lead_gap: true gap, lane_offset: offset, lane_width: width}
G1:
  text: top
  supportedBy: [Sn1]
Sn1:
  text: the contract
"""


def compiled(contract: str) -> CompiledFormula:
    result = load_text(HEAD + f"  contract: {contract}\n", "case.yaml")
    assert result.case is not None, [f.format() for f in result.findings]
    spec, findings = compile_case(result.case)
    assert spec is not None, [f.format() for f in findings]
    return spec.formulas[0]


def robustness(formula: CompiledFormula, rows: list[dict[str, float]]) -> list[float]:
    """rtamt's robustness of `formula` at each row (one row per 0.1 s tick)."""
    monitor = build_rtamt_monitor(formula, 0.1)
    monitor.reset()
    return [float(monitor.update(i, [(n, row[n]) for n in formula.signals]))
            for i, row in enumerate(rows)]  # fmt: skip


def test_lane_keeping_hand_computed():
    f = compiled("{use: lane_keeping}")
    assert f.source == "abs(lane_offset) < (lane_width - 1.9) / 2"
    assert f.assumption is not None and f.assumption.source == "lane_width > 1.9"
    # offset 0.5 m in a 3.5 m lane with a 1.9 m ego: bound (3.5 - 1.9) / 2 = 0.8, margin 0.3
    assert robustness(f, [{"lane_offset": 0.5, "lane_width": 3.5}]) == [pytest.approx(0.3)]
    assert robustness(f, [{"lane_offset": -1.0, "lane_width": 3.5}]) == [pytest.approx(-0.2)]
    # a lane narrower than the car: outside the assumption
    assert robustness(f.assumption, [{"lane_width": 1.5}]) == [pytest.approx(-0.4)]


def test_static_safety_hand_computed():
    f = compiled("{use: static_safety}")
    assert robustness(f, [{"lead_gap": 1.5}]) == [pytest.approx(-0.5)]  # margin 2 m
    # no leader (the cap) is outside the assumption, not a pass by 198 m
    assert robustness(f.assumption, [{"lead_gap": GAP_CAP}]) == [-1.0]
    assert robustness(f.assumption, [{"lead_gap": 50.0}]) == [pytest.approx(149.0)]


def test_passive_safety_hand_computed():
    # v 10 m/s, reaction 0.5 s, braking 6 m/s^2: 10 * 0.5 + 100 / 12 = 13.333 m
    f = compiled("{use: passive_safety}")
    assert robustness(f, [{"lead_gap": 20.0, "ego_speed": 10.0}]) == [
        pytest.approx(20.0 - 5.0 - 100.0 / 12.0)]


def test_passive_friendly_safety_hand_computed():
    # ego 10 m/s stops in 18.333 m beyond a 10 m follow gap, the follower (12 m/s, 1 s,
    # 6 m/s^2) needs 12 + 144 / 12 = 24 m: violated by 5.667 m; the lead side holds by 6.667
    f = compiled("{use: passive_friendly_safety}")
    row = {"lead_gap": 20.0, "ego_speed": 10.0, "follow_gap": 10.0, "follow_speed": 12.0}
    assert robustness(f, [row]) == [pytest.approx(10.0 + 100.0 / 12.0 - 24.0)]


def test_rss_longitudinal_hand_computed():
    # v_r 20, v_f 15, rho 0.5, a 2, b_min 4, b_max 8:
    # 20 * 0.5 + 0.5 * 2 * 0.25 + 21^2 / 8 - 15^2 / 16 = 10 + 0.25 + 55.125 - 14.0625 = 51.3125
    f = compiled("{use: rss_longitudinal}")
    rows = [{"lead_gap": gap, "ego_speed": 20.0, "lead_speed": 15.0} for gap in (52.0, 50.0)]
    assert robustness(f, rows) == [pytest.approx(0.6875), pytest.approx(-1.3125)]
    assert f.contract_use == "rss_longitudinal"


def test_rss_parameters_are_substituted():
    f = compiled("{use: rss_longitudinal, params: {response_time: 0.0, min_brake: 5}}")
    # rho 0: d_min = v_r^2 / (2 * 5) - v_f^2 / 16 = 40 - 14.0625 = 25.9375
    rows = [{"lead_gap": 30.0, "ego_speed": 20.0, "lead_speed": 15.0}]
    assert robustness(f, rows) == [pytest.approx(30.0 - 25.9375)]


def test_detection_accuracy_sums_the_last_five_frames():
    f = compiled("{use: detection_accuracy, params: {channel: camera}}")
    assert f.source == "sum[0:0.4](abs(lead_gap__camera - gt_lead_gap)) < 5.0"
    assert f.assumption is not None and f.assumption.source == "gt_lead_gap < 60.0"
    assert f.warmup_ticks == 4  # the first four ticks after a restart have no full window
    errors = [1.0, 1.0, 1.0, 1.0, 0.5, 3.0]
    rows = [{"lead_gap__camera": 30.0 + e, "gt_lead_gap": 30.0} for e in errors]
    rho = robustness(f, rows)
    # at the fifth tick: 1 + 1 + 1 + 1 + 0.5 = 4.5 < 5 by 0.5; at the sixth: 1+1+1+0.5+3 = 6.5
    assert rho[4:] == [pytest.approx(0.5), pytest.approx(-1.5)]
    assert all(math.isinf(r) for r in rho[:4])  # incomplete windows (evaluator: no data)


def test_detection_accuracy_against_another_channel_over_three_frames():
    f = compiled("{use: detection_accuracy, params: {channel: camera, reference: "
                 "lead_gap__lidar, frames: 3, bound: 2}}")  # fmt: skip
    assert f.source == "sum[0:0.2](abs(lead_gap__camera - lead_gap__lidar)) < 2.0"
    assert f.assumption.source == "lead_gap__lidar < 60.0"


def test_a_hand_written_contract_and_an_override():
    f = compiled('{assume: "lane_width > 3", guarantee: "abs(lane_offset) < 0.5"}')
    assert (f.assumption.source, f.source, f.contract_use) == (
        "lane_width > 3", "abs(lane_offset) < 0.5", None)
    g = compiled('{use: lane_keeping, assume: "lane_width > 3.2"}')
    assert g.assumption.source == "lane_width > 3.2"
    assert g.source == "abs(lane_offset) < (lane_width - 1.9) / 2"


def test_the_library_no_leader_bound_sits_below_the_situation_cap():
    """`lead_gap < 199` in the library means "there is a leader": with none the gap reads
    GAP_CAP (200 m), where `< 200` would hold with robustness 0."""
    for template in library().values():
        if template.assume and "lead_gap <" in template.assume:
            assert f"lead_gap < {GAP_CAP - 1:g}" in template.assume


def test_every_library_parameter_has_bounds_or_a_kind():
    for template in library().values():
        for p in template.params.values():
            assert p.kind in ("number", "channel", "signal")
            if p.kind == "number":
                assert p.lo is not None and p.hi is not None and p.default is not None
                assert p.lo <= p.default <= p.hi, (template.name, p.name)


@pytest.mark.parametrize(
    ("contract", "code", "col", "words"),
    [
        ("{use: rss_longitudnal}", "CW008", 19, "did you mean 'rss_longitudinal'"),
        ("{use: rss_longitudinal, params: {response_tim: 1}}", "CW008", 46,
         "no parameter 'response_tim'"),
        ("{use: rss_longitudinal, params: {response_time: 9}}", "CW008", 61,
         "must lie in [0, 5] s"),
        ("{use: detection_accuracy}", "CW008", 19, "needs `params.channel`"),
        ("{use: detection_accuracy, params: {channel: radar}}", "CW008", 57,
         "one of the case's channels (lidar, camera)"),
        ("{use: detection_accuracy, params: {channel: camera, frames: 2.5}}", "CW008", 73,
         "whole number"),
        ("{params: {margin: 1}}", "CW018", None, "add `use`"),
        ("{assume: \"ego_speed > 1\"}", "CW018", None, "needs `guarantee`"),
        ("{use: static_safety, severity: high}", "CW013", None, "unknown key 'severity'"),
    ],
)  # fmt: skip
def test_contract_errors(contract: str, code: str, col: int | None, words: str):
    result = load_text(HEAD + f"  contract: {contract}\n", "case.yaml")
    assert result.case is None
    found = [f for f in result.findings if f.code == code]
    assert found, [f.format() for f in result.findings]
    assert found[0].line == 11 and words in found[0].message, found[0].format()
    if col is not None:
        assert found[0].col == col, found[0].format()


def test_a_contract_needing_an_undeclared_signal_says_what_to_declare():
    text = HEAD.replace("  signals: {gt_lead_gap: true gap, lane_offset: offset, "
                        "lane_width: width}\n", "")  # fmt: skip
    result = load_text(text + "  contract: {use: lane_keeping}\n", "case.yaml")
    (f,) = [f for f in result.findings if f.code == "CW008"]
    assert "lane_offset, lane_width" in f.message and "monitor.signals" in f.message
    assert "lane_offset: lateral offset" in f.hint


def test_spi_and_contract_on_one_node_and_misplaced_keys():
    both = load_text(HEAD + "  spi: {signal: els, threshold: '>= 0.6'}\n"
                     "  contract: {use: static_safety}\n", "case.yaml")  # fmt: skip
    assert [f.code for f in both.findings] == ["CW018"] and both.findings[0].line == 12
    goal = load_text(HEAD.replace("  supportedBy: [Sn1]\n", "  supportedBy: [Sn1]\n"
                                  "  contract: {use: static_safety}\n"), "case.yaml")  # fmt: skip
    assert "CW021" in [f.code for f in goal.findings]
    odd_goal = load_text(HEAD.replace("  supportedBy: [Sn1]\n", "  supportedBy: [Sn1]\n"
                                      "  odd: {attributes: {road.type: [highway]}}\n"),
                         "case.yaml")  # fmt: skip
    assert "CW009" in [f.code for f in odd_goal.findings]


ODD_HEAD = HEAD.replace("  supportedBy: [Sn1]\n", "  supportedBy: [Sn1]\n  inContextOf: [C1]\n")


@pytest.mark.parametrize(
    ("odd", "words"),
    [
        ("{attributes: {weather: [clear]}}", "neither a layered condition"),
        ("{attributes: {enviroment.weather: [clear]}}", "unknown layer 'enviroment'"),
        ("{attributes: {environment.weather: []}}", "no accepted value"),
        ("{attributes: {ego_speed: {}}}", "needs `min`, `max` or both"),
        ("{attributes: {ego_speed: {min: 5, max: 1}}}", "min 5 > max 1"),
        ("{attributes: {road.type: [urban]}, combinations: [{road.lanes: 2}]}",
         "a combination names layered conditions the ODD lists"),
        ("{attributes: {}}", "at least one attribute"),
        ("{atributes: {road.type: [urban]}}", "atributes"),
        ("no-such-odd.yaml", "cannot read the ODD specification"),
    ],
)  # fmt: skip
def test_odd_errors(odd: str, words: str):
    text = ODD_HEAD + "  spi: {signal: els, threshold: '>= 0.6'}\nC1:\n  text: the ODD\n"
    result = load_text(text + f"  odd: {odd}\n", "case.yaml")
    found = [f for f in result.findings if f.code == "CW009"]
    assert found and words in found[0].message, [f.format() for f in result.findings]
    assert (found[0].line, found[0].col) == (15, 8)


def test_an_odd_file_is_read_relative_to_the_case(tmp_path):
    (tmp_path / "domain.yaml").write_text(
        "odd:\n  name: highway\n  attributes:\n    road.type: [highway]\n"
        "    ego_speed: {max: 30}\n")  # fmt: skip
    case = tmp_path / "case.yaml"
    case.write_text(ODD_HEAD + "  spi: {signal: els, threshold: '>= 0.6'}\nC1:\n"
                    "  text: the ODD\n  odd: domain.yaml\n")  # fmt: skip
    result = load_text(case.read_text(), str(case))
    assert result.case is not None, [f.format() for f in result.findings]
    odd = result.case.nodes["C1"].odd
    assert odd.name == "highway" and odd.attributes["road.type"] == ["highway"]
    assert odd.attributes["ego_speed"].max == 30.0 and odd.source.endswith("domain.yaml")
