"""The typed syntax tree of a casewatch formula.

Two sorts, kept apart on purpose: a `Term` is a real-valued expression over signals (arithmetic),
a `Formula` is a condition whose STL robustness says how well it holds. Temporal and boolean
operators take formulas only; comparisons turn two terms into a formula. Keeping the sorts apart
means `prev` never applies to a raw signal, so robustness stays free of `inf - inf` (NaN). The
one number that can be infinite is a `sum` whose window is not complete yet (`+inf`, as rtamt
expands it); `docs/formulas.md` ("Windowed sums") says what that means for arithmetic on sums.

Every node is a frozen dataclass: values, hashable, comparable. Source columns (`col`) are carried
for error messages but excluded from equality, so a formula equals its re-parsed canonical text.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Literal, TypeAlias

ArithOp = Literal["+", "-", "*", "/"]
CompareOp = Literal["<", "<=", ">", ">=", "==", "!="]
BoolOpName = Literal["and", "or", "implies"]
WindowOpName = Literal["once", "historically", "eventually", "always"]
SpanOpName = Literal["since", "until"]

PAST_WINDOWS: frozenset[str] = frozenset({"once", "historically"})
FUTURE_WINDOWS: frozenset[str] = frozenset({"eventually", "always"})


@dataclass(frozen=True)
class Interval:
    """A closed time window `[lo:hi]` in seconds, exact (bounds are parsed as decimals)."""

    lo: Fraction
    hi: Fraction
    col: int = field(default=0, compare=False)


# ---- terms -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Num:
    value: float


@dataclass(frozen=True)
class Signal:
    name: str
    col: int = field(default=0, compare=False)  # 1-based column of the name in the formula


@dataclass(frozen=True)
class Neg:
    operand: Term


@dataclass(frozen=True)
class Abs:
    operand: Term


@dataclass(frozen=True)
class Arith:
    op: ArithOp
    left: Term
    right: Term


@dataclass(frozen=True)
class Sum:
    """`sum[a:b](e)`: the sum of the term `e` over the samples `t-b .. t-a` (a past operator).

    A sample before the first one (of the stream, or since a monitor reset) counts as `+inf`,
    as rtamt's `prev` gives it, so the sum is `+inf` until its window is complete.
    """

    interval: Interval
    operand: Term
    col: int = field(default=0, compare=False)  # column of the `sum` keyword


Term: TypeAlias = Num | Signal | Neg | Abs | Arith | Sum

# ---- formulas ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Compare:
    op: CompareOp
    left: Term
    right: Term


@dataclass(frozen=True)
class Not:
    operand: Formula


@dataclass(frozen=True)
class BoolOp:
    op: BoolOpName
    left: Formula
    right: Formula


@dataclass(frozen=True)
class Prev:
    """Value of the operand one sample earlier (rtamt: +inf robustness at the first sample)."""

    operand: Formula
    col: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Next:
    """Value of the operand one sample later (future: offline only)."""

    operand: Formula
    col: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Window:
    """`once`, `historically` (past) or `eventually`, `always` (future) over `interval`.

    `interval is None` is the unbounded form, allowed only for the past operators.
    """

    op: WindowOpName
    interval: Interval | None
    operand: Formula
    col: int = field(default=0, compare=False)  # column of the operator keyword


@dataclass(frozen=True)
class Span:
    """`left since[a:b] right` (past) or `left until[a:b] right` (future)."""

    op: SpanOpName
    interval: Interval | None
    left: Formula
    right: Formula
    col: int = field(default=0, compare=False)  # column of the operator keyword


Formula: TypeAlias = Compare | Not | BoolOp | Prev | Next | Window | Span
Node: TypeAlias = Term | Formula

TERM_TYPES = (Num, Signal, Neg, Abs, Arith, Sum)
FORMULA_TYPES = (Compare, Not, BoolOp, Prev, Next, Window, Span)


def children(node: Node) -> tuple[Node, ...]:
    """Direct sub-nodes, left to right."""
    if isinstance(node, Num | Signal):
        return ()
    if isinstance(node, Neg | Abs | Sum | Not | Prev | Next | Window):
        return (node.operand,)
    return (node.left, node.right)


def walk(node: Node) -> list[Node]:
    """Every node of the tree, pre-order."""
    out: list[Node] = [node]
    for child in children(node):
        out.extend(walk(child))
    return out


def signals_of(node: Node) -> list[Signal]:
    """Every signal occurrence, in source order."""
    return [n for n in walk(node) if isinstance(n, Signal)]


def is_future(node: Node) -> bool:
    """True for an operator that looks ahead of the current sample."""
    return (
        isinstance(node, Next)
        or (isinstance(node, Window) and node.op in FUTURE_WINDOWS)
        or (isinstance(node, Span) and node.op == "until")
    )


def future_operators(node: Node) -> list[Node]:
    return [n for n in walk(node) if is_future(n)]
