"""A plain-Python reference evaluator of formula robustness over a finite trace.

Written for clarity, not speed: it exists so tests can check rtamt's answers against an
independent reading of the semantics. It follows rtamt 0.4.10's discrete-time definitions
exactly, including its edges (checked operator by operator against rtamt's online operations):

- `a >= b`, `a > b` -> `a - b`; `a <= b`, `a < b` -> `b - a` (strict and non-strict agree);
- `a == b` -> `-|a - b|`; `a != b` -> `|a - b|`;
- `not` -> negation; `and`/`or` -> min/max; `a implies b` -> `max(-a, b)`;
- `prev f` at the first sample -> `+inf`;
- `sum[a:b](e)` at `t` -> `e(t-a) + (e(t-a-1) + (... + e(t-b)))`, a missing sample (before the
  first) counting `+inf` (rtamt's `prev` of a real; `spec.emit` expands it so, in this order);
- `once[a:b] f` at `t` -> max of `f` over samples `t-b .. t-a` that exist, `-inf` if none;
  `historically` the min, `+inf` if none; unbounded forms run from the first sample;
- `l since[a:b] r` at `t` -> max over samples `s` in `t-b .. t-a` of
  `min(r(s), min of l over s+1 .. t)` (missing samples: r = -inf);
- future operators see the trace end as missing samples (eventually/until: -inf,
  always: +inf, next: -inf). rtamt's offline evaluator fills the end differently (`next` at
  the last sample is +inf); the two agree on every sample whose look-ahead lies inside the
  trace (tested), and verdicts closer to the end are incomplete either way.

Time is counted in samples: a bound of `b` seconds at period `p` is `b / p` samples.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from casewatch.spec.ast import (
    Abs,
    Arith,
    BoolOp,
    Compare,
    Formula,
    Interval,
    Neg,
    Next,
    Not,
    Num,
    Prev,
    Signal,
    Span,
    Sum,
    Term,
    Window,
)
from casewatch.spec.emit import period_fraction
from casewatch.spec.visitor import Visitor

INF = math.inf


class ReferenceEvaluator(Visitor[float]):
    """Robustness of a formula at every sample of a trace (dict of equal-length lists)."""

    def __init__(self, trace: Mapping[str, Sequence[float]], period: float):
        lengths = {len(v) for v in trace.values()}
        if len(lengths) > 1:
            raise ValueError(f"trace signals have different lengths: {sorted(lengths)}")
        self.trace = trace
        self.n = lengths.pop() if lengths else 0
        self.period = period_fraction(period)
        self._memo: dict[tuple[int, int], float] = {}

    def _ticks(self, interval: Interval | None) -> tuple[int, int | None]:
        if interval is None:
            return 0, None
        lo, hi = interval.lo / self.period, interval.hi / self.period
        if lo.denominator != 1 or hi.denominator != 1:
            raise ValueError("interval bound is not a whole number of sampling periods")
        return int(lo), int(hi)

    def term(self, node: Term, t: int) -> float:
        return self.visit(node, t)

    def robustness(self, node: Formula, t: int) -> float:
        key = (id(node), t)
        if key not in self._memo:
            self._memo[key] = self.visit(node, t)
        return self._memo[key]

    # -- terms: their value at sample t -----------------------------------------------------

    def visit_Num(self, node: Num, t: int) -> float:
        return node.value

    def visit_Signal(self, node: Signal, t: int) -> float:
        return float(self.trace[node.name][t])

    def visit_Neg(self, node: Neg, t: int) -> float:
        return -self.term(node.operand, t)

    def visit_Abs(self, node: Abs, t: int) -> float:
        return abs(self.term(node.operand, t))

    def visit_Arith(self, node: Arith, t: int) -> float:
        a, b = self.term(node.left, t), self.term(node.right, t)
        if node.op == "+":
            return a + b
        if node.op == "-":
            return a - b
        if node.op == "*":
            return a * b
        return a / b

    def visit_Sum(self, node: Sum, t: int) -> float:
        lo, hi = self._ticks(node.interval)
        assert hi is not None
        total = INF if t - hi < 0 else self.term(node.operand, t - hi)
        for k in range(hi - 1, lo - 1, -1):
            total = (INF if t - k < 0 else self.term(node.operand, t - k)) + total
        return total

    # -- formulas: their robustness at sample t ---------------------------------------------

    def visit_Compare(self, node: Compare, t: int) -> float:
        a, b = self.term(node.left, t), self.term(node.right, t)
        if node.op in (">=", ">"):
            return a - b
        if node.op in ("<=", "<"):
            return b - a
        if node.op == "==":
            return -abs(a - b)
        return abs(a - b)

    def visit_Not(self, node: Not, t: int) -> float:
        return -self.robustness(node.operand, t)

    def visit_BoolOp(self, node: BoolOp, t: int) -> float:
        a, b = self.robustness(node.left, t), self.robustness(node.right, t)
        if node.op == "and":
            return min(a, b)
        if node.op == "or":
            return max(a, b)
        return max(-a, b)

    def visit_Prev(self, node: Prev, t: int) -> float:
        return INF if t == 0 else self.robustness(node.operand, t - 1)

    def visit_Next(self, node: Next, t: int) -> float:
        return -INF if t + 1 >= self.n else self.robustness(node.operand, t + 1)

    def visit_Window(self, node: Window, t: int) -> float:
        return self._window(node, t)

    def visit_Span(self, node: Span, t: int) -> float:
        return self._span(node, t)

    def _window(self, node: Window, t: int) -> float:
        lo, hi = self._ticks(node.interval)
        if node.op in ("once", "historically"):
            first = 0 if hi is None else max(0, t - hi)
            samples = range(first, t - lo + 1)
        else:
            assert hi is not None
            samples = range(t + lo, min(t + hi, self.n - 1) + 1)
        values = [self.robustness(node.operand, s) for s in samples]
        if node.op in ("once", "eventually"):
            return max(values, default=-INF)
        return min(values, default=INF)

    def _span(self, node: Span, t: int) -> float:
        lo, hi = self._ticks(node.interval)
        best = -INF
        if node.op == "since":
            first = 0 if hi is None else max(0, t - hi)
            for s in range(first, t - lo + 1):
                left = min(
                    (self.robustness(node.left, u) for u in range(s + 1, t + 1)), default=INF
                )
                best = max(best, min(self.robustness(node.right, s), left))
            return best
        assert hi is not None
        for s in range(t + lo, min(t + hi, self.n - 1) + 1):
            left = min((self.robustness(node.left, u) for u in range(t, s)), default=INF)
            best = max(best, min(self.robustness(node.right, s), left))
        return best

    def series(self, formula: Formula) -> list[float]:
        """Robustness at every sample, first to last."""
        return [self.robustness(formula, t) for t in range(self.n)]


def reference_robustness(
    formula: Formula, trace: Mapping[str, Sequence[float]], period: float
) -> list[float]:
    """Robustness of `formula` at every sample of `trace` (see the module docstring)."""
    return ReferenceEvaluator(trace, period).series(formula)


def reference_verdicts(
    formula: Formula,
    trace: Mapping[str, Sequence[float]],
    period: float,
    warmup_ticks: int = 0,
    persist_ticks: int = 0,
) -> list[float]:
    """The value the evaluator judges at every sample, NaN where it has no verdict, by the
    rules of docs/results.md and docs/formulas.md written out plainly: a sample where an input
    is not a finite number is a gap; every run of samples between gaps is evaluated as a trace
    of its own (the monitor restarts); its first `warmup_ticks` samples have no verdict (a
    `sum` window filling); and a violation (negative) at its first `persist_ticks` samples has
    none either, because it has not yet lasted an SPI's `for:` of data."""
    names = sorted(trace)
    n = len(trace[names[0]]) if names else 0
    present = [all(math.isfinite(trace[k][i]) for k in names) for i in range(n)]
    out = [math.nan] * n
    i = 0
    while i < n:
        if not present[i]:
            i += 1
            continue
        end = i
        while end < n and present[end]:
            end += 1
        segment = {k: list(trace[k][i:end]) for k in names}
        for k, value in enumerate(ReferenceEvaluator(segment, period).series(formula)):
            settled = k >= warmup_ticks and (value >= 0 or k >= persist_ticks)
            out[i + k] = value if settled else math.nan
        i = end
    return out
