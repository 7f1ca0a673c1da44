"""Parsing formula text into the typed AST of `spec/ast.py`, with errors that point at a column.

The grammar (`grammar.lark`, LALR) fixes precedence and associativity; this module then builds
typed nodes and checks sorts (a condition where a condition is needed, a number where a number
is needed), because a sort error is a user error that deserves a column, not a traceback.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from decimal import Decimal
from fractions import Fraction
from functools import cache
from importlib import resources
from typing import cast

from lark import Lark, Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from casewatch.errors import CasewatchError
from casewatch.safety_case.model import Mark
from casewatch.spec.ast import (
    FORMULA_TYPES,
    TERM_TYPES,
    Abs,
    Arith,
    BoolOp,
    Compare,
    Formula,
    Interval,
    Neg,
    Next,
    Node,
    Not,
    Num,
    Prev,
    Signal,
    Span,
    Sum,
    Term,
    Window,
)

#: What the user sees for each grammar terminal in "expected ..." lists.
_TERMINAL_WORDS: dict[str, str] = {
    "NUMBER": "a number",
    "NAME": "a signal name",
    "CMP": "a comparison (< <= > >= == !=)",
    "PLUS": "'+'",
    "MINUS": "'-'",
    "STAR": "'*'",
    "SLASH": "'/'",
    "LPAR": "'('",
    "RPAR": "')'",
    "LSQB": "'['",
    "RSQB": "']'",
    "COLON": "':'",
    "UNIT": "a unit (s or ms)",
    "AND": "'and'",
    "OR": "'or'",
    "IMPLIES": "'implies'",
    "NOT": "'not'",
    "SINCE": "'since'",
    "UNTIL": "'until'",
    "PREV": "'prev'",
    "NEXT": "'next'",
    "ONCE": "'once'",
    "HISTORICALLY": "'historically'",
    "EVENTUALLY": "'eventually'",
    "ALWAYS": "'always'",
    "ABS": "'abs'",
    "SUM": "'sum'",
    "$END": "the end of the formula",
}


@dataclass
class FormulaError(CasewatchError):
    """A formula that cannot be parsed or has the wrong sort; `col` is 1-based in the text."""

    message: str
    col: int
    text: str = ""
    line: int = 1  # 1-based line inside the formula text (multi-line YAML values)
    code: str = "CW040"  # CW051 for a formula nested too deeply

    def __str__(self) -> str:
        return f"column {self.col}: {self.message}"

    def yaml_position(self, mark: Mark) -> tuple[int, int]:
        """Where this error sits in the YAML file, given the formula value's `formula_mark`."""
        return yaml_position(mark, self.line, self.col)


#: Operators nested inside each other, at most (CW051). Python evaluates a formula, and rtamt
#: parses and evaluates it, recursively: a bound here, not the interpreter's stack, decides
#: (rtamt 0.4.10 runs out of stack near 200 nested `and`).
MAX_NESTING = 100
#: The same bound on the text rtamt receives (`parse_rtamt`), where an expanded `sum` nests two
#: levels per sample: rtamt 0.4.10 evaluates 150 nested `and` and fails at 172 levels (a sum
#: of 85 samples) with RecursionError.
MAX_RTAMT_NESTING = 150


def _check_nesting(tree: Tree, text: str, limit: int = MAX_NESTING) -> None:
    """Raise CW051 when the parse tree nests deeper than `limit` (counted without recursion:
    a 2001-term conjunction is 2000 levels deep)."""
    deepest, level = 0, [tree]
    while level:
        deepest += 1
        if deepest > limit + 1:
            raise FormulaError(
                f"the formula nests more than {limit} operators inside each other (a chain of "
                "`and` nests one level per term, a `sum` as rtamt receives it two per sample); "
                "split it over several nodes or shorten it",
                1,
                text,
                1,
                code="CW051",
            )
        level = [c for node in level for c in node.children if isinstance(c, Tree)]


@cache
def _parser() -> Lark:
    grammar = resources.files("casewatch.spec").joinpath("grammar.lark").read_text(encoding="utf-8")
    return Lark(grammar, parser="lalr", propagate_positions=True, maybe_placeholders=False)


def _expected(names: set[str] | frozenset[str]) -> str:
    words = sorted({_TERMINAL_WORDS.get(n, n.lower()) for n in names})
    return ", ".join(words)


def _line_col(text: str, pos: int) -> tuple[int, int]:
    """1-based line and column of character offset `pos`."""
    line = text.count("\n", 0, pos) + 1
    start = text.rfind("\n", 0, pos) + 1
    return line, pos - start + 1


