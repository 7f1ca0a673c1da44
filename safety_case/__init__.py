"""The YAML safety-case language: schema, loading with positions, the GSN graph and its checks."""

from safety_case.checks import check_case, check_file
from safety_case.findings import CaseError, Finding
from safety_case.loader import load_case, load_case_text, require_case
from safety_case.model import Case
from safety_case.trace import traces_to_root

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
