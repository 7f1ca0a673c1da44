"""Samples after a (re)start at which a formula's verdict is fixed before any data is read.

rtamt's past windows read only the samples that exist (docs/formulas.md, robustness table):
`once[a:b] p` with `a > 0` reads no sample during the first `a` after the start of a stream
and after every monitor reset (a data gap), and is `-inf` there, violated whatever the data;
`historically[a:b]` is `+inf`, `p since[a:b] q` is `-inf`, and `prev p` is `+inf` at the
first sample. `vacant_ticks` finds the samples at which the monitored formula is `-inf` for
this reason alone, so `check` can warn (CW050) before a run reports them as violations (an
SPI) or as the hazard being present (a hazard).

The analysis is three-valued per sample: `-inf`, `+inf` (fixed by missing samples) or `None`
(it depends on the data). Comparisons and terms depend on the data; a `sum` still filling is
the evaluator's warm-up (no data), not a verdict, so it is read as depending on the data too.
"""

from __future__ import annotations

from fractions import Fraction

from casewatch.spec.ast import (
    BoolOp,
    Node,
    Not,
    Prev,
    Span,
    Window,
)
from casewatch.spec.timing import bound_ticks
from casewatch.spec.visitor import Visitor

INF = float("inf")

#: Samples examined after a restart; a vacancy longer than this is reported as this long.
MAX_EXAMINED = 2000

Fixed = float | None  # -inf, +inf, or None (depends on the data)


def vacant_ticks(node: Node, period: Fraction) -> list[int]:
    """The samples (0 = the first after a restart) at which `node` is `-inf` whatever the data,
    up to `MAX_EXAMINED`; [] when there is none (or a bound is not whole periods)."""
    try:
        analysis = _Vacancy(period)
        reach = min(analysis.reach(node), MAX_EXAMINED)
        return [k for k in range(reach) if analysis.value(node, k) == -INF]
    except _NotWhole:
        return []


class _NotWhole(Exception):
    """A bound is not a whole number of periods (CW043 reports it)."""


class _Vacancy:
    def __init__(self, period: Fraction):
        self.period = period
        self._memo: dict[tuple[int, int], Fixed] = {}
        self._reach: dict[int, int] = {}

    def _ticks(self, seconds: Fraction) -> int:
        ticks = bound_ticks(seconds, self.period)
        if ticks is None:
            raise _NotWhole
        return ticks

    def reach(self, node: Node) -> int:
        """Samples after a restart beyond which `node` can no longer be fixed by them."""
        key = id(node)
        if key not in self._reach:
            self._reach[key] = self._reach_of(node)
        return self._reach[key]

    def _reach_of(self, node: Node) -> int:
        return _Reach(self).visit(node)

    def value(self, node: Node, k: int) -> Fixed:
        if k >= self.reach(node):
            return None
        key = (id(node), k)
        if key not in self._memo:
            self._memo[key] = self._value(node, k)
        return self._memo[key]

    def _value(self, node: Node, k: int) -> Fixed:
        return _Value(self).visit(node, k)

    def _window(self, node: Window, k: int) -> Fixed:
        once = node.op == "once"
        lo = self._ticks(node.interval.lo) if node.interval else 0
        first = max(0, k - self._ticks(node.interval.hi)) if node.interval else 0
        last = k - lo
        if last < first:
            return -INF if once else INF
        inner_reach = self.reach(node.operand)
        fixed = [self.value(node.operand, s) for s in range(first, min(last, inner_reach - 1) + 1)]
        complete = last < inner_reach  # every sample of the window is fixed
        if once:
            if INF in fixed:
                return INF
            return -INF if complete and all(v == -INF for v in fixed) else None
        if -INF in fixed:
            return -INF
        return INF if complete and all(v == INF for v in fixed) else None


class _Reach(Visitor[int]):
    """`_Vacancy.reach` by node class: how many samples after a restart can fix a node."""

    def __init__(self, analysis: _Vacancy):
        self.analysis = analysis

    def generic_visit(self, node: Node, *args: object) -> int:
        return 0  # terms, comparisons and `next` read the data at once

    def visit_Not(self, node: Not) -> int:
        return self.analysis.reach(node.operand)

    def visit_BoolOp(self, node: BoolOp) -> int:
        return max(self.analysis.reach(node.left), self.analysis.reach(node.right))

    def visit_Prev(self, node: Prev) -> int:
        return 1 + self.analysis.reach(node.operand)

    def visit_Window(self, node: Window) -> int:
        if node.op not in ("once", "historically"):
            return 0
        lo = self.analysis._ticks(node.interval.lo) if node.interval else 0
        return min(lo + self.analysis.reach(node.operand), MAX_EXAMINED)

    def visit_Span(self, node: Span) -> int:
        if node.op != "since" or node.interval is None:
            return 0
        return self.analysis._ticks(node.interval.lo)


class _Value(Visitor[Fixed]):
    """`_Vacancy.value` by node class: a node's fixed value `k` samples after a restart."""

    def __init__(self, analysis: _Vacancy):
        self.analysis = analysis

    def generic_visit(self, node: Node, *args: object) -> Fixed:
        return None  # depends on the data

    def visit_Not(self, node: Not, k: int) -> Fixed:
        inner = self.analysis.value(node.operand, k)
        return None if inner is None else -inner

    def visit_BoolOp(self, node: BoolOp, k: int) -> Fixed:
        left, right = self.analysis.value(node.left, k), self.analysis.value(node.right, k)
        if node.op == "implies":
            left = None if left is None else -left
        if node.op == "and":
            return _and(left, right)
        return _or(left, right)

    def visit_Prev(self, node: Prev, k: int) -> Fixed:
        return INF if k == 0 else self.analysis.value(node.operand, k - 1)

    def visit_Window(self, node: Window, k: int) -> Fixed:
        return self.analysis._window(node, k)

    def visit_Span(self, node: Span, k: int) -> Fixed:
        return -INF  # since[a:b] at k < a: no sample s in k-b .. k-a


def _and(left: Fixed, right: Fixed) -> Fixed:
    if left == -INF or right == -INF:
        return -INF
    return INF if left == INF and right == INF else None


def _or(left: Fixed, right: Fixed) -> Fixed:
    if left == INF or right == INF:
        return INF
    return -INF if left == -INF and right == -INF else None
