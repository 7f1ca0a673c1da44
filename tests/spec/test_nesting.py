"""Issue 31: recursion is bounded by the checks (CW051), not by Python's stack or rtamt's."""

from __future__ import annotations

import pytest

from casewatch.spec.compiler import check_formulas, compile_case
from casewatch.spec.parser import MAX_NESTING, FormulaError, parse_formula
from tests.spec.cases import hazard_node, make_case, stl_node


def _found(*nodes) -> list[tuple[str, str]]:
    return [(f.code, f.message) for f in check_formulas(make_case(*nodes))]


def test_a_2001_term_conjunction_is_a_finding_not_a_recursion_error() -> None:
    ((code, message),) = _found(stl_node("Sn1", " and ".join(["els > 0"] * 2001)))
    assert code == "CW051"
    assert message.startswith(
        "formula of node Sn1 is nested too deeply: the formula nests "
        f"more than {MAX_NESTING} operators"
    )


def test_the_nesting_limit_is_exact() -> None:
    parse_formula(" and ".join(["x > 0"] * MAX_NESTING))  # 99 `and`: fine
    with pytest.raises(FormulaError) as caught:
        parse_formula(" and ".join(["x > 0"] * (MAX_NESTING + 2)))
    assert caught.value.code == "CW051"


def test_nested_negations_compile_and_run_in_linear_time() -> None:
    """rtamt's `not` node held its child twice: 20 nested `not` took 12 s at the first update,
    and 300 (a fuzz formula that `check` passes) never finished. With the fence: at once."""
    import time

    from casewatch.spec.emit import build_rtamt_monitor

    assert _found(stl_node("Sn1", "not " * 60 + "els > 0")) == []
    spec, _ = compile_case(make_case(hazard_node("CSn1", "not " * 61 + "els > 0")))
    assert spec is not None
    (formula,) = spec.formulas
    assert formula.rtamt.count("not") == 62  # the hazard adds one
    started = time.perf_counter()
    monitor = build_rtamt_monitor(formula, 0.1)
    for _ in range(3):
        monitor.reset()
        # 62 negations of (els > 0): the value of els > 0 itself
        assert monitor.update(0, [(formula.signals[0], 0.5)]) == 0.5
    assert time.perf_counter() - started < 5.0


def test_a_sum_too_long_for_rtamt_is_a_finding() -> None:
    assert _found(stl_node("Sn1", "sum[0:5s](abs(els - 1)) < 3")) == []  # 51 samples
    ((code, message),) = _found(stl_node("Sn1", "sum[0:9.9s](abs(els - 1)) < 3"))  # 100
    assert code == "CW051" and "is nested too deeply for rtamt" in message


def test_rtamt_builds_a_long_sum_in_linear_time() -> None:
    """rtamt 0.4.10's Addition holds its children twice; unfenced, a 20-sample sum took 13 s
    to build its operators (2^20 visits), and again at every reset. The fence drops the
    repeats: every Addition has two children, and the values are the sum's."""
    import time
    from fractions import Fraction

    from casewatch.spec.emit import new_rtamt_spec, to_rtamt

    text = to_rtamt(parse_formula("sum[0:6.9](abs(x - y)) < 3"), Fraction(1, 10))  # 70
    started = time.perf_counter()
    monitor = new_rtamt_spec(text, ["x", "y"], 0.1)
    # before any update (which is where rtamt would visit the repeats): fails fast unfenced
    stack, additions = list(monitor.ast.specs), 0
    while stack:
        node = stack.pop()
        if type(node).__name__ == "Addition":
            assert len(node.children) == 2
            additions += 1
        stack.extend(node.children)
    assert additions == 69  # a sum of 70 samples adds 69 times
    values = [monitor.update(i * 0.1, [("x", 1.0), ("y", 2.0)]) for i in range(72)]
    monitor.reset()
    again = monitor.update(0.0, [("x", 1.0), ("y", 2.0)])
    assert time.perf_counter() - started < 5.0
    assert values[69:] == [3.0 - 70, 3.0 - 70, 3.0 - 70] and again == float("-inf")
