"""Structural checks: each code fires on its fixture at the right line; clean cases stay clean."""

from __future__ import annotations

from pathlib import Path

import pytest

from casewatch.safety_case.checks import check_case, check_file
from casewatch.safety_case.loader import load_text
from tests.safety_case.fixtures import BASE, CHECK_FIXTURES, case

REFERENCE = Path(__file__).resolve().parents[2] / "examples" / "reference-case.yaml"


def all_findings(text: str) -> list:
    result = load_text(text, "fixture.yaml")
    findings = list(result.findings)
    if result.partial is not None:
        findings += check_case(result.partial, skipped=result.skipped, invalid=result.invalid)
    return findings


@pytest.mark.parametrize(
    ("code", "text", "line", "col"), CHECK_FIXTURES, ids=[f[0] for f in CHECK_FIXTURES]
)
def test_check_fixture_reports_code_at_line(code: str, text: str, line: int, col: int) -> None:
    findings = all_findings(text)
    assert (line, col) in [(f.line, f.col) for f in findings if f.code == code], [
        f.format() for f in findings
    ]


def test_structural_fixtures_load_but_fail_checks() -> None:
    # the check fixtures are schema-valid: the loader alone accepts them
    for code, text, _, _ in CHECK_FIXTURES:
        result = load_text(text)
        assert result.case is not None, code


def test_base_and_reference_are_clean() -> None:
    assert all_findings(BASE) == []
    value, findings = check_file(REFERENCE)
    assert value is not None and findings == []


def test_dangling_reference_suggests_close_id() -> None:
    findings = all_findings(case("G1:\n  text: top\n  supportedBy: [Sn11]\nSn1: {text: e}\n"))
    hit = next(f for f in findings if f.code == "CW030")
    assert "did you mean 'Sn1'" in hit.message


def test_unknown_node_type_is_not_also_dangling() -> None:
    findings = all_findings(case("G1:\n  text: top\n  supportedBy: [X1]\nX1: {text: e}\n"))
    assert [f.code for f in findings] == ["CW020"]


def test_supported_by_context_hints_in_context_of() -> None:
    findings = all_findings(
        case("G1:\n  text: top\n  supportedBy: [Sn1, C1]\nSn1: {text: e}\nC1: {text: c}\n")
    )
    hit = next(f for f in findings if f.code == "CW032")
    assert "inContextOf: [C1]" in hit.hint
    # C1 is otherwise connected through the (wrong) edge, so it is not also unreachable
    assert "CW037" not in [f.code for f in findings]


def test_solution_cannot_have_support() -> None:
    text = case(
        "G1: {text: top, supportedBy: [Sn1]}\nSn1: {text: e, supportedBy: [Sn2]}\nSn2: {text: f}\n"
    )
    findings = all_findings(text)
    hit = next(f for f in findings if f.code == "CW032")
    assert hit.line == 4 and "cannot have `supportedBy`" in hit.message


def test_counter_goal_supported_by_counter_solution_is_fine() -> None:
    text = BASE + (
        "CG1:\n  text: doubt\n  challenges: G1\n  supportedBy: [CSn1]\n"  # lines 8-11
        "CSn1:\n  text: evidence of doubt\n  challenges: G1\n"
    )
    assert all_findings(text) == []


def test_counter_node_hanging_off_unreachable_node_is_unreachable() -> None:
    text = BASE + "G2: {text: other, undeveloped: true}\nCSn1: {text: h, challenges: G2}\n"
    findings = all_findings(text)
    codes = [(f.code, f.line) for f in findings]
    assert ("CW035", 8) in codes  # G2 is a second root
    # CSn1 challenges G2, which is itself a root, so it counts as reached from G2
    assert ("CW037", 9) not in codes


def test_root_cycle_reports_no_root() -> None:
    text = case("G1: {text: a, supportedBy: [G2]}\nG2: {text: b, supportedBy: [G1]}\n")
    codes = [f.code for f in all_findings(text)]
    assert "CW034" in codes and "CW035" in codes


def test_undeveloped_warning_is_only_a_warning() -> None:
    findings = all_findings(case("G1:\n  text: top\n"))
    assert [(f.code, f.severity) for f in findings] == [("CW039", "warning")]
    assert all_findings(case("G1:\n  text: top\n  undeveloped: true\n")) == []


def test_root_goal_with_empty_support_list_is_warned() -> None:
    findings = all_findings(case("G1:\n  text: top\n  supportedBy: []\n"))
    assert [(f.code, f.severity, f.line, f.col) for f in findings] == [("CW039", "warning", 5, 3)]
    assert "root goal G1 has no support" in findings[0].message


def test_invalid_support_list_is_not_warned_again() -> None:
    findings = all_findings(case("G1:\n  text: top\n  supportedBy: [1]\n"))
    assert [f.code for f in findings] == ["CW012"]


def test_challenging_a_solution_suggests_the_goal_above() -> None:
    text = BASE + "CSn1:\n  text: d\n  challenges: Sn1\n"
    hit = next(f for f in all_findings(text) if f.code == "CW027")
    assert (hit.line, hit.col) == (10, 15) and hit.hint.endswith("`challenges: G1`")
