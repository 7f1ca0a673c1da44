"""Emitting formulas as text: our canonical syntax, and rtamt 0.4.10 text with its fences.

rtamt 0.4.10 gives wrong answers or rejects valid text in a few reproducible ways (see
`docs/formulas.md`, "rtamt fences", and `tests/spec/test_emit.py` which shows each one). The
rtamt emitter therefore never relies on rtamt's precedence or associativity:

- every binary operation is parenthesised: rtamt parses `x / 2 * 4` as `x / (2 * 4)`,
  `x - y + z` as `x - (y + z)` and `a implies b implies c` left-associatively;
- a number right of a binary minus is wrapped, `(x - (1.0))`: rtamt rejects `x - 1`
  ("Attempting full context" ambiguity error), `abs(x) - 1` and `x - 1 + 1` alike;
- unary minus on anything but a number is `(0.0 - e)`: rtamt has no unary minus, only signed
  literals;
- `!=` is rtamt's `!==`;
- bounds are emitted as exact decimal seconds, a whole number of sampling periods, and the
  monitor's period is set as an exact fraction, so rtamt's own "multiple of the sampling period"
  test (done in exact fractions) cannot trip on binary rounding;
- a repeated stateful subformula (`prev`, `once`, `historically`, `since`) is made textually
  unique: rtamt keys operator state by the printed subformula and would update a shared one
  twice per sample;
- `pastify()` is never called (it shifts a predicate twice beside a bounded future operator);
- rtamt has no windowed sum: `sum[a:b](e)` is expanded with `prev` on the term, nested
  (Horner form) so that each of its `b` `prev` operators has a different text:
  `sum[0:0.2](e)` is `(e + (prev (e + (prev e))))`, and `sum[0.1:0.2](e)` is
  `(prev (e + (prev e)))`. A flat `e + prev e + prev prev e` would repeat `prev e` (shared
  state, see below) and need O(n^2) operators.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from decimal import Decimal, localcontext
from fractions import Fraction
from typing import Any

from casewatch.safety_case.numbers import number_text
from casewatch.spec.ast import (
    Abs,
    Arith,
    BoolOp,
    Compare,
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
    Window,
)
from casewatch.spec.model import CompiledFormula
from casewatch.spec.timing import bound_ticks
from casewatch.spec.visitor import Visitor

#: Name of the output variable every built monitor declares.
OUTPUT_VAR = "robustness"


def period_fraction(period: float) -> Fraction:
    """The sampling period as the exact decimal the user wrote (0.1 is 1/10, not 0x3FB999...)."""
    return Fraction(repr(float(period)))


def decimal_text(value: Fraction) -> str:
    """Exact decimal text of a fraction whose denominator is 2^a 5^b (every bound here is)."""
    with localcontext() as ctx:
        ctx.prec = 60
        dec = (Decimal(value.numerator) / Decimal(value.denominator)).normalize()
    text = format(dec, "f")
    return text


def _seconds_text(value: Fraction) -> str:
    return decimal_text(value) + "s"


def interval_text(interval: Interval) -> str:
    return f"[{_seconds_text(interval.lo)}:{_seconds_text(interval.hi)}]"


# ---- our canonical syntax ---------------------------------------------------------------


def to_text(node: Node) -> str:
    """Fully parenthesised text in casewatch's own syntax; `parse_formula` reads it back equal."""
    return _TextWriter().visit(node)


