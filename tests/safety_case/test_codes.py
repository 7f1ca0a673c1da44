"""The code registry, the docs table and the fixtures agree."""

from __future__ import annotations

import re
from pathlib import Path

from casewatch.safety_case.codes import CODES
from tests.safety_case.fixtures import CHECK_FIXTURES, LOADER_FIXTURES

DOCS = Path(__file__).resolve().parents[2] / "docs" / "checks.md"


def test_every_code_has_a_failing_fixture() -> None:
    # CW001: test_loader; CW029 (an id in two files): test_modules
    # CW060 (a used module's monitor): test_gsn2x
    covered = {f[0] for f in LOADER_FIXTURES + CHECK_FIXTURES} | {"CW001", "CW029", "CW060"}
    assert covered == set(CODES)


def test_codes_stay_in_the_structural_range() -> None:
    assert all(re.fullmatch(r"CW0[0-3]\d|CW0[67]\d", code) for code in CODES)


def test_docs_table_lists_every_code_with_its_severity() -> None:
    rows = dict(re.findall(r"^\| (CW\d{3}) \| (error|warning) \|", DOCS.read_text(), re.M))
    assert {c: e.severity for c, e in CODES.items()} == {c: rows[c] for c in CODES}


def test_language_doc_example_passes_check() -> None:
    from casewatch.safety_case.checks import check_case
    from casewatch.safety_case.loader import load_text

    doc = (DOCS.parent / "safety-case-language.md").read_text()
    example = doc.split("```yaml\n", 1)[1].split("```", 1)[0]
    result = load_text(example, "example.yaml")
    assert result.case is not None, [f.format() for f in result.findings]
    assert result.findings == [] and check_case(result.case) == []
    assert result.case.nodes["Sn2"].spi is not None
    assert result.case.monitor.signals == {"lane_offset": "lateral offset from the lane centre [m]"}
