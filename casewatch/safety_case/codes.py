"""The registry of structural check codes (CW001-CW039, CW060-CW079) and a helper to build
findings from them.

Every code has a fixed severity and a one-line title; `docs/checks.md` documents the same table
with a fixing example per code. A retired code is never reused: delete its row's meaning only by
marking it retired here and in the docs. CW040-CW059 belong to the formula checks in `spec/`;
when CW001-CW039 were used up, the structural checks continued at CW060.
"""

from __future__ import annotations

from dataclasses import dataclass

from casewatch.safety_case.findings import Finding, Severity
from casewatch.safety_case.model import Mark


@dataclass(frozen=True)
class CheckCode:
    """One stable check code: what it means and how bad it is."""

    code: str
    severity: Severity
    title: str


_TABLE: tuple[tuple[str, Severity, str], ...] = (
    ("CW001", "error", "file cannot be read"),
    ("CW002", "error", "file is not valid UTF-8"),
    ("CW003", "error", "YAML syntax error"),
    ("CW004", "error", "top level is not a mapping of node ids (or the file is empty)"),
    ("CW005", "error", "duplicate key in a YAML mapping"),
    (
        "CW006",
        "error",
        "unsupported YAML construct (alias, explicit tag, complex key, deep nesting)",
    ),
    ("CW007", "error", "number in a YAML 1.1-only notation (1_000, 1:30, 0b101, 017)"),
    (
        "CW008",
        "error",
        "library contract or rule cannot be expanded (unknown entry or "
        "parameter, parameter out of range, undeclared signal)",
    ),
    ("CW009", "error", "ODD specification cannot be used (unreadable, malformed, misplaced)"),
    ("CW010", "error", "missing `module` block"),
    ("CW011", "warning", "no `monitor` block: a pure argument, nothing to judge at run time"),
    ("CW012", "error", "value of the wrong type or out of range"),
    ("CW013", "error", "unknown key"),
    ("CW014", "error", "missing required key"),
    ("CW016", "error", "malformed threshold"),
    ("CW015", "error", "malformed warning margin (`warn`): not a finite number above 0"),
    ("CW017", "error", "malformed duration"),
    (
        "CW018",
        "error",
        "binding of the wrong shape (`spi`: `signal` + `threshold` or `stl`; "
        "`contract`: `guarantee` or `use`; not both `spi` and `contract`)",
    ),
    ("CW019", "error", "invalid channel set"),
    ("CW020", "error", "unknown node type (id prefix)"),
    ("CW021", "error", "`spi` or `contract` on a node that is not a solution (Sn)"),
    ("CW022", "error", "`hazard` on a node that is not a counter-solution (CSn)"),
    ("CW023", "error", "`challenges` on a node that is not a counter node (CG, CSn)"),
    ("CW024", "error", "counter node without `challenges`"),
    ("CW025", "error", "invalid declared signal name"),
    ("CW026", "error", "`challenges` names a counter node"),
    ("CW027", "error", "`challenges` names a node that is not a goal"),
    ("CW028", "error", "module `uses` a file that cannot be used (missing, cyclic)"),
    ("CW029", "error", "node id defined in two modules"),
    ("CW030", "error", "dangling reference"),
    ("CW031", "error", "node references itself"),
    ("CW032", "error", "wrong `supportedBy` relation for the node types"),
    ("CW033", "error", "wrong `inContextOf` relation for the node types"),
    ("CW034", "error", "`supportedBy` cycle"),
    ("CW035", "error", "not exactly one root goal"),
    ("CW036", "error", "the root of the argument is not a goal"),
    ("CW037", "error", "node unreachable from the root goal"),
    ("CW038", "error", "node marked undeveloped but supported"),
    ("CW039", "warning", "goal or strategy without support, not marked undeveloped"),
    ("CW060", "warning", "a used module's own `monitor` block is ignored"),
    ("CW061", "warning", "a pure argument has more than one root (gsn2x only warns: C01)"),
    ("CW062", "error", "`challenges` names a relation the argument does not have"),
    (
        "CW063",
        "warning",
        "a key gsn2x does not read, close to one it does, is kept as a layer (a pure argument)",
    ),
    ("CW064", "warning", "a challenged relation is drawn but not judged at run time"),
    ("CW065", "error", "gsn2x `extends` that cannot be applied (module or element missing)"),
    ("CW066", "error", "`defeated` or `defeatedRelation` that nothing in the argument backs"),
    ("CW067", "error", "assurance claim point (`acp`) on an element the node is not linked to"),
    ("CW068", "warning", "a relation list names the same node twice"),
)

#: code -> CheckCode, in code order.
CODES: dict[str, CheckCode] = {c: CheckCode(c, s, t) for c, s, t in _TABLE}


def finding(
    code: str, message: str, path: str, mark: Mark | None = None, hint: str = ""
) -> Finding:
    """Build a finding with the registered severity of `code` (KeyError for an unknown code)."""
    entry = CODES[code]
    m = mark or Mark()
    return Finding(
        code=code,
        severity=entry.severity,
        message=message,
        path=m.path or path,
        line=m.line,
        col=m.col,
        hint=hint,
    )