class _TextWriter(Visitor[str]):
    """casewatch's canonical syntax, one case per node class."""

    def visit_Num(self, node: Num) -> str:
        return number_text(node.value)

    def visit_Signal(self, node: Signal) -> str:
        return node.name

    def visit_Neg(self, node: Neg) -> str:
        return f"(-{self.visit(node.operand)})"

    def visit_Abs(self, node: Abs) -> str:
        return f"abs({self.visit(node.operand)})"

    def visit_Sum(self, node: Sum) -> str:
        return f"sum{interval_text(node.interval)}({self.visit(node.operand)})"

    def visit_Arith(self, node: Arith | Compare | BoolOp) -> str:
        return f"({self.visit(node.left)} {node.op} {self.visit(node.right)})"

    visit_Compare = visit_BoolOp = visit_Arith

    def visit_Not(self, node: Not) -> str:
        return f"(not {self.visit(node.operand)})"

    def visit_Prev(self, node: Prev | Next) -> str:
        word = "prev" if isinstance(node, Prev) else "next"
        return f"({word} {self.visit(node.operand)})"

    visit_Next = visit_Prev

    def visit_Window(self, node: Window) -> str:
        bounds = interval_text(node.interval) if node.interval else ""
        return f"({node.op}{bounds} {self.visit(node.operand)})"

    def visit_Span(self, node: Span) -> str:
        bounds = interval_text(node.interval) if node.interval else ""
        return f"({self.visit(node.left)} {node.op}{bounds} {self.visit(node.right)})"


# ---- rtamt 0.4.10 text -------------------------------------------------------------------


def to_rtamt(node: Node, period: Fraction | None = None) -> str:
    """Canonical rtamt text with every fence applied (see the module docstring).

    `period` (exact seconds, `period_fraction`) is needed only by a `sum`, whose window is
    expanded sample by sample; a formula with a `sum` and no period is a `ValueError`."""
    return _RtamtEmitter(period).emit(node)


def sum_ticks(node: Sum, period: Fraction | None) -> tuple[int, int]:
    """The window `[a:b]` of a `sum` in samples (ValueError without a period or when a bound is
    not a whole number of periods, which the compiler reports as CW043 first)."""
    if period is None:
        raise ValueError(f"{to_text(node)} needs the sampling period to be expanded for rtamt")
    lo, hi = bound_ticks(node.interval.lo, period), bound_ticks(node.interval.hi, period)
    if lo is None or hi is None:
        raise ValueError(f"{to_text(node)}: a bound is not a whole number of periods")
    return lo, hi


class _RtamtEmitter(Visitor[str]):
    """One emission: remembers the stateful subformulas already written.

    rtamt 0.4.10 keeps the state of each temporal operator under the operator's printed name,
    so two equal subformulas (`prev (x >= 1) and prev (x >= 1)`) share one state that is
    updated twice per sample: the second reads the sample just written. The fence writes a
    repeated stateful subformula with its operand as `not (not ...)` (same robustness,
    different name) as many times as needed to make every stateful name unique. A repeated
    `prev` of a term (from `sum` expansions) gets its operand as `(... * 1.0)` instead: exact
    for every float, infinities and -0.0 included.
    """

    def __init__(self, period: Fraction | None = None) -> None:
        self.stateful: set[str] = set()
        self.period = period

    def emit(self, node: Node) -> str:
        return self.visit(node)

    def visit_Num(self, node: Num) -> str:
        return number_text(node.value)

    def visit_Signal(self, node: Signal) -> str:
        return node.name

    def visit_Neg(self, node: Neg) -> str:
        if isinstance(node.operand, Num):
            # fence: rtamt only knows signed literals; the parentheses keep `x - (-1.0)` legal
            return f"(-{number_text(node.operand.value)})"
        return f"(0.0 - {self.visit(node.operand)})"

    def visit_Abs(self, node: Abs) -> str:
        return f"abs({self.visit(node.operand)})"

    def visit_Sum(self, node: Sum) -> str:
        return self._sum(node)

    def visit_Arith(self, node: Arith) -> str:
        right = self.visit(node.right)
        if node.op == "-" and isinstance(node.right, Num):
            right = f"({right})"  # fence: `x - 1` does not parse in rtamt 0.4.10
        return f"({self.visit(node.left)} {node.op} {right})"

    def visit_Compare(self, node: Compare) -> str:
        op = "!==" if node.op == "!=" else node.op
        return f"({self.visit(node.left)} {op} {self.visit(node.right)})"

    def visit_Not(self, node: Not) -> str:
        return f"(not {self.visit(node.operand)})"

    def visit_BoolOp(self, node: BoolOp) -> str:
        return f"({self.visit(node.left)} {node.op} {self.visit(node.right)})"

    def visit_Prev(self, node: Prev | Next) -> str:
        word = "prev" if isinstance(node, Prev) else "next"
        return self._unique(lambda operand: f"({word} {operand})", self.visit(node.operand))

    visit_Next = visit_Prev

    def visit_Window(self, node: Window) -> str:
        bounds = interval_text(node.interval) if node.interval else ""
        return self._unique(
            lambda operand: f"({node.op}{bounds} {operand})", self.visit(node.operand)
        )

    def visit_Span(self, node: Span) -> str:
        bounds = interval_text(node.interval) if node.interval else ""
        left = self.visit(node.left)
        return self._unique(
            lambda operand: f"({left} {node.op}{bounds} {operand})", self.visit(node.right)
        )

    def _unique(self, shape: Callable[[str], str], operand: str, term: bool = False) -> str:
        text = shape(operand)
        while text in self.stateful:
            operand = f"({operand} * 1.0)" if term else f"(not (not {operand}))"
            text = shape(operand)
        self.stateful.add(text)
        return text

    def _sum(self, node: Sum) -> str:
        """`sum[a:b](e)` as `prev`s of `e + prev(e + prev(...))`: the value at `t` is
        `e(t-a) + (e(t-a-1) + (... + e(t-b)))`, and `+inf` once a `prev` reaches before the
        first sample (rtamt's `prev` of a real at the first sample). Each copy of `e` is
        emitted afresh, so stateful operators inside it (a nested `sum`) get unique names."""
        lo, hi = sum_ticks(node, self.period)
        text = self.emit(node.operand)
        for _ in range(hi - lo):
            inner = self._unique(lambda operand: f"(prev {operand})", text, term=True)
            text = f"({self.emit(node.operand)} + {inner})"
        for _ in range(lo):
            text = self._unique(lambda operand: f"(prev {operand})", text, term=True)
        return text


