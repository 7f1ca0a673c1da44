"""The contract library: each contract expanded and judged on hand-computed values, and every
way a `contract:` or an `odd:` can be wrong reported with its code and position."""

from __future__ import annotations

import math

import pytest

from casewatch.monitor.situation import GAP_CAP
from casewatch.safety_case.contracts import library
from casewatch.safety_case.loader import load_text
from casewatch.spec.compiler import compile_case
from casewatch.spec.emit import build_rtamt_monitor
from casewatch.spec.model import CompiledFormula

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
    return [
        float(monitor.update(i, [(n, row[n]) for n in formula.signals]))
        for i, row in enumerate(rows)
    ]


def test_lane_keeping_follows_eq_3_25():
    # the study: d < w/2. Offset 0.5 m in a 3.5 m lane: bound 1.75, margin 1.25; an offset of
    # -1.9 m leaves the lane by 0.15 m. No assumption: the study states none.
    f = compiled("{use: lane_keeping}")
    assert f.source == "abs(lane_offset) < lane_width / 2" and f.assumption is None
    rows = [{"lane_offset": 0.5, "lane_width": 3.5}, {"lane_offset": -1.9, "lane_width": 3.5}]
    assert robustness(f, rows) == [pytest.approx(1.25), pytest.approx(-0.15)]
    # a straight drive 0.2 m off centre in a 3.5 m lane is inside it (1.75 - 0.2 = 1.55)
    assert robustness(f, [{"lane_offset": 0.2, "lane_width": 3.5}]) == [pytest.approx(1.55)]


def test_lane_keeping_body_is_the_stricter_variant():
    f = compiled("{use: lane_keeping_body}")
    assert f.source == "abs(lane_offset) < (lane_width - 1.9) / 2"
    assert f.assumption is not None and f.assumption.source == "lane_width > 1.9"
    # offset 0.5 m in a 3.5 m lane with a 1.9 m ego: bound (3.5 - 1.9) / 2 = 0.8, margin 0.3
    assert robustness(f, [{"lane_offset": 0.5, "lane_width": 3.5}]) == [pytest.approx(0.3)]
    assert robustness(f, [{"lane_offset": -1.0, "lane_width": 3.5}]) == [pytest.approx(-0.2)]
    # a lane narrower than the car: outside the assumption
    assert robustness(f.assumption, [{"lane_width": 1.5}]) == [pytest.approx(-0.4)]


def test_static_safety_follows_eq_3_17():
    # ||p - o|| > 0: a gap of 1.5 m holds by 1.5 m; with a 2 m margin it fails by 0.5 m
    f = compiled("{use: static_safety}")
    assert f.source == "lead_gap > 0.0"
    assert robustness(f, [{"lead_gap": 1.5}]) == [pytest.approx(1.5)]
    g = compiled("{use: static_safety, params: {margin: 2}}")
    assert robustness(g, [{"lead_gap": 1.5}]) == [pytest.approx(-0.5)]
    # no leader (the cap) is outside the assumption, not a pass by 198 m
    assert robustness(f.assumption, [{"lead_gap": GAP_CAP}]) == [-1.0]
    assert robustness(f.assumption, [{"lead_gap": 50.0}]) == [pytest.approx(149.0)]


def test_passive_safety_follows_eq_3_18():
    # (||p - o|| > 0) while ||v|| > 0: a moving ego 20 m behind holds by 20 m; at 0 m (contact)
    # it holds by 0, at -0.3 m (overlap) fails; standing (0 m/s) is outside the assumption
    f = compiled("{use: passive_safety}")
    assert (f.assumption.source, f.source) == ("lead_gap < 199 and ego_speed > 0.1", "lead_gap > 0")
    assert robustness(f, [{"lead_gap": 20.0}, {"lead_gap": -0.3}]) == [
        pytest.approx(20.0),
        pytest.approx(-0.3),
    ]
    rows = [{"lead_gap": 20.0, "ego_speed": 10.0}, {"lead_gap": 20.0, "ego_speed": 0.0}]
    # min(199 - 20, 10 - 0.1) = 9.9; standing: min(179, -0.1) = -0.1
    assert robustness(f.assumption, rows) == [pytest.approx(9.9), pytest.approx(-0.1)]