def _syntax_error(text: str, exc: UnexpectedInput) -> FormulaError:
    if isinstance(exc, UnexpectedEOF) or (
        isinstance(exc, UnexpectedToken) and exc.token.type == "$END"
    ):
        expected: Iterable[str] = (
            getattr(exc, "expected", None) or getattr(exc, "accepts", None) or set()
        )
        line, col = _line_col(text, len(text.rstrip()))
        return FormulaError(
            f"formula ends too early; expected {_expected(set(expected))}", col, text, line
        )
    if isinstance(exc, UnexpectedCharacters):
        at = exc.pos_in_stream or 0
        line, col = _line_col(text, at)
        char = text[at]
        return FormulaError(f"unexpected character {char!r}", col, text, line)
    if isinstance(exc, UnexpectedToken):
        token = exc.token
        pos = token.start_pos if token.start_pos is not None else 0
        line, col = _line_col(text, pos)
        expected = exc.accepts or exc.expected
        return FormulaError(
            f"unexpected {str(token)!r}; expected {_expected(set(expected))}", col, text, line
        )
    return FormulaError(str(exc), 1, text)  # pragma: no cover - lark has no other kinds


def parse_formula(text: str) -> Formula:
    """Parse a condition (a formula whose robustness is judged). Raises `FormulaError`."""
    if not text.strip():
        raise FormulaError("empty formula; expected a condition such as 'els >= 0.6'", 1, text)
    try:
        tree = _parser().parse(text)
    except UnexpectedInput as exc:
        raise _syntax_error(text, exc) from None
    _check_nesting(tree, text)
    node = _Builder(text).build(tree)
    return _need_formula(node, tree, text)


def parse_rtamt(text: str, period: float) -> Formula:
    """Read back the rtamt text `spec.emit.to_rtamt` wrote (`CompiledFormula.rtamt`) as the
    formula rtamt evaluates, for the whole-log engine: `!==` is `!=`, and `prev` of a number
    (from an expanded `sum`) is `sum[p:p]` at the period `p`: the value one sample earlier,
    `+inf` at the first sample, as rtamt's `prev` of a real."""
    text = text.replace("!==", "!=")
    try:
        tree = _parser().parse(text)
    except UnexpectedInput as exc:
        raise _syntax_error(text, exc) from None
    _check_nesting(tree, text, MAX_RTAMT_NESTING)
    node = _Builder(text, term_prev=Fraction(repr(float(period)))).build(tree)
    return _need_formula(node, tree, text)


def parse_term(text: str) -> Term:
    """Parse a numeric expression (used for SPI signals written as expressions)."""
    try:
        tree = _parser().parse(text)
    except UnexpectedInput as exc:
        raise _syntax_error(text, exc) from None
    _check_nesting(tree, text)
    node = _Builder(text).build(tree)
    return _need_term(node, tree, text)


def _col_of(tree: Tree | Token, text: str) -> tuple[int, int]:
    if isinstance(tree, Token):
        pos = tree.start_pos or 0
    else:
        pos = getattr(tree.meta, "start_pos", 0) if not tree.meta.empty else 0
    return _line_col(text, pos)


def _need_formula(node: Node, tree: Tree | Token, text: str) -> Formula:
    if isinstance(node, FORMULA_TYPES):
        return cast(Formula, node)
    line, col = _col_of(tree, text)
    raise FormulaError(
        "expected a condition here (a comparison such as 'x >= 0.6', or a formula built from "
        "comparisons), found a numeric expression",
        col,
        text,
        line,
    )


def _need_term(node: Node, tree: Tree | Token, text: str) -> Term:
    if isinstance(node, TERM_TYPES):
        return cast(Term, node)
    line, col = _col_of(tree, text)
    raise FormulaError(
        "expected a number or signal here, found a condition; conditions combine with "
        "'and', 'or', 'not', not with arithmetic or comparisons",
        col,
        text,
        line,
    )


def _seconds(bound: Tree) -> Fraction:
    number = cast(Token, bound.children[0])
    value = Fraction(Decimal(str(number)))
    if len(bound.children) > 1 and str(bound.children[1]) == "ms":
        value /= 1000
    return value


