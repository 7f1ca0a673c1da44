"""The YAML safety-case language: schema, loading with positions, the GSN graph and its checks."""

from casewatch.safety_case.checks import check_case, check_file
from casewatch.safety_case.findings import CaseError, Finding
from casewatch.safety_case.loader import load_case, load_case_text, require_case
from casewatch.safety_case.model import Case
from casewatch.safety_case.trace import traces_to_root

__all__ = [
    "Case",
    "CaseError",
    "Finding",
    "check_case",
    "check_file",
    "load_case",
    "load_case_text",
    "require_case",
    "traces_to_root",
]