def test_passive_friendly_safety_follows_eq_3_19():
    # ||p - o|| > v^2 / 2b + v tau: v 10 m/s, b 6 m/s^2, tau 0.5 s: 100 / 12 + 5 = 13.333 m;
    # a gap of 20 m holds by 6.667 m, one of 12 m fails by 1.333 m
    f = compiled("{use: passive_friendly_safety}")
    rows = [{"lead_gap": 20.0, "ego_speed": 10.0}, {"lead_gap": 12.0, "ego_speed": 10.0}]
    assert robustness(f, rows) == [
        pytest.approx(20.0 - 100.0 / 12.0 - 5.0),
        pytest.approx(12.0 - 100.0 / 12.0 - 5.0),
    ]
    assert f.assumption.source == "lead_gap < 199 and ego_speed > 0.1"
    # no follower clause: the study has none (a follower 1 m behind changes nothing)
    assert "follow" not in f.source


def test_passive_friendly_follower_is_casewatchs_variant():
    # ego 10 m/s stops in 18.333 m beyond a 10 m follow gap, the follower (12 m/s, 1 s,
    # 6 m/s^2) needs 12 + 144 / 12 = 24 m: violated by 5.667 m; the lead side holds by 6.667
    f = compiled("{use: passive_friendly_follower}")
    row = {"lead_gap": 20.0, "ego_speed": 10.0, "follow_gap": 10.0, "follow_speed": 12.0}
    assert robustness(f, [row]) == [pytest.approx(10.0 + 100.0 / 12.0 - 24.0)]


def test_rss_longitudinal_follows_eqs_3_20_to_3_23():
    # d_min with v_r 20, v_f 15, rho 0.5, a_max,accel 2, a_min,brake 4, a_max,brake 8:
    # 20 * 0.5 + 0.5 * 2 * 0.25 + 21^2 / 8 - 15^2 / 16 = 10 + 0.25 + 55.125 - 14.0625 = 51.3125
    f = compiled("{use: rss_longitudinal}")
    assert f.contract_use == "rss_longitudinal"
    rows = [
        # gap 50 < d_min, the ego brakes at 5 m/s^2, inside [4, 8]: holds by min(8 - 5, 5 - 4)
        {"lead_gap": 50.0, "ego_speed": 20.0, "lead_speed": 15.0, "ego_accel": -5.0},
        # gap 50 < d_min, the ego brakes at only 2 m/s^2: max(50 - 51.3125, -4 + 2) = -1.3125
        {"lead_gap": 50.0, "ego_speed": 20.0, "lead_speed": 15.0, "ego_accel": -2.0},
        # gap 52 >= d_min: free to accelerate, holds by 52 - 51.3125 = 0.6875
        {"lead_gap": 52.0, "ego_speed": 20.0, "lead_speed": 15.0, "ego_accel": 1.0},
        # gap 40, braking at 9 m/s^2, harder than a_max,brake: max(-11.3125, 8 - 9) = -1
        {"lead_gap": 40.0, "ego_speed": 20.0, "lead_speed": 15.0, "ego_accel": -9.0},
    ]
    assert robustness(f, rows) == [
        pytest.approx(1.0),
        pytest.approx(-1.3125),
        pytest.approx(0.6875),
        pytest.approx(-1.0),
    ]


def test_rss_longitudinal_assumes_the_leaders_acceleration_bounded():
    # the leader's acceleration is its speed now minus one second ago (11 ticks at 0.1 s)
    f = compiled("{use: rss_longitudinal}")
    assert f.assumption.warmup_ticks == 10

    def rows(v0: float, v1: float) -> list[dict[str, float]]:
        return [
            {"lead_gap": 50.0, "ego_speed": 20.0, "lead_speed": v0 + (v1 - v0) * k / 10}
            for k in range(11)
        ]

    # 15 -> 10 m/s in 1 s: -5 m/s^2 in [-8, 2]: min(149, 20, 10, -5 + 8, 2 + 5) = 3
    assert robustness(f.assumption, rows(15.0, 10.0))[-1] == pytest.approx(3.0)
    # 15 -> 5 m/s in 1 s: -10 m/s^2, harder than a_max,brake: outside by 2
    assert robustness(f.assumption, rows(15.0, 5.0))[-1] == pytest.approx(-2.0)


