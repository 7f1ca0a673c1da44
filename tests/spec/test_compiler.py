"""Compilation of SPI and hazard bindings, and the formula checks (CW040-CW047)."""

from __future__ import annotations

import math
from pathlib import Path

from casewatch.safety_case.model import Mark, Node, NodeType, SpiBinding
from casewatch.spec.compiler import check_formulas, compile_case
from tests.spec.cases import hazard_node, make_case, spi_node, stl_node
from tests.spec.rtamt_helpers import online

REFERENCE_CASE = Path(__file__).resolve().parents[2] / "examples" / "reference-case.yaml"


def test_threshold_compiles_to_comparison() -> None:
    spec, findings = compile_case(make_case(spi_node("Sn1", "els", ">=", 0.6)))
    assert findings == []
    assert spec is not None
    (formula,) = spec.formulas
    assert (formula.id, formula.kind, formula.rtamt) == ("Sn1", "spi", "(els >= 0.6)")
    assert (formula.signal, formula.threshold, formula.signals) == ("els", ">= 0.6", ["els"])
    assert (formula.merge_gap, formula.min_duration, formula.horizon) == (1.0, 0.0, 0.0)
    assert spec.traces["Sn1"][0][0].id == "Sn1" and spec.traces["Sn1"][0][-1].id == "G1"
    assert spec.signals == {"els": ["Sn1"]}


def test_for_compiles_to_once_and_is_violated_only_after_d() -> None:
    spec, findings = compile_case(make_case(spi_node("Sn1", "els", ">=", 0.6, for_seconds=0.2)))
    assert findings == [] and spec is not None
    formula = spec.formulas[0]
    assert formula.rtamt == "(once[0s:0.2s] (els >= 0.6))"
    assert math.isclose(formula.horizon, 0.2)
    # els fails from t=1 on; with for 0.2 s (2 periods) the SPI is violated only at t=3,
    # once samples 1, 2, 3 all failed: max(0.3-0.6, 0.2-0.6, 0.1-0.6) = -0.3
    got = online(formula.rtamt, {"els": [0.9, 0.3, 0.2, 0.1, 0.8]})
    expected = [0.3, 0.3, 0.3, -0.3, 0.2]
    assert all(abs(g - e) <= 1e-9 for g, e in zip(got, expected, strict=True))


def test_raw_stl_is_parsed_and_reemitted_canonically() -> None:
    spec, findings = compile_case(make_case(stl_node("Sn1", "ets>=0.6 or  once[0:300ms] ets>0.7")))
    assert findings == [] and spec is not None
    formula = spec.formulas[0]
    assert formula.source == "ets>=0.6 or  once[0:300ms] ets>0.7"
    assert formula.rtamt == "((ets >= 0.6) or (once[0s:0.3s] (ets > 0.7)))"
    assert formula.signal is None and formula.threshold is None


def test_hazard_compiles_to_negation() -> None:
    case = make_case(hazard_node("CSn1", "els_var > 0.05"))
    spec, findings = compile_case(case)
    assert findings == [] and spec is not None
    formula = spec.formulas[0]
    assert (formula.kind, formula.rtamt) == ("hazard", "(not (els_var > 0.05))")
    # hazard present (els_var = 0.08) -> robustness -(0.08 - 0.05) = -0.03 < 0
    assert abs(online(formula.rtamt, {"els_var": [0.08]})[0] + 0.03) <= 1e-9
    assert [step.id for step in spec.traces["CSn1"][0]] == ["CSn1", "G1"]


def test_merge_gap_and_min_duration_resolve_against_defaults() -> None:
    node = spi_node("Sn1", "els", ">=", 0.6)
    node = node.model_copy(
        update={"spi": node.spi.model_copy(update={"merge_gap": 2.5})}  # type: ignore[union-attr]
    )
    spec, _ = compile_case(make_case(node))
    assert spec is not None
    assert (spec.formulas[0].merge_gap, spec.formulas[0].min_duration) == (2.5, 0.0)