class _Builder:
    """Turns the lark tree into typed nodes, checking sorts on the way."""

    def __init__(self, text: str, term_prev: Fraction | None = None):
        self.text = text
        self.term_prev = term_prev  # read `prev` of a number as `sum[p:p]` (parse_rtamt)

    def build(self, tree: Tree | Token) -> Node:
        if isinstance(tree, Token):  # pragma: no cover - every token sits under a rule
            raise FormulaError(f"unexpected {str(tree)!r}", _col_of(tree, self.text)[1], self.text)
        kids = tree.children
        rule = str(tree.data)
        if rule == "number":
            value = float(str(kids[0]))
            if not math.isfinite(value):
                line, col = _col_of(kids[0], self.text)
                raise FormulaError(f"number {str(kids[0])!r} is too large", col, self.text, line)
            return Num(value)
        if rule == "signal":
            token = cast(Token, kids[0])
            return Signal(str(token), col=_col_of(token, self.text)[1])
        if rule == "neg":
            return Neg(self.term(kids[1]))
        if rule == "abs_":
            return Abs(self.term(kids[0]))
        if rule == "sum_window":
            col = _col_of(kids[0], self.text)[1]
            return Sum(self.interval(kids[1]), self.term(kids[2]), col=col)
        if rule == "arith":
            op = str(kids[1])
            return Arith(op, self.term(kids[0]), self.term(kids[2]))  # type: ignore[arg-type]
        if rule == "compare":
            op = str(kids[1])
            return Compare(op, self.term(kids[0]), self.term(kids[2]))  # type: ignore[arg-type]
        if rule == "not_":
            return Not(self.formula(kids[0]))
        if rule in ("and_", "or_", "implies"):
            name = rule.rstrip("_")
            return BoolOp(name, self.formula(kids[0]), self.formula(kids[1]))  # type: ignore[arg-type]
        if rule == "prev":
            col = _col_of(kids[0], self.text)[1]
            operand = self.build(kids[1])
            if self.term_prev is not None and isinstance(operand, TERM_TYPES):
                one = Interval(self.term_prev, self.term_prev)
                return Sum(one, cast(Term, operand), col=col)
            return Prev(_need_formula(operand, kids[1], self.text), col=col)
        if rule == "next_":
            return Next(self.formula(kids[1]), col=_col_of(kids[0], self.text)[1])
        if rule == "window":
            op = str(kids[0])
            interval = self.interval(kids[1]) if len(kids) == 3 else None
            if interval is None and op in ("eventually", "always"):
                line, col = _col_of(kids[0], self.text)
                raise FormulaError(
                    f"'{op}' needs a bound, e.g. '{op}[0:1s]': casewatch monitors only bounded "
                    "future operators",
                    col,
                    self.text,
                    line,
                )
            col = _col_of(kids[0], self.text)[1]
            return Window(op, interval, self.formula(kids[-1]), col)  # type: ignore[arg-type]
        if rule == "span":
            op = str(kids[1])
            interval = self.interval(kids[2]) if len(kids) == 4 else None
            if interval is None and op == "until":
                line, col = _col_of(kids[1], self.text)
                raise FormulaError(
                    "'until' needs a bound, e.g. 'until[0:1s]': casewatch monitors only bounded "
                    "future operators",
                    col,
                    self.text,
                    line,
                )
            col = _col_of(kids[1], self.text)[1]
            left, right = self.formula(kids[0]), self.formula(kids[-1])
            return Span(op, interval, left, right, col)  # type: ignore[arg-type]
        raise FormulaError(f"unsupported construct {rule!r}", 1, self.text)  # pragma: no cover

    def term(self, tree: Tree | Token) -> Term:
        return _need_term(self.build(tree), tree, self.text)

    def formula(self, tree: Tree | Token) -> Formula:
        return _need_formula(self.build(tree), tree, self.text)

    def interval(self, tree: Tree | Token) -> Interval:
        tree = cast(Tree, tree)
        lo, hi = (_seconds(cast(Tree, b)) for b in tree.children)
        line, col = _col_of(tree, self.text)
        if lo > hi:
            raise FormulaError(
                f"empty interval: lower bound {float(lo):g}s is above upper bound {float(hi):g}s",
                col,
                self.text,
                line,
            )
        return Interval(lo, hi, col=col)


def yaml_position(mark: Mark, error_line: int, error_col: int) -> tuple[int, int]:
    """Map a 1-based (line, col) inside a formula to the YAML file, given the value's mark.

    Exact for single-line values (the usual `when: "..."` or `stl: ...`): line is the mark's
    line and the column is offset from where the value's text starts. For a block scalar the
    line is offset too and the column is the column within that line of the formula text.
    """
    if error_line <= 1:
        return mark.line, mark.col + error_col - 1
    return mark.line + error_line - 1, error_col