def new_rtamt_spec(text: str, variables: list[str], period: float) -> Any:
    """A parsed rtamt discrete-time specification `robustness = text` over float `variables`.

    The sampling period is passed as an exact fraction of seconds so bounds written as exact
    decimals divide evenly (rtamt checks this in fractions). rtamt's discrete-time monitors
    count samples; the timestamps given to `update` only feed its sampling-violation counter.
    """
    import warnings

    import rtamt

    spec = rtamt.StlDiscreteTimeSpecification()
    for name in variables:
        spec.declare_var(name, "float")
    spec.declare_var(OUTPUT_VAR, "float")
    spec.set_var_io_type(OUTPUT_VAR, "output")
    spec.set_sampling_period(period_fraction(period), "s", 0.1)
    spec.spec = f"{OUTPUT_VAR} = {text}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rtamt warns about undeclared io types; not ours
        spec.parse()
    _single_children(spec.ast)
    _ieee_division()
    return spec


def _ieee_division() -> None:
    """rtamt 0.4.10 divides with Python's `/`, which raises ZeroDivisionError when a divisor
    signal reaches 0 at run time (`els / (els - els)`: CW045 only refuses the constant 0). The
    numpy engine divides as IEEE 754 does (x / 0 = +-inf, 0 / 0 = NaN, a tick without a verdict
    in evaluator.core); rtamt's division operation is given the same rule, once."""
    from rtamt.semantics.arithmetic.discrete_time.online import division_operation

    operation = division_operation.DivisionOperation
    if getattr(operation, "_casewatch_ieee", False):
        return

    def update(self: Any, left: float, right: float) -> float:
        try:
            return left / right
        except ZeroDivisionError:
            if left == 0 or math.isnan(left):
                return math.nan
            return math.copysign(math.inf, left) * math.copysign(1.0, right)

    operation.update = update  # type: ignore[method-assign]
    operation._casewatch_ieee = True  # type: ignore[attr-defined]