def test_rss_safe_distance_is_casewatchs_distance_only_variant():
    f = compiled("{use: rss_safe_distance}")
    rows = [{"lead_gap": gap, "ego_speed": 20.0, "lead_speed": 15.0} for gap in (52.0, 50.0)]
    assert robustness(f, rows) == [pytest.approx(0.6875), pytest.approx(-1.3125)]
    g = compiled("{use: rss_safe_distance, params: {response_time: 0.0, min_brake: 5}}")
    # rho 0: d_min = v_r^2 / (2 * 5) - v_f^2 / 16 = 40 - 14.0625 = 25.9375
    rows = [{"lead_gap": 30.0, "ego_speed": 20.0, "lead_speed": 15.0}]
    assert robustness(g, rows) == [pytest.approx(30.0 - 25.9375)]


def test_detection_accuracy_follows_eq_3_26():
    # the cumulative error over the last five frames below epsilon = 3 m
    f = compiled("{use: detection_accuracy, params: {channel: camera}}")
    assert f.source == "sum[0:0.4](abs(lead_gap__camera - gt_lead_gap)) < 3.0"
    assert f.assumption is not None and f.assumption.source == "gt_lead_gap < 199.0"
    assert f.warmup_ticks == 4  # the first four ticks after a restart have no full window
    errors = [0.5, 0.5, 0.5, 0.5, 0.5, 1.0, 1.5]
    rows = [{"lead_gap__camera": 30.0 + e, "gt_lead_gap": 30.0} for e in errors]
    rho = robustness(f, rows)
    # fifth tick: 5 * 0.5 = 2.5 < 3 by 0.5; sixth: 4 * 0.5 + 1 = 3.0, holds by 0;
    # seventh: 3 * 0.5 + 1 + 1.5 = 4.0, violated by 1
    assert rho[4:] == [pytest.approx(0.5), pytest.approx(0.0), pytest.approx(-1.0)]
    assert all(math.isinf(r) for r in rho[:4])  # incomplete windows (evaluator: no data)


def test_detection_accuracy_against_another_channel_over_three_frames():
    f = compiled(
        "{use: detection_accuracy, params: {channel: camera, reference: "
        "lead_gap__lidar, frames: 3, bound: 2, range: 60}}"
    )
    assert f.source == "sum[0:0.2](abs(lead_gap__camera - lead_gap__lidar)) < 2.0"
    assert f.assumption.source == "lead_gap__lidar < 60.0"


def test_every_entry_names_its_source_and_every_variant_its_deviation():
    sources = {name: t.source for name, t in library().items()}
    assert sources == {
        "lane_keeping": "eq. 3.25",
        "lane_keeping_body": "casewatch",
        "detection_accuracy": "eq. 3.26 (3.16)",
        "static_safety": "eq. 3.17",
        "passive_safety": "eq. 3.18",
        "passive_friendly_safety": "eq. 3.19",
        "passive_friendly_follower": "casewatch",
        "rss_longitudinal": "eqs. 3.20-3.23",
        "rss_safe_distance": "casewatch",
    }
    for name, template in library().items():
        assert bool(template.deviation) == (template.source == "casewatch"), name


