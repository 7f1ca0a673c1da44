"""Time in formulas: bounds as whole sampling periods, look-back horizons, and a correct shift of
future formulas into past time (the suggestion the online causality check makes).

rtamt's discrete-time monitors count samples. A bound of `0.3s` at a period of `0.1s` means 3
samples, and a bound that is not a whole number of periods has no meaning there, so it is a
finding (CW043) rather than a silent rounding.
"""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction
from typing import TypeVar

from casewatch.spec.ast import (
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
    Window,
    WindowOpName,
    future_operators,
)
from casewatch.spec.visitor import Visitor

R = TypeVar("R")


def bound_ticks(seconds: Fraction, period: Fraction) -> int | None:
    """`seconds` in samples, or None when it is not a whole number of periods."""
    ticks = seconds / period
    return int(ticks) if ticks.denominator == 1 else None


def intervals_of(node: Node) -> list[Interval]:
    from casewatch.spec.ast import walk

    return [n.interval for n in walk(node) if isinstance(n, Window | Span | Sum) and n.interval]


def _ticks(interval: Interval, period: Fraction) -> tuple[int, int]:
    lo, hi = bound_ticks(interval.lo, period), bound_ticks(interval.hi, period)
    if lo is None or hi is None:
        raise ValueError(f"interval [{interval.lo}:{interval.hi}] is not whole periods")
    return lo, hi


def past_horizon(node: Node, period: Fraction) -> int:
    """Samples of history the formula reads at most (unbounded operators add nothing: they read
    from the start of the stream, which no warm-up can fill)."""
    return _PastHorizon(period).visit(node)


class _Pass(Visitor[R]):
    """A timing pass: the sampling period, and a node's bounds in samples."""

    def __init__(self, period: Fraction):
        self.period = period

    def ticks(self, interval: Interval) -> tuple[int, int]:
        return _ticks(interval, self.period)


class _PastHorizon(_Pass[int]):
    def visit_Num(self, node: Num | Signal) -> int:
        return 0

    visit_Signal = visit_Num

    def visit_Neg(self, node: Neg | Abs | Not | Next) -> int:
        return self.visit(node.operand)

    visit_Abs = visit_Not = visit_Next = visit_Neg

    def visit_Arith(self, node: Arith | Compare | BoolOp) -> int:
        return max(self.visit(node.left), self.visit(node.right))

    visit_Compare = visit_BoolOp = visit_Arith

    def visit_Prev(self, node: Prev) -> int:
        return 1 + self.visit(node.operand)

    def visit_Sum(self, node: Sum) -> int:
        return self.ticks(node.interval)[1] + self.visit(node.operand)

    def visit_Window(self, node: Window) -> int:
        inner = self.visit(node.operand)
        if node.interval is None or node.op not in ("once", "historically"):
            return inner
        return self.ticks(node.interval)[1] + inner

    def visit_Span(self, node: Span) -> int:
        inner = max(self.visit(node.left), self.visit(node.right))
        if node.interval is None or node.op != "since":
            return inner
        return self.ticks(node.interval)[1] + inner


def sum_warmup(node: Node, period: Fraction) -> int:
    """Samples after a (re)start during which some `sum` the formula reads has an incomplete
    window (a sample before the start, `+inf` in rtamt): the past depth of the deepest `sum`
    window end, where nested sums add and so do the operators around a sum (`prev`: 1,
    `once[a:b]`: b; a future operator's lower bound is credited). 0 without a `sum`.

    An unbounded past operator (`once`, `historically`, `since` without bound) adds nothing,
    as in `past_horizon`: it keeps reading the incomplete windows of the first samples for ever.
    """
    depth = _sum_depth(node, period)
    return max(0, depth) if depth is not None else 0


def _sum_depth(node: Node, period: Fraction) -> int | None:
    """How far before `t` the deepest `sum` window under `node` reaches (None: no `sum`)."""
    return _SumDepth(period).visit(node)


def _deepest(*depths: int | None) -> int | None:
    found = [d for d in depths if d is not None]
    return max(found) if found else None


def _shifted(depth: int | None, by: int) -> int | None:
    return None if depth is None else depth + by


class _SumDepth(_Pass[int | None]):
    def visit_Num(self, node: Num | Signal) -> int | None:
        return None

    visit_Signal = visit_Num

    def visit_Sum(self, node: Sum) -> int | None:
        return self.ticks(node.interval)[1] + (self.visit(node.operand) or 0)

    def visit_Neg(self, node: Neg | Abs | Not) -> int | None:
        return self.visit(node.operand)

    visit_Abs = visit_Not = visit_Neg

    def visit_Arith(self, node: Arith | Compare | BoolOp) -> int | None:
        return _deepest(self.visit(node.left), self.visit(node.right))

    visit_Compare = visit_BoolOp = visit_Arith

    def visit_Prev(self, node: Prev | Next) -> int | None:
        return _shifted(self.visit(node.operand), 1 if isinstance(node, Prev) else -1)

    visit_Next = visit_Prev

    def visit_Window(self, node: Window) -> int | None:
        inner = self.visit(node.operand)
        if node.interval is None:
            return inner
        lo, hi = self.ticks(node.interval)
        return _shifted(inner, hi if node.op in ("once", "historically") else -lo)

    def visit_Span(self, node: Span) -> int | None:
        inner = _deepest(self.visit(node.left), self.visit(node.right))
        if node.interval is None:
            return inner
        lo, hi = self.ticks(node.interval)
        if node.op == "since":
            return _shifted(inner, hi)
        # until: the right operand from t + lo, the left from t
        return _deepest(self.visit(node.left), _shifted(self.visit(node.right), -lo))


