"""Every pass over a formula is a `Visitor`, and every pass handles every operator.

Adding a node class to `casewatch.spec.ast` makes `test_every_pass_handles_every_node` list the
passes that have no case for it (docs/architecture.md, "A formula operator").
"""

from __future__ import annotations

import importlib
import pkgutil
from fractions import Fraction

import pytest

import casewatch
from casewatch.spec.ast import Compare, Interval, Num, Signal, Window
from casewatch.spec.visitor import NODE_TYPES, Visitor


def _all_passes() -> list[type[Visitor]]:
    for info in pkgutil.walk_packages(casewatch.__path__, "casewatch."):
        if info.name.startswith(("casewatch.spec", "casewatch.evaluator")):
            importlib.import_module(info.name)
    found, todo = [], list(Visitor.__subclasses__())
    while todo:
        cls = todo.pop()
        found.append(cls)
        todo.extend(cls.__subclasses__())
    # a shared base of several passes (no case of its own, only subclasses) is not a pass
    return [
        c
        for c in found
        if c.__module__.startswith("casewatch.") and (c._handlers or not c.__subclasses__())
    ]


def test_the_formula_passes_are_visitors():
    names = {f"{c.__module__}.{c.__name__}" for c in _all_passes()}
    for expected in [
        "casewatch.spec.emit._TextWriter",
        "casewatch.spec.emit._RtamtEmitter",
        "casewatch.spec.reference_eval.ReferenceEvaluator",
        "casewatch.spec.timing._PastHorizon",
        "casewatch.spec.timing._SumDepth",
        "casewatch.spec.timing._FutureDepth",
        "casewatch.spec.timing._FutureReach",
        "casewatch.spec.vacancy._Reach",
        "casewatch.spec.vacancy._Value",
        "casewatch.evaluator.vector_eval._Evaluator",
    ]:
        assert expected in names


def test_every_pass_handles_every_node():
    gaps = {
        f"{c.__module__}.{c.__name__}": c.unhandled()
        for c in _all_passes()
        if c.unhandled() and not c.is_partial()
    }
    assert gaps == {}, f"passes without a case for these node classes: {gaps}"


class _Depth(Visitor[int]):
    """A pass for the tests: nesting depth of windows, a default for everything else."""

    def generic_visit(self, node, *args):
        return 0

    def visit_Window(self, node: Window, extra: int = 0) -> int:
        return 1 + extra + self.visit(node.operand)


class _OnlyNumbers(Visitor[float]):
    def visit_Num(self, node: Num) -> float:
        return node.value


def test_dispatch_by_class_passes_arguments_through():
    inner = Compare(">=", Signal("els"), Num(0.5))
    twice = Window("once", Interval(Fraction(0), Fraction(1)), Window("once", None, inner))
    assert _Depth().visit(twice) == 2
    assert _Depth().visit(twice, 10) == 12  # the extra argument reaches the handler
    assert _Depth().visit(inner) == 0  # the declared default


def test_a_missing_case_names_the_pass_and_the_node():
    assert _OnlyNumbers().visit(Num(2.5)) == 2.5
    with pytest.raises(TypeError, match="_OnlyNumbers has no visit_Signal"):
        _OnlyNumbers().visit(Signal("els"))
    assert "Signal" in _OnlyNumbers.unhandled() and "Num" not in _OnlyNumbers.unhandled()
    assert not _OnlyNumbers.is_partial() and _Depth.is_partial()
    assert len(NODE_TYPES) == 13
