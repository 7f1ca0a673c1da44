"""Loader: every loading code fires on its fixture at the right line, and a valid case loads."""

from __future__ import annotations

from pathlib import Path

import pytest

from casewatch.safety_case.codes import CODES
from casewatch.safety_case.findings import CaseError
from casewatch.safety_case.loader import (
    load_bytes,
    load_case,
    load_case_text,
    load_file,
    require_case,
)
from casewatch.safety_case.model import Mark, NodeType, Threshold
from tests.safety_case.fixtures import BASE, LOADER_FIXTURES, case

REFERENCE = Path(__file__).resolve().parents[2] / "examples" / "reference-case.yaml"


def codes_at(findings: list, code: str) -> list[tuple[int, int]]:
    return [(f.line, f.col) for f in findings if f.code == code]


@pytest.mark.parametrize(
    ("code", "text", "line", "col"),
    [f for f in LOADER_FIXTURES if f[0] != "CW002"],
    ids=[f[0] for f in LOADER_FIXTURES if f[0] != "CW002"],
)
def test_loader_fixture_reports_code_at_line(code: str, text: str, line: int, col: int) -> None:
    case_value, findings = load_case_text(text, "fixture.yaml")
    assert (case_value is None) == (CODES[code].severity == "error")  # CW011 only warns
    assert (line, col) in codes_at(findings, code), [f.format() for f in findings]
    assert all(f.path == "fixture.yaml" for f in findings)


def test_invalid_utf8_is_cw002_at_the_bad_byte() -> None:
    # line 2 is b"text: caf\xe9": the bad byte is the 10th byte of the line
    result = load_bytes(b"module: {name: t}\ntext: caf\xe9\n", "bad.yaml")
    assert [(f.code, f.line, f.col) for f in result.findings] == [("CW002", 2, 10)]
    assert result.case is None


def test_unreadable_file_is_cw001(tmp_path: Path) -> None:
    case_value, findings = load_case(tmp_path / "missing.yaml")
    assert case_value is None
    assert [f.code for f in findings] == ["CW001"]
    assert "cannot read file" in findings[0].message
    _, findings = load_case(tmp_path)  # a directory is unreadable as a file too
    assert [f.code for f in findings] == ["CW001"]


def test_empty_file_is_cw004() -> None:
    _, findings = load_case_text("", "e.yaml")
    assert [(f.code, f.line) for f in findings] == [("CW004", 1)]
    _, findings = load_case_text("# only a comment\n", "e.yaml")
    assert [f.code for f in findings] == ["CW004"]


def test_base_loads_with_positions() -> None:
    value, findings = load_case_text(BASE, "b.yaml")
    assert findings == []
    assert value is not None
    assert value.nodes["G1"].type is NodeType.GOAL
    assert value.nodes["G1"].supported_by == ["Sn1"]
    assert value.nodes["G1"].mark == Mark(line=3, col=1)
    # "  supportedBy: [Sn1]" -> Sn1 starts at column 17
    assert value.nodes["G1"].ref_marks == {"supportedBy": {"Sn1": Mark(line=5, col=17)}}
    assert value.nodes["Sn1"].type is NodeType.SOLUTION
    assert value.monitor.channels == ["lav", "tfuse"]
    assert value.monitor.period == 0.1
    assert value.module.name == "t"
    assert len(value.digest) == 64


