"""JUnit XML: well-formed whatever the text, one case per SPI and hazard, failing on episodes."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.evaluator.result import RunResult
from casewatch.reports.junit import render_junit, xml_text


def test_well_formed_with_hostile_text_and_control_characters(hostile_result: RunResult) -> None:
    xml = render_junit(hostile_result)
    root = ET.fromstring(xml.encode("utf-8"))  # raises on malformed XML
    suite = root.find("testsuite")
    assert suite is not None
    assert suite.get("name") == hostile_result.case.module  # markup kept as text, escaped
    names = [
        case.get("name") or ""
        for case in suite.iter("testcase")
        if not case.get("classname", "").endswith(".stream")
    ]
    assert names and all("<script>alert(1)</script>" in n for n in names)


def test_one_case_per_spi_and_hazard_failing_on_episodes(reference_result: RunResult) -> None:
    root = ET.fromstring(render_junit(reference_result))
    suite = root.find("testsuite")
    cases = {
        c.get("name", "").split(":")[0]: c
        for c in suite.iter("testcase")
        if not c.get("classname", "").endswith(".stream")
    }
    formulas = {f.node_id: f for f in reference_result.formulas}
    assert set(cases) == set(formulas)
    failing = {n for n, c in cases.items() if c.find("failure") is not None}
    assert failing == {n for n, f in formulas.items() if f.episodes > 0}
    # issue 31: a damaged log adds one failing case of its own, under every --fail-on policy
    damaged = reference_result.stream.defect_count > 0
    assert suite.get("tests") == str(len(formulas) + damaged)
    assert suite.get("failures") == str(len(failing) + damaged)


def test_a_damaged_log_fails_its_stream_case_under_every_policy(
    reference_result: RunResult,
) -> None:
    clean = reference_result.stream.model_copy(update={"defects": [], "defect_count": 0})
    for policy in ("any", "never"):
        result = reference_result.model_copy(update={"fail_on": policy})
        stream_cases = [
            c
            for c in ET.fromstring(render_junit(result)).iter("testcase")
            if c.get("classname", "").endswith(".stream")
        ]
        if reference_result.stream.defect_count:
            (case,) = stream_cases
            failure = case.find("failure")
            assert failure is not None and failure.get("type") == "casewatch.damage"
            assert f"{reference_result.stream.defect_count} stream defect(s)" in failure.get(
                "message"
            )
        without = render_junit(result.model_copy(update={"stream": clean}))
        assert "casewatch.damage" not in without


def test_failure_holds_worst_episode_and_trace(reference_result: RunResult) -> None:
    root = ET.fromstring(render_junit(reference_result))
    episodes = [e for e in reference_result.episodes if e.node_id == "Sn1"]
    worst = min(episodes, key=lambda e: e.worst_robustness)
    case = next(c for c in root.iter("testcase") if c.get("name", "").startswith("Sn1:"))
    failure = case.find("failure")
    assert f"worst robustness {worst.worst_robustness:+.3f}" in failure.get("message")
    assert f"had {len(episodes)} episodes" in failure.get("message")
    assert "Sn1 (" in failure.text and "-> G1 (" in failure.text


def test_never_evaluated_formula_is_an_error_not_a_pass(reference_result: RunResult) -> None:
    formulas = [
        f.model_copy(update={"ticks_evaluated": 0, "episodes": 0}) if f.id == "Sn10" else f
        for f in reference_result.formulas
    ]
    episodes = [e for e in reference_result.episodes if e.formula_id != "Sn10"]
    result = reference_result.model_copy(update={"formulas": formulas, "episodes": episodes})
    case = next(
        c
        for c in ET.fromstring(render_junit(result)).iter("testcase")
        if c.get("name", "").startswith("Sn10:")
    )
    assert case.find("error") is not None


def test_xml_text_strips_illegal_characters() -> None:
    assert xml_text("a\x00b\x1bc\td\ne") == "abc\td\ne"


@settings(max_examples=60, deadline=None)
@given(st.text())
def test_any_node_text_gives_well_formed_xml(text: str) -> None:
    element = ET.Element("testcase", name=xml_text(text))
    element.text = xml_text(text)
    parsed = ET.fromstring(ET.tostring(element, encoding="unicode"))  # raises if malformed
    # XML parsers normalise line ends to \n; everything else survives
    expected = xml_text(text).replace("\r\n", "\n").replace("\r", "\n")
    assert (parsed.text or "") == expected
