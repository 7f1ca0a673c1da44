"""Whole-run robustness of a formula in numpy, from saved signals (for threshold tuning).

The online evaluator feeds rtamt tick by tick; tuning needs the same verdicts for hundreds of
candidate thresholds over hours of saved signals, so it evaluates the formula over all ticks at
once. The semantics are rtamt 0.4.10's, as `spec.reference_eval` writes them out (and a property
test holds this module to it), applied the way `evaluator.core` applies them:

- a tick is evaluated when every input signal of the formula has a finite value; other ticks
  are data gaps (NaN robustness);
- the monitor restarts at every gap (a non-evaluated tick, or a jump in tick time longer than
  `max_gap`): past windows and `prev` never reach across one, and time inside a segment is
  counted in samples, as rtamt counts it.

Supported: terms, comparisons, `not`, `and`, `or`, `implies`, `prev`, and the past windows
`once` / `historically` (bounded or not). Future operators and `since` raise `Unsupported`:
tuning is for the formulas an online monitor runs, and those it names.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from itertools import pairwise

import numpy as np

from spec.ast import (
    Abs,
    Arith,
    BoolOp,
    Compare,
    Formula,
    Neg,
    Node,
    Not,
    Num,
    Prev,
    Signal,
    Term,
    Window,
    signals_of,
)

INF = np.inf


class Unsupported(ValueError):
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
        self.position = np.arange(n) - np.repeat(starts, np.diff(np.append(starts, n)))


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


class _Evaluator:
    """Robustness over the evaluated ticks only (compacted arrays)."""

    def __init__(self, columns: Mapping[str, np.ndarray], segments: Segments, period: float):
        self.columns = columns
        self.segments = segments
        self.period = period
        self.n = len(segments.index)

    def term(self, node: Term) -> np.ndarray:
        if isinstance(node, Num):
            return np.full(self.n, float(node.value))
        if isinstance(node, Signal):
            return self.columns[node.name]
        if isinstance(node, Neg):
            return -self.term(node.operand)
        if isinstance(node, Abs):
            return np.abs(self.term(node.operand))
        if isinstance(node, Arith):
            a, b = self.term(node.left), self.term(node.right)
            ops: dict[str, Callable] = {"+": np.add, "-": np.subtract, "*": np.multiply,
                                        "/": np.divide}  # fmt: skip
            with np.errstate(divide="ignore", invalid="ignore"):
                return ops[node.op](a, b)
        raise Unsupported(f"{type(node).__name__} is not a term")

    def formula(self, node: Formula) -> np.ndarray:
        if isinstance(node, Compare):
            a, b = self.term(node.left), self.term(node.right)
            if node.op in (">=", ">"):
                return a - b
            if node.op in ("<=", "<"):
                return b - a
            return -np.abs(a - b) if node.op == "==" else np.abs(a - b)
        if isinstance(node, Not):
            return -self.formula(node.operand)
        if isinstance(node, BoolOp):
            a, b = self.formula(node.left), self.formula(node.right)
            if node.op == "and":
                return np.minimum(a, b)
            if node.op == "or":
                return np.maximum(a, b)
            return np.maximum(-a, b)
        if isinstance(node, Prev):
            inner = self.formula(node.operand)
            out = np.full(self.n, INF)
            later = self.segments.position > 0
            out[later] = inner[np.flatnonzero(later) - 1]
            return out
        if isinstance(node, Window) and node.op in ("once", "historically"):
            return self._window(node)
        raise Unsupported(f"operator {_name(node)} (tuning evaluates past-time formulas "
                          "without `since`)")  # fmt: skip

    def _window(self, node: Window) -> np.ndarray:
        inner = self.formula(node.operand)
        once = node.op == "once"
        empty = -INF if once else INF
        reduce = np.maximum if once else np.minimum
        position = self.segments.position
        if node.interval is None:
            return self._running(inner, reduce)
        lo = round(float(node.interval.lo) / self.period)
        hi = round(float(node.interval.hi) / self.period)
        out = np.full(self.n, empty)
        for shift in range(lo, hi + 1):
            reach = position >= shift  # the sample `shift` back lies inside the segment
            if not reach.any():
                break
            rows = np.flatnonzero(reach)
            out[rows] = reduce(out[rows], inner[rows - shift])
        return out

    def _running(self, inner: np.ndarray, reduce: Callable) -> np.ndarray:
        out = np.empty(self.n)
        bounds = [*self.segments.starts.tolist(), self.n]
        for a, b in pairwise(bounds):
            out[a:b] = reduce.accumulate(inner[a:b])
        return out


def _name(node: Node) -> str:
    op = getattr(node, "op", None)
    return f"`{op}`" if isinstance(op, str) else type(node).__name__.lower()
