"""The formula code registry and the docs table agree (the structural codes: tests/safety_case)."""

from __future__ import annotations

import re
from pathlib import Path

from casewatch.safety_case.codes import CODES
from casewatch.spec.codes import FORMULA_CODES

DOCS = Path(__file__).resolve().parents[2] / "docs" / "checks.md"


def test_formula_codes_stay_in_their_range_and_apart_from_structural_ones() -> None:
    assert all(re.fullmatch(r"CW0[45]\d", code) for code in FORMULA_CODES)
    assert not set(FORMULA_CODES) & set(CODES)


def test_docs_table_lists_every_formula_code_with_its_severity() -> None:
    rows = dict(re.findall(r"^\| (CW\d{3}) \| (error|warning) \|", DOCS.read_text(), re.M))
    assert {c: severity for c, (severity, _) in FORMULA_CODES.items()} == {
        c: rows.get(c) for c in FORMULA_CODES
    }
