"""The formula check codes CW040-CW059 (the structural codes CW001-CW039 live in
`safety_case/codes.py`). `docs/checks.md`, section "Formula checks", documents each one."""

from __future__ import annotations

from casewatch.safety_case.findings import Finding, Severity

FORMULA_CODES: dict[str, tuple[Severity, str]] = {
    "CW040": ("error", "formula does not parse"),
    "CW041": ("error", "unknown signal in a formula"),
    "CW042": ("error", "future operator in an online (causal) formula"),
    "CW043": ("error", "time bound is not a whole number of sampling periods"),
    "CW044": ("error", "binding has no formula to compile"),
    "CW045": ("error", "division by the constant zero"),
    "CW046": ("error", "sampling period is not a positive whole number of nanoseconds"),
    "CW047": ("error", "formula reads no signal (a constant verdict)"),
    "CW048": ("error", "time window longer than 10^6 sampling periods"),
    "CW049": ("error", "`sum` window of more than 100 samples"),
    "CW050": ("warning", "a window reads no sample at the start, fixing the verdict there"),
    "CW051": ("error", "formula nested deeper than Python and rtamt can evaluate"),
}


def formula_finding(
    code: str, message: str, path: str, line: int = 0, col: int = 0, hint: str = ""
) -> Finding:
    """A finding with the registered severity of `code` (KeyError for an unknown code)."""
    severity, _title = FORMULA_CODES[code]
    return Finding(code, severity, message, path, line, col, hint)
