"""Time in formulas: bounds as whole sampling periods, look-back horizons, and a correct shift of
future formulas into past time (the suggestion the online causality check makes).

rtamt's discrete-time monitors count samples. A bound of `0.3s` at a period of `0.1s` means 3
samples, and a bound that is not a whole number of periods has no meaning there, so it is a
finding (CW043) rather than a silent rounding.
"""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction

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
    future_operators,
)


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
    if isinstance(node, Num | Signal):
        return 0
    if isinstance(node, Neg | Abs | Not | Next):
        return past_horizon(node.operand, period)
    if isinstance(node, Arith | Compare | BoolOp):
        return max(past_horizon(node.left, period), past_horizon(node.right, period))
    if isinstance(node, Prev):
        return 1 + past_horizon(node.operand, period)
    if isinstance(node, Sum):
        return _ticks(node.interval, period)[1] + past_horizon(node.operand, period)
    if isinstance(node, Window):
        inner = past_horizon(node.operand, period)
        if node.interval is None or node.op not in ("once", "historically"):
            return inner
        return _ticks(node.interval, period)[1] + inner
    if isinstance(node, Span):
        inner = max(past_horizon(node.left, period), past_horizon(node.right, period))
        if node.interval is None or node.op != "since":
            return inner
        return _ticks(node.interval, period)[1] + inner
    raise TypeError(node)


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

    def deepest(*depths: int | None) -> int | None:
        found = [d for d in depths if d is not None]
        return max(found) if found else None

    def shifted(depth: int | None, by: int) -> int | None:
        return None if depth is None else depth + by

    if isinstance(node, Num | Signal):
        return None
    if isinstance(node, Sum):
        return _ticks(node.interval, period)[1] + (_sum_depth(node.operand, period) or 0)
    if isinstance(node, Neg | Abs | Not):
        return _sum_depth(node.operand, period)
    if isinstance(node, Arith | Compare | BoolOp):
        return deepest(_sum_depth(node.left, period), _sum_depth(node.right, period))
    if isinstance(node, Prev | Next):
        return shifted(_sum_depth(node.operand, period), 1 if isinstance(node, Prev) else -1)
    if isinstance(node, Window):
        inner = _sum_depth(node.operand, period)
        if node.interval is None:
            return inner
        lo, hi = _ticks(node.interval, period)
        return shifted(inner, hi if node.op in ("once", "historically") else -lo)
    if isinstance(node, Span):
        inner = deepest(_sum_depth(node.left, period), _sum_depth(node.right, period))
        if node.interval is None:
            return inner
        lo, hi = _ticks(node.interval, period)
        if node.op == "since":
            return shifted(inner, hi)
        # until: the right operand from t + lo, the left from t
        return deepest(_sum_depth(node.left, period), shifted(_sum_depth(node.right, period), -lo))
    raise TypeError(node)


def future_depth(node: Node, period: Fraction) -> int:
    """Samples ahead of `t` the formula needs to be known at `t` (0 for a causal formula)."""
    if isinstance(node, Num | Signal | Compare | Arith | Neg | Abs | Sum):
        return 0  # terms have no future operators
    if isinstance(node, Not):
        return future_depth(node.operand, period)
    if isinstance(node, BoolOp):
        return max(future_depth(node.left, period), future_depth(node.right, period))
    if isinstance(node, Prev):
        return max(0, future_depth(node.operand, period) - 1)
    if isinstance(node, Next):
        return future_depth(node.operand, period) + 1
    if isinstance(node, Window):
        inner = future_depth(node.operand, period)
        lo, hi = _ticks(node.interval, period) if node.interval else (0, 0)
        if node.op in ("eventually", "always"):
            return hi + inner
        return max(0, inner - lo)
    if isinstance(node, Span):
        left, right = future_depth(node.left, period), future_depth(node.right, period)
        lo, hi = _ticks(node.interval, period) if node.interval else (0, 0)
        if node.op == "until":
            return hi + max(left, right)
        return max(left, right - lo)
    raise TypeError(node)


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
            op = "once" if formula.op == "eventually" else "historically"
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
    if isinstance(node, Compare):
        return 0
    if isinstance(node, Not | Prev):
        return future_reach(node.operand, period)
    if isinstance(node, Next):
        return 1 + future_reach(node.operand, period)
    if isinstance(node, Window):
        inner = future_reach(node.operand, period)
        if node.op in ("eventually", "always") and node.interval is not None:
            return _ticks(node.interval, period)[1] + inner
        return inner
    if isinstance(node, BoolOp | Span):
        inner = max(future_reach(node.left, period), future_reach(node.right, period))
        if isinstance(node, Span) and node.op == "until" and node.interval is not None:
            return _ticks(node.interval, period)[1] + inner
        return inner
    return 0


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