def test_a_hand_written_contract_and_an_override():
    f = compiled('{assume: "lane_width > 3", guarantee: "abs(lane_offset) < 0.5"}')
    assert (f.assumption.source, f.source, f.contract_use) == (
        "lane_width > 3",
        "abs(lane_offset) < 0.5",
        None,
    )
    g = compiled('{use: lane_keeping_body, assume: "lane_width > 3.2"}')
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
        (
            "{use: rss_longitudinal, params: {response_tim: 1}}",
            "CW008",
            46,
            "no parameter 'response_tim'",
        ),
        (
            "{use: rss_longitudinal, params: {response_time: 9}}",
            "CW008",
            61,
            "must lie in [0, 5] s",
        ),
        ("{use: detection_accuracy}", "CW008", 19, "needs `params.channel`"),
        (
            "{use: detection_accuracy, params: {channel: radar}}",
            "CW008",
            57,
            "one of the case's channels (lidar, camera)",
        ),
        (
            "{use: detection_accuracy, params: {channel: camera, frames: 2.5}}",
            "CW008",
            73,
            "whole number",
        ),
        ("{params: {margin: 1}}", "CW018", None, "add `use`"),
        ('{assume: "ego_speed > 1"}', "CW018", None, "needs `guarantee`"),
        ("{use: static_safety, severity: high}", "CW013", None, "unknown key 'severity'"),
    ],
)
def test_contract_errors(contract: str, code: str, col: int | None, words: str):
    result = load_text(HEAD + f"  contract: {contract}\n", "case.yaml")
    assert result.case is None
    found = [f for f in result.findings if f.code == code]
    assert found, [f.format() for f in result.findings]
    assert found[0].line == 11 and words in found[0].message, found[0].format()
    if col is not None:
        assert found[0].col == col, found[0].format()


def test_a_contract_needing_an_undeclared_signal_says_what_to_declare():
    text = HEAD.replace(
        "  signals: {gt_lead_gap: true gap, lane_offset: offset, lane_width: width}\n", ""
    )
    result = load_text(text + "  contract: {use: lane_keeping}\n", "case.yaml")
    (f,) = [f for f in result.findings if f.code == "CW008"]
    assert "lane_offset, lane_width" in f.message and "monitor.signals" in f.message
    assert "lane_offset: lateral offset" in f.hint


def test_spi_and_contract_on_one_node_and_misplaced_keys():
    both = load_text(
        HEAD + "  spi: {signal: els, threshold: '>= 0.6'}\n  contract: {use: static_safety}\n",
        "case.yaml",
    )
    assert [f.code for f in both.findings] == ["CW018"] and both.findings[0].line == 12
    goal = load_text(
        HEAD.replace(
            "  supportedBy: [Sn1]\n", "  supportedBy: [Sn1]\n  contract: {use: static_safety}\n"
        ),
        "case.yaml",
    )
    assert "CW021" in [f.code for f in goal.findings]
    odd_goal = load_text(
        HEAD.replace(
            "  supportedBy: [Sn1]\n",
            "  supportedBy: [Sn1]\n  odd: {attributes: {road.type: [highway]}}\n",
        ),
        "case.yaml",
    )
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
        (
            "{attributes: {road.type: [urban]}, combinations: [{road.lanes: 2}]}",
            "a combination names layered conditions the ODD lists",
        ),
        ("{attributes: {}}", "at least one attribute"),
        ("{atributes: {road.type: [urban]}}", "atributes"),
        ("no-such-odd.yaml", "cannot read the ODD specification"),
    ],
)
def test_odd_errors(odd: str, words: str):
    text = ODD_HEAD + "  spi: {signal: els, threshold: '>= 0.6'}\nC1:\n  text: the ODD\n"
    result = load_text(text + f"  odd: {odd}\n", "case.yaml")
    found = [f for f in result.findings if f.code == "CW009"]
    assert found and words in found[0].message, [f.format() for f in result.findings]
    assert (found[0].line, found[0].col) == (15, 8)


def test_an_odd_file_is_read_relative_to_the_case(tmp_path):
    (tmp_path / "domain.yaml").write_text(
        "odd:\n  name: highway\n  attributes:\n    road.type: [highway]\n    ego_speed: {max: 30}\n"
    )
    case = tmp_path / "case.yaml"
    case.write_text(
        ODD_HEAD + "  spi: {signal: els, threshold: '>= 0.6'}\nC1:\n"
        "  text: the ODD\n  odd: domain.yaml\n"
    )
    result = load_text(case.read_text(), str(case))
    assert result.case is not None, [f.format() for f in result.findings]
    odd = result.case.nodes["C1"].odd
    assert odd.name == "highway" and odd.attributes["road.type"] == ["highway"]
    assert odd.attributes["ego_speed"].max == 30.0 and odd.source.endswith("domain.yaml")