def test_spi_and_hazard_bindings_are_normalised_with_formula_marks() -> None:
    text = case(
        "G1:\n"  # 3
        "  text: top\n"  # 4
        "  supportedBy: [Sn1, Sn2]\n"  # 5
        "Sn1:\n"  # 6
        "  text: e\n"  # 7
        "  spi: {signal: els, threshold: '>= 0.6', for: 300ms, merge_gap: 2s}\n"  # 8
        "Sn2:\n"  # 9
        "  text: f\n"  # 10
        "  spi:\n"  # 11
        '    stl: "always(ets >= 0.6)"\n'  # 12
        "    min_duration: 1min\n"  # 13
        "CSn1:\n"  # 14
        "  text: h\n"  # 15
        "  challenges: G1\n"  # 16
        "  hazard:\n"  # 17
        "    when: |\n"  # 18
        "      els_var > 0.05\n"  # 19
    )
    value, findings = load_case_text(text)
    assert findings == []
    assert value is not None
    sn1 = value.nodes["Sn1"].spi
    assert sn1 is not None
    assert (sn1.signal, sn1.for_seconds) == ("els", 0.3)
    assert sn1.threshold == Threshold(op=">=", value=0.6)
    assert sn1.merge_gap == 2.0 and sn1.min_duration is None and sn1.stl is None
    assert sn1.mark == Mark(line=8, col=3)
    # plain scalar `els` after "  spi: {signal: " (16 characters) -> column 17
    assert sn1.formula_mark == Mark(line=8, col=17)
    sn2 = value.nodes["Sn2"].spi
    assert sn2 is not None and sn2.stl == "always(ets >= 0.6)" and sn2.min_duration == 60.0
    # quoted: `    stl: "` is 10 characters, the formula's first character is column 11
    assert sn2.formula_mark == Mark(line=12, col=11)
    hazard = value.nodes["CSn1"].hazard
    assert hazard is not None and hazard.when == "els_var > 0.05\n"
    # block scalar: first content line 19, indented 6 -> column 7
    assert hazard.formula_mark == Mark(line=19, col=7)
    assert value.nodes["CSn1"].challenges == ["G1"]


def test_monitor_block_full() -> None:
    text = (
        "module: {name: m, brief: b}\n"
        "monitor:\n"
        "  channels: [lav, tfuse, third]\n"
        "  period: 50ms\n"
        "  signals: {speed: 'ego speed [m/s]', lane_offset: }\n"
        "  metrics: {pairing_gate: 2.5, els_window: 7}\n"
        "  merge_gap: 0.5\n"
        "  min_duration: 200ms\n"
        "G1: {text: t, undeveloped: true}\n"
    )
    value, findings = load_case_text(text)
    assert findings == []
    assert value is not None
    monitor = value.monitor
    assert monitor.channels == ["lav", "tfuse", "third"]
    assert monitor.period == pytest.approx(0.05)
    assert monitor.signals == {"speed": "ego speed [m/s]", "lane_offset": ""}
    assert monitor.metrics.pairing_gate == 2.5 and monitor.metrics.els_window == 7
    assert monitor.metrics.plan_history == 10  # default kept
    assert monitor.merge_gap == 0.5 and monitor.min_duration == pytest.approx(0.2)
    assert monitor.mark == Mark(line=2, col=1)


def test_signals_as_list() -> None:
    text = "module: {name: m}\nmonitor: {channels: [a, b], signals: [speed]}\nG1: {text: t}\n"
    value, _ = load_case_text(text)
    assert value is not None and value.monitor.signals == {"speed": ""}


@pytest.mark.parametrize(
    ("channels", "fragment"),
    [
        ("[lav, 7up]", "must start with a letter"),
        ("[lav, tf-use]", "only letters, digits and '_'"),
        ('[lav, "tfuse\\n"]', "only letters, digits and '_'"),  # fullmatch: no newline
        ("[lav, tf__use]", "must not contain '__'"),
        ("[lav, tfuse_]", "must not end in '_'"),
        ("[lav, lav]", "listed twice"),
        ("[lav]", "at least two"),
    ],
)
def test_channel_rules(channels: str, fragment: str) -> None:
    text = f"module: {{name: m}}\nmonitor:\n  channels: {channels}\nG1: {{text: t}}\n"
    _, findings = load_case_text(text)
    hits = [f for f in findings if f.code == "CW019"]
    assert len(hits) == 1 and fragment in hits[0].message and hits[0].line == 3


@pytest.mark.parametrize("channels", ["[chA, Apollo7]", "[lav, LAV]", "[front_cam, rear_2]"])
def test_channel_names_are_identifiers_of_any_case(channels: str) -> None:
    text = f"module: {{name: m}}\nmonitor:\n  channels: {channels}\nG1: {{text: t}}\n"
    value, findings = load_case_text(text)
    assert value is not None and findings == []


def test_unknown_metric_parameter_suggests_the_right_one() -> None:
    text = "module: {name: m}\nmonitor:\n  channels: [a, b]\n  metrics:\n    pet_rf: 2\n"
    _, findings = load_case_text(text)
    hit = next(f for f in findings if f.code == "CW013")
    assert (hit.line, hit.col) == (5, 5)
    assert "did you mean 'pet_ref'" in hit.message