def future_depth(node: Node, period: Fraction) -> int:
    """Samples ahead of `t` the formula needs to be known at `t` (0 for a causal formula)."""
    return _FutureDepth(period).visit(node)


class _FutureDepth(_Pass[int]):
    def visit_Num(self, node: Num | Signal | Compare | Arith | Neg | Abs | Sum) -> int:
        return 0  # terms have no future operators

    visit_Signal = visit_Compare = visit_Arith = visit_Neg = visit_Abs = visit_Sum = visit_Num

    def visit_Not(self, node: Not) -> int:
        return self.visit(node.operand)

    def visit_BoolOp(self, node: BoolOp) -> int:
        return max(self.visit(node.left), self.visit(node.right))

    def visit_Prev(self, node: Prev) -> int:
        return max(0, self.visit(node.operand) - 1)

    def visit_Next(self, node: Next) -> int:
        return self.visit(node.operand) + 1

    def visit_Window(self, node: Window) -> int:
        inner = self.visit(node.operand)
        lo, hi = self.ticks(node.interval) if node.interval else (0, 0)
        if node.op in ("eventually", "always"):
            return hi + inner
        return max(0, inner - lo)

    def visit_Span(self, node: Span) -> int:
        left, right = self.visit(node.left), self.visit(node.right)
        lo, hi = self.ticks(node.interval) if node.interval else (0, 0)
        if node.op == "until":
            return hi + max(left, right)
        return max(left, right - lo)


def _interval(lo: int, hi: int, period: Fraction) -> Interval:
    return Interval(Fraction(lo) * period, Fraction(hi) * period)


def delay(formula: Formula, ticks: int, period: Fraction) -> Formula | None:
    """A past-time formula whose value at `t` is `formula`'s value at `t - ticks`.

    Returns None when no such formula is found for this `ticks` (below `future_reach` some
    shapes need more delay; `until` has no single past operator); `past_form` picks the delay.
    This is the shift rtamt's `pastify()` gets wrong: it shifts a predicate beside a bounded
    future operator twice.
    """
    if ticks < future_depth(formula, period):
        return None
    if not future_operators(formula):
        return delay_past(formula, ticks, period)
    if isinstance(formula, Not):
        inner = delay(formula.operand, ticks, period)
        return None if inner is None else Not(inner)
    if isinstance(formula, BoolOp):
        left, right = delay(formula.left, ticks, period), delay(formula.right, ticks, period)
        return None if left is None or right is None else BoolOp(formula.op, left, right)
    if isinstance(formula, Next):
        return delay(formula.operand, ticks - 1, period)
    if isinstance(formula, Prev):
        return delay(formula.operand, ticks + 1, period)
    if isinstance(formula, Window):
        # the operand judged late by the least delay that has a past form: its depth, or
        # (a `since` whose lower bound credits a `next`, say) its reach
        for h in sorted(
            {future_depth(formula.operand, period), future_reach(formula.operand, period)}
        ):
            shifted = delay(formula.operand, h, period)
            if shifted is not None:
                break
        else:
            return None
        lo, hi = _ticks(formula.interval, period) if formula.interval else (0, 0)
        e = ticks - h
        if e + lo < 0:
            return None
        if formula.op in ("eventually", "always"):
            op: WindowOpName = "once" if formula.op == "eventually" else "historically"
            return Window(op, _interval(e - hi, e - lo, period), shifted)
        if formula.interval is None:  # unbounded past of a future formula: shift the whole
            return delay_past(Window(formula.op, None, shifted), e, period)
        return Window(formula.op, _interval(e + lo, e + hi, period), shifted)
    if isinstance(formula, Span) and formula.op == "since":
        h = max(future_depth(formula.left, period), future_depth(formula.right, period))
        left, right = delay(formula.left, h, period), delay(formula.right, h, period)
        if left is None or right is None or ticks < h:
            return None
        return delay_past(replace(formula, left=left, right=right), ticks - h, period)
    return None


def future_reach(node: Node, period: Fraction) -> int:
    """Like `future_depth` but never crediting `prev` or a window's lower bound: a delay of at
    least this many samples always has a past-time form (see `past_form`)."""
    return _FutureReach(period).visit(node)


class _FutureReach(_Pass[int]):
    def generic_visit(self, node: Node, *args: object) -> int:
        return 0  # a comparison and the terms under it look no further than `t`

    def visit_Not(self, node: Not | Prev) -> int:
        return self.visit(node.operand)

    visit_Prev = visit_Not

    def visit_Next(self, node: Next) -> int:
        return 1 + self.visit(node.operand)

    def visit_Window(self, node: Window) -> int:
        inner = self.visit(node.operand)
        if node.op in ("eventually", "always") and node.interval is not None:
            return self.ticks(node.interval)[1] + inner
        return inner

    def visit_BoolOp(self, node: BoolOp | Span) -> int:
        inner = max(self.visit(node.left), self.visit(node.right))
        if isinstance(node, Span) and node.op == "until" and node.interval is not None:
            return self.ticks(node.interval)[1] + inner
        return inner

    visit_Span = visit_BoolOp


def past_form(formula: Formula, period: Fraction) -> tuple[Formula, int] | None:
    """The causal formula judging `formula` late, and by how many samples (shortest found).

    None when `formula` uses `until` over future operands (no single past operator for it).
    """
    for ticks in sorted({future_depth(formula, period), future_reach(formula, period)}):
        shifted = delay(formula, ticks, period)
        if shifted is not None:
            return shifted, ticks
    return None


def delay_past(formula: Formula, ticks: int, period: Fraction) -> Formula:
    """Shift a causal formula `ticks` samples into the past."""
    if ticks == 0:
        return formula
    return Window("once", _interval(ticks, ticks, period), formula)
