"""The whole-log STL engine: robustness of a formula at every tick at once, in numpy.

The online evaluator feeds rtamt tick by tick, a Python call per formula and sample. A log is
all there: this evaluates each formula over whole arrays instead (`casewatch run --stl-engine
numpy`, and threshold tuning over hundreds of candidates). It lives in `evaluator/`, not in
`spec/`, because what it must reproduce is the evaluator's judging, not only the formula
semantics: which ticks are data gaps and where the monitor restarts. The semantics are rtamt
0.4.10's, as `spec.reference_eval` writes them out; property tests hold this module to it and
to rtamt itself, applied the way `evaluator.core` applies them:

- a tick is evaluated when every input signal of the formula has a finite value; other ticks
  are data gaps (NaN robustness);
- the monitor restarts at every gap (a non-evaluated tick, or a jump in tick time longer than
  `max_gap`): past windows and `prev` never reach across one, and time inside a segment is
  counted in samples, as rtamt counts it.

Every operator of the formula language: terms, comparisons, `not`, `and`, `or`, `implies`,
`prev`, `once` / `historically` (bounded or not), `since`, the term `sum[a:b]`, and for
offline formulas `next`, `eventually`, `always`, `until` (bounded), which read the end of a
segment as missing samples, as `spec.reference_eval` does. The temporal operators are compiled loops
(`evaluator.stl_kernels`): windows in O(n) with a monotonic deque, whatever their length.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from casewatch.errors import CasewatchError
from casewatch.evaluator import stl_kernels
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
    signals_of,
)
from casewatch.spec.visitor import Visitor

INF = np.inf


class Unsupported(CasewatchError, ValueError):
    """A formula operator the vectorised evaluator does not implement."""


class Segments:
    """Where the monitor restarts: the evaluated ticks and, for each, its position inside its
    run of consecutive evaluated ticks (0 at a restart)."""

    def __init__(self, t: np.ndarray, evaluated: np.ndarray, max_gap: float):
        self.evaluated = evaluated
        index = np.flatnonzero(evaluated)
        self.index = index
        n = len(index)
        restart = np.ones(n, dtype=bool)
        if n > 1:
            consecutive = np.diff(index) == 1
            close = np.diff(t[index]) <= max_gap + 1e-9
            restart[1:] = ~(consecutive & close)
        starts = np.flatnonzero(restart)
        self.starts = starts
        lengths = np.diff(np.append(starts, n))
        self.position = np.arange(n) - np.repeat(starts, lengths)
        #: per evaluated tick, its segment's first index and one past its last
        self.start = np.repeat(starts, lengths).astype(np.int64)
        self.end = np.repeat(starts + lengths, lengths).astype(np.int64)


def evaluated_ticks(formula: Node, columns: Mapping[str, np.ndarray]) -> np.ndarray:
    """(n,) True where every input signal of `formula` has a finite value."""
    names = sorted({s.name for s in signals_of(formula)})
    if not names:
        raise Unsupported("the formula reads no signal")
    ok = np.isfinite(columns[names[0]])
    for name in names[1:]:
        ok &= np.isfinite(columns[name])
    return ok


def robustness(
    formula: Formula,
    columns: Mapping[str, np.ndarray],
    t: np.ndarray,
    period: float,
    max_gap: float,
) -> np.ndarray:
    """(n,) robustness of `formula` at every tick; NaN where the tick is a data gap."""
    evaluated = evaluated_ticks(formula, columns)
    segments = Segments(t, evaluated, max_gap)
    picked = {name: col[segments.index] for name, col in columns.items()}
    out = np.full(len(t), np.nan)
    if len(segments.index):
        out[segments.index] = _Evaluator(picked, segments, period).formula(formula)
    return out


class _Evaluator(Visitor[np.ndarray]):
    """Robustness over the evaluated ticks only (compacted arrays): a term's values, or a
    formula's robustness, one case per node class."""

    def __init__(self, columns: Mapping[str, np.ndarray], segments: Segments, period: float):
        self.columns = columns
        self.segments = segments
        self.period = period
        self.n = len(segments.index)

    def formula(self, node: Formula) -> np.ndarray:
        return self.visit(node)

    def generic_visit(self, node: Node, *args: object) -> np.ndarray:
        raise Unsupported(f"operator {_name(node)}")

    # -- terms ----------------------------------------------------------------------------

    def visit_Num(self, node: Num) -> np.ndarray:
        return np.full(self.n, float(node.value))

    def visit_Signal(self, node: Signal) -> np.ndarray:
        return self.columns[node.name]

    def visit_Neg(self, node: Neg) -> np.ndarray:
        return -self.visit(node.operand)

    def visit_Abs(self, node: Abs) -> np.ndarray:
        return np.abs(self.visit(node.operand))

    def visit_Arith(self, node: Arith) -> np.ndarray:
        a, b = self.visit(node.left), self.visit(node.right)
        ops: dict[str, Callable] = {
            "+": np.add,
            "-": np.subtract,
            "*": np.multiply,
            "/": np.divide,
        }
        with np.errstate(divide="ignore", invalid="ignore"):
            return ops[node.op](a, b)

    def visit_Sum(self, node: Sum) -> np.ndarray:
        return self._sum(node)

    # -- formulas -------------------------------------------------------------------------

    def visit_Compare(self, node: Compare) -> np.ndarray:
        a, b = self.visit(node.left), self.visit(node.right)
        if node.op in (">=", ">"):
            return a - b
        if node.op in ("<=", "<"):
            return b - a
        return -np.abs(a - b) if node.op == "==" else np.abs(a - b)

    def visit_Not(self, node: Not) -> np.ndarray:
        return -self.visit(node.operand)

    def visit_BoolOp(self, node: BoolOp) -> np.ndarray:
        a, b = self.visit(node.left), self.visit(node.right)
        if node.op == "and":
            return np.minimum(a, b)
        if node.op == "or":
            return np.maximum(a, b)
        return np.maximum(-a, b)

    def visit_Prev(self, node: Prev) -> np.ndarray:
        inner = self.visit(node.operand)
        out = np.full(self.n, INF)
        later = self.segments.position > 0
        out[later] = inner[np.flatnonzero(later) - 1]
        return out

    def visit_Next(self, node: Next) -> np.ndarray:
        inner = self.visit(node.operand)
        out = np.full(self.n, -INF)
        has_next = np.arange(self.n) + 1 < self.segments.end
        out[has_next] = inner[np.flatnonzero(has_next) + 1]
        return out

    def visit_Window(self, node: Window) -> np.ndarray:
        return self._window(node)

    def visit_Span(self, node: Span) -> np.ndarray:
        return self._span(node)

    def _shift(self, values: np.ndarray, k: int) -> np.ndarray:
        """`values` `k` samples earlier inside each segment, `+inf` before its start (`prev`)."""
        if k == 0:
            return values
        out = np.full(self.n, INF)
        later = self.segments.position >= k
        out[later] = values[np.flatnonzero(later) - k]
        return out

    def _sum(self, node: Sum) -> np.ndarray:
        """`e(t-a) + (e(t-a-1) + (... + e(t-b)))`: the additions in the order of rtamt's
        expansion (`spec.emit`), so the values are the same to the bit."""
        inner = np.asarray(self.visit(node.operand), dtype=float)
        lo, hi = self._samples(node.interval)
        total = self._shift(inner, hi)
        with np.errstate(invalid="ignore"):
            for k in range(hi - 1, lo - 1, -1):
                total = self._shift(inner, k) + total
        return total

    def _samples(self, interval: Interval | None) -> tuple[int, int]:
        """An interval in samples; hi -1 for an unbounded one."""
        if interval is None:
            return 0, -1
        return (round(float(interval.lo) / self.period), round(float(interval.hi) / self.period))

    def _window(self, node: Window) -> np.ndarray:
        inner = np.ascontiguousarray(self.formula(node.operand), dtype=float)
        lo, hi = self._samples(node.interval)
        take_max = node.op in ("once", "eventually")
        if node.op in ("once", "historically"):
            return stl_kernels.past_window(inner, self.segments.start, lo, hi, take_max)
        if hi < 0:
            raise Unsupported(f"unbounded {node.op}")
        # a future window is a past window of the reversed ticks
        rev_start = (self.n - self.segments.end)[::-1].copy()
        return stl_kernels.past_window(inner[::-1].copy(), rev_start, lo, hi, take_max)[::-1]

    def _span(self, node: Span) -> np.ndarray:
        left = np.ascontiguousarray(self.formula(node.left), dtype=float)
        right = np.ascontiguousarray(self.formula(node.right), dtype=float)
        lo, hi = self._samples(node.interval)
        if node.op == "since":
            return stl_kernels.since(left, right, self.segments.start, lo, hi)
        if hi < 0:
            raise Unsupported("unbounded until")
        return stl_kernels.until(left, right, self.segments.end, lo, hi)


def _name(node: Node) -> str:
    op = getattr(node, "op", None)
    return f"`{op}`" if isinstance(op, str) else type(node).__name__.lower()
