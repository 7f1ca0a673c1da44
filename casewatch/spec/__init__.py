"""Compiling SPI and hazard bindings into STL formulas that rtamt evaluates correctly.

Public entry points: `compile_case` / `check_formulas` (spec.compiler), `parse_formula` /
`FormulaError` (spec.parser), `build_rtamt_monitor` (spec.emit). See `docs/formulas.md`.
"""

from casewatch.spec.compiler import check_formulas, compile_case
from casewatch.spec.emit import build_rtamt_monitor, to_rtamt, to_text
from casewatch.spec.parser import FormulaError, parse_formula

__all__ = [
    "FormulaError",
    "build_rtamt_monitor",
    "check_formulas",
    "compile_case",
    "parse_formula",
    "to_rtamt",
    "to_text",
]