def test_metric_parameter_out_of_range_is_cw012() -> None:
    text = "module: {name: m}\nmonitor:\n  channels: [a, b]\n  metrics: {trajectory_decay: 1.5}\n"
    _, findings = load_case_text(text)
    hit = next(f for f in findings if f.code == "CW012")
    assert hit.line == 4 and "trajectory_decay" in hit.message


@pytest.mark.parametrize(
    ("spi", "fragment"),
    [
        ("{stl: 'els > 1', signal: els, threshold: '>1'}", "not both"),
        ("{stl: 'els > 1', for: 1s}", "`for` applies"),
        ("{threshold: '>1'}", "`signal` is missing"),
        ("{merge_gap: 1s}", "needs `signal` + `threshold`"),
    ],
)
def test_spi_shapes(spi: str, fragment: str) -> None:
    text = case(f"G1: {{text: t, supportedBy: Sn1}}\nSn1:\n  text: e\n  spi: {spi}\n")
    _, findings = load_case_text(text)
    hits = [f for f in findings if f.code == "CW018"]
    assert len(hits) == 1 and fragment in hits[0].message and hits[0].line == 6


def test_unknown_top_level_key_suggests_reserved_block() -> None:
    text = "module: {name: m}\nmonitr: {channels: [a, b]}\nG1: {text: t}\n"
    _, findings = load_case_text(text)
    hit = next(f for f in findings if f.code == "CW020")
    assert hit.line == 2 and "did you mean 'monitor'" in hit.message


def test_tags_are_never_constructed() -> None:
    text = case("G1:\n  text: !!python/object/apply:os.system ['echo hacked']\n")
    value, findings = load_case_text(text)
    assert value is None
    assert ("CW006", 4) in [(f.code, f.line) for f in findings]


def test_require_case_raises_with_all_errors(tmp_path: Path) -> None:
    path = tmp_path / "c.yaml"
    path.write_text(case("G1:\n  text: top\n  supportedBy: [Sn9]\n"))
    with pytest.raises(CaseError) as info:
        require_case(path)
    assert [f.code for f in info.value.findings] == ["CW030"]
    good = tmp_path / "good.yaml"
    good.write_text(BASE)
    assert require_case(good).nodes["Sn1"].text == "evidence"


def test_reference_case_loads_cleanly() -> None:
    result = load_file(REFERENCE)
    assert result.findings == []
    assert result.case is not None
    spis = {n.spi.signal for n in result.case.nodes.values() if n.spi is not None}
    # every judged SPI of spi-reference (ocs is observed, not judged)
    assert spis == {
        "els",
        "els_var",
        "eos",
        "ols",
        "oos",
        "oas",
        "ots",
        "ets",
        "crpps",
        "chpps",
        "hcs",
        "ppcs",
        "ompv",
        "ss",
        "lone_age",
        "plan_lat",
    }
    hazards = {n.id: n.hazard.when for n in result.case.nodes.values() if n.hazard is not None}
    assert hazards["CSn2"] == "lead_thw < 1.0 and ego_speed > 5.0"
    assert result.case.nodes["G1"].text == "EGO vehicle goes from Point A to Point B safely"


def test_study_case_keeps_the_study_rules_verbatim() -> None:
    result = load_file(REFERENCE.parent / "study-case.yaml")
    assert result.findings == [] and result.case is not None
    hazards = {n.id: n.hazard.when for n in result.case.nodes.values() if n.hazard is not None}
    assert hazards == {
        "CSn1": "els_var > 0.05",
        "CSn2": "abs(ocs - ols) > 0.5 and ss >= 0.8 and ppcs < 0.9 and ppcs >= 0.7",
        "CSn3": "abs(ocs - ols) > 0.5 and ss < 0.8 and ppcs >= 0.8",
    }
    # the same argument as the reference case: only the hazard rules differ
    reference = load_file(REFERENCE).case
    assert reference is not None
    assert [(n.id, n.text, n.spi) for n in result.case.nodes.values()] == [
        (n.id, n.text, n.spi) for n in reference.nodes.values()
    ]