def _single_children(ast: Any) -> None:
    """rtamt 0.4.10's `Addition` and `Xor` nodes add their two children twice, and `Neg` (`not`)
    its one child twice (the base constructor and their own), and the visitors that build and
    reset the online operators visit every child: a `sum` expanded into nested `x + (prev ...)`
    then costs 2^samples at the first update and at every reset (a 20-sample sum: 13 s), and
    so do nested `not`. Evaluation reads only the first children, so dropping the repeats
    changes no value; without this fence the rtamt engine hangs on formulas the checks allow."""
    from rtamt.syntax.node.unary_node import UnaryNode

    stack = list(getattr(ast, "specs", []))
    seen: set[int] = set()
    while stack:
        node = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        children = getattr(node, "children", None)
        if not isinstance(children, list):
            continue
        if len(children) == 4 and children[2] is children[0] and children[3] is children[1]:
            del children[2:]
        elif isinstance(node, UnaryNode) and len(children) == 2 and children[1] is children[0]:
            del children[1:]
        stack.extend(children)


def build_rtamt_monitor(formula: CompiledFormula, period: float) -> Any:
    """A ready rtamt online monitor for one compiled formula (call `update(t, [(name, v)...])`).

    `period` must be the compiled spec's period: bounds in `formula.rtamt` are whole multiples
    of it. Inputs are the formula's signals, declared as floats; the output is `robustness`.

    Two fences against rtamt's per-update overhead, both on this instance only and neither
    changing a value:

    - rtamt counts "sampling violations" on every update by comparing timestamp differences
      with the period in `Fraction` arithmetic, which costs about 30 % of an update. casewatch
      never reads that counter: the evaluator feeds exactly one update per sample and resets
      the monitor after any gap, so the counter is switched off.
    - rtamt's predicate operation looks its comparison operator up through a dozen enum
      attribute reads on every sample. Each predicate gets the one subtraction its operator
      means (`a >= b`: a - b; `a <= b`: b - a; `a == b`: -|a - b|; `a !== b`: |a - b|),
      chosen once here. The operators are built eagerly for that, which also lets `reset()`
      work before the first update.

    Returns rtamt's discrete-time online interpreter, which has the interface the evaluator
    uses: `update(timestamp, [(name, value), ...])` -> robustness, and `reset()`.
    """
    spec = new_rtamt_spec(formula.rtamt, list(formula.signals), period)
    interpreter = spec.online_interpreter
    interpreter.update_sampling_violation_counter = _ignore_sampling
    interpreter.set_ast(spec.ast)
    _direct_predicates(interpreter.online_operator_dict)
    # The interpreter itself: the specification's `update` only forwards to it, after type
    # checks that cost a microsecond per call.
    return interpreter


def _direct_predicates(operators: dict[str, Any]) -> None:
    """Give every rtamt discrete-time predicate operation its robustness arithmetic directly
    (see build_rtamt_monitor). Same arithmetic as rtamt's `PredicateOperation.update`."""
    from rtamt.semantics.enumerations.comp_oper import StlComparisonOperator as Op
    from rtamt.semantics.stl.discrete_time.online.predicate_operation import PredicateOperation

    # Keyed by the operator's value, as rtamt compares them: it has two enum classes of that
    # name (the parser's and the semantics'), with the same values.
    arithmetic: dict[int, Callable[[float, float], float]] = {
        Op.GEQ.value: operator.sub,
        Op.GREATER.value: operator.sub,
        Op.LEQ.value: _right_minus_left,
        Op.LESS.value: _right_minus_left,
        Op.EQ.value: _minus_distance,
        Op.NEQ.value: _distance,
    }
    for op in operators.values():
        if type(op) is PredicateOperation:
            op.update = arithmetic[op.comparison_op.value]


def _right_minus_left(left: float, right: float) -> float:
    return right - left


def _minus_distance(left: float, right: float) -> float:
    return -abs(left - right)


def _distance(left: float, right: float) -> float:
    return abs(left - right)


def _ignore_sampling(duration: object) -> None:
    """Replaces rtamt's per-update sampling-violation bookkeeping (see build_rtamt_monitor)."""
