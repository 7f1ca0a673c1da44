"""`check_file`: load a case and run every structural check on it, in one call.

The checks themselves live in `structure.py`, which loads nothing, so that imports run one way:
`structure` <- `loader` <- `checks`. `check_case` and `sort_findings` are re-exported here,
where callers have always found them.
"""

from __future__ import annotations

from pathlib import Path

from casewatch.safety_case.findings import Finding
from casewatch.safety_case.loader import load_file
from casewatch.safety_case.model import Case
from casewatch.safety_case.structure import check_case, sort_findings

__all__ = ["check_case", "check_file", "sort_findings"]


def check_file(path: str | Path) -> tuple[Case | None, list[Finding]]:
    """Load `path` and run every structural check; findings sorted by position."""
    result = load_file(path)
    findings = list(result.findings)
    if result.partial is not None:
        findings += check_case(
            result.partial,
            skipped=result.skipped,
            invalid=result.invalid,
            gsn2x_rules=result.gsn2x_rules,
        )
    return result.case, sort_findings(findings)