def test_unknown_signal_finding_points_into_yaml() -> None:
    findings = check_formulas(make_case(hazard_node("CSn1", "abs(ocs - olss) > 0.5", 30, 12)))
    (finding,) = findings
    # 'olss' is at formula column 11; the text starts at YAML column 12 -> 12 + 11 - 1 = 22
    assert (finding.code, finding.line, finding.col) == ("CW041", 30, 22)
    assert "did you mean 'ols'?" in finding.message
    assert finding.format().startswith(
        "case.yaml:30:22: CW041 error: unknown signal 'olss' in formula of node CSn1; did you mean"
    )


def test_unknown_threshold_signal_points_at_signal_value() -> None:
    (finding,) = check_formulas(make_case(spi_node("Sn1", "elss", ">=", 0.6)))
    assert (finding.code, finding.line, finding.col) == ("CW041", 10, 18)


def test_parse_error_finding() -> None:
    (finding,) = check_formulas(make_case(stl_node("Sn1", "els >= 0.6 and", 20, 10)))
    # formula ends after column 14 -> error at formula col 15 -> YAML col 10 + 15 - 1 = 24
    assert (finding.code, finding.line, finding.col) == ("CW040", 20, 24)
    assert "does not parse" in finding.message


def test_online_rejects_future_operators_with_past_time_suggestion() -> None:
    case = make_case(stl_node("Sn1", "eventually[0:1s] els >= 0.6", 20, 10))
    (finding,) = check_formulas(case, mode="online")
    assert (finding.code, finding.line, finding.col) == ("CW042", 20, 10)
    assert "once[0s:1s] (els >= 0.6)" in finding.hint
    assert "1s late" in finding.hint
    # offline accepts it and records how far it looks ahead
    spec, findings = compile_case(case, mode="offline")
    assert findings == [] and spec is not None
    assert spec.formulas[0].rtamt == "(eventually[0s:1s] (els >= 0.6))"
    assert spec.formulas[0].future_horizon == 1.0


def test_bounds_must_be_whole_periods() -> None:
    (finding,) = check_formulas(make_case(stl_node("Sn1", "once[0:0.25s] els >= 0.6")))
    assert finding.code == "CW043" and "0.25s" in finding.message
    (finding,) = check_formulas(make_case(spi_node("Sn1", "els", ">=", 0.6, for_seconds=0.15)))
    assert (finding.code, finding.line, finding.col) == ("CW043", 10, 3)
    # at a period of 50 ms the same bound is fine
    spec, findings = compile_case(
        make_case(stl_node("Sn1", "once[0:0.25s] els >= 0.6"), period=0.05)
    )
    assert findings == [] and spec is not None


def test_division_by_constant_zero() -> None:
    (finding,) = check_formulas(make_case(stl_node("Sn1", "els / 0 >= 1")))
    assert finding.code == "CW045"


def test_spi_without_formula_is_reported_not_skipped() -> None:
    node = Node(
        id="Sn1", type=NodeType.SOLUTION, text="empty", spi=SpiBinding(mark=Mark(line=5, col=3))
    )
    spec, findings = compile_case(make_case(node))
    assert spec is None
    assert [(f.code, f.line) for f in findings] == [("CW044", 5)]


def test_declared_signals_listed_even_unused() -> None:
    case = make_case(stl_node("Sn1", "speed <= 14"), signals={"speed": "m/s", "lane": "m"})
    spec, _ = compile_case(case)
    assert spec is not None
    assert spec.signals == {"lane": [], "speed": ["Sn1"]}


