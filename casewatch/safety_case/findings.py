"""Findings: the one shape every check in casewatch reports in.

A finding says where (file, line, column), what (a stable code and a message in the user's
terms) and how bad (error or warning). `docs/checks.md` holds the table of codes; a retired code
is never reused.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Literal

from casewatch.errors import CasewatchError

Severity = Literal["error", "warning"]


@dataclass(frozen=True)
class Finding:
    """One problem found in a safety case, a formula or a stream."""

    code: str
    severity: Severity
    message: str
    path: str = "<input>"
    line: int = 0
    col: int = 0
    hint: str = ""

    def format(self) -> str:
        """Render as `PATH:LINE:COL: CODE severity: message`, plus an indented hint line."""
        text = f"{self.path}:{self.line}:{self.col}: {self.code} {self.severity}: {self.message}"
        if self.hint:
            text += "\n    " + self.hint.replace("\n", "\n    ")
        return text

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


def has_errors(findings: list[Finding]) -> bool:
    return any(f.severity == "error" for f in findings)


class CaseError(CasewatchError):
    """Raised by the public API when a safety case has errors; carries every finding."""

    def __init__(self, findings: list[Finding]):
        self.findings = findings
        super().__init__("\n".join(f.format() for f in findings))