# One hand-made sample for the reference case, and each formula's robustness by hand.
REFERENCE_SAMPLE = {
    "els": 0.7,
    "els_var": 0.01,
    "eos": 0.9,
    "ocs": 1.0,
    "ols": 0.2,
    "oos": 0.65,
    "oas": 0.5,
    "ots": 0.6,
    "ompv": 0.75,
    "ets": 0.55,
    "crpps": 0.8,
    "chpps": 0.72,
    "hcs": 0.85,
    "ppcs": 0.85,
    "ss": 0.95,
    "ego_dist": 0.3,
    "lead_thw": 0.8,
    "ego_speed": 20.0,
    "follow_thw": 2.5,
    "follow_speed": 10.0,
    "lone_age": 0.4,
    "plan_lat": 0.2,
}
REFERENCE_EXPECTED = {
    "Sn1": 0.1,  # els >= 0.6: 0.7 - 0.6
    "Sn2": 0.04,  # els_var <= 0.05: 0.05 - 0.01
    "Sn3": 0.1,  # eos >= 0.8: 0.9 - 0.8
    "Sn4": -0.3,  # ols >= 0.5: 0.2 - 0.5
    "Sn5": 0.05,  # oos >= 0.6: 0.65 - 0.6
    "Sn6": -0.1,  # oas >= 0.6: 0.5 - 0.6
    "Sn7": 0.0,  # ots >= 0.6: 0.6 - 0.6
    "Sn8": 0.25,  # ompv >= 0.5: 0.75 - 0.5
    "Sn9": -0.05,  # ets >= 0.6: 0.55 - 0.6
    "Sn10": 0.3,  # crpps >= 0.5: 0.8 - 0.5
    "Sn11": 0.02,  # chpps >= 0.7: 0.72 - 0.7
    "Sn12": 0.05,  # hcs >= 0.8: 0.85 - 0.8
    "Sn13": 0.05,  # ppcs >= 0.8: 0.85 - 0.8
    "Sn14": 0.45,  # ss >= 0.5: 0.95 - 0.5
    "Sn15": 1.1,  # lone_age <= 1.5: 1.5 - 0.4
    "Sn16": 0.4,  # plan_lat <= 0.6: 0.6 - 0.2
    # not (els_var > 0.05 or ego_dist > 1.5) = -max(0.01 - 0.05, 0.3 - 1.5) = 0.04
    "CSn1": 0.04,
    # not (lead_thw < 1.0 and ego_speed > 5.0) = -min(1.0 - 0.8, 20 - 5) = -0.2: tailgating
    "CSn2": -0.2,
    # not (follow_thw < 1.0 and follow_speed > 5.0) = -min(1.0 - 2.5, 10 - 5) = 1.5
    "CSn3": 1.5,
}


def test_reference_case_compiles_and_rtamt_matches_hand_values() -> None:
    from casewatch.safety_case.loader import load_case

    case, load_findings = load_case(REFERENCE_CASE)
    assert case is not None, [f.format() for f in load_findings]
    spec, findings = compile_case(case)
    assert findings == [] and spec is not None
    assert sorted(f.id for f in spec.formulas) == sorted(REFERENCE_EXPECTED)
    for formula in spec.formulas:
        trace = {name: [REFERENCE_SAMPLE[name]] for name in formula.signals}
        (got,) = online(formula.rtamt, trace)  # rtamt parses the emitted text and evaluates it
        assert abs(got - REFERENCE_EXPECTED[formula.id]) <= 1e-9, (formula.id, formula.rtamt, got)


def test_formula_without_any_signal_is_refused() -> None:
    (finding,) = check_formulas(make_case(hazard_node("CSn1", "1 > 0", 30, 12)))
    assert (finding.code, finding.line, finding.col) == ("CW047", 30, 12)
    assert "reads no signal" in finding.message
    (finding,) = check_formulas(make_case(stl_node("Sn1", "once[0:1s] (2 >= 1)", 20, 10)))
    assert (finding.code, finding.line, finding.col) == ("CW047", 20, 10)


def test_numbers_are_ascii_digits_without_separators() -> None:
    for text in ("els >= 1_0", "els >= \u0661"):  # a digit separator; ARABIC-INDIC DIGIT ONE
        (finding,) = check_formulas(make_case(stl_node("Sn1", text, 20, 10)))
        assert finding.code == "CW040", text


def test_windows_longer_than_a_million_samples_are_refused() -> None:
    (finding,) = check_formulas(make_case(stl_node("Sn1", "once[0:1e300s] els > 0", 20, 10)))
    assert (finding.code, finding.line, finding.col) == ("CW048", 20, 14)  # at the interval
    (finding,) = check_formulas(make_case(spi_node("Sn1", "els", ">=", 0.6, for_seconds=1e7)))
    assert (finding.code, finding.line, finding.col) == ("CW048", 10, 3)
    spec, findings = compile_case(make_case(stl_node("Sn1", "once[0:100000s] els > 0")))
    assert findings == [] and spec is not None  # exactly 10^6 samples at 0.1 s
