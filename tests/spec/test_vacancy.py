"""Issue 31, item 2: windows that read no sample at the start of a stream (spec.vacancy) and
the CW050 warning `check` gives for them."""

from __future__ import annotations

from fractions import Fraction

import pytest
from hypothesis import given, settings

from casewatch.cli import main
from casewatch.spec.compiler import check_formulas
from casewatch.spec.parser import parse_formula
from casewatch.spec.reference_eval import reference_robustness
from casewatch.spec.vacancy import vacant_ticks
from tests.spec.cases import hazard_node, make_case, spi_node, stl_node
from tests.spec.strategies import PERIOD, past_formulas, traces

P = Fraction(1, 10)


@pytest.mark.parametrize(
    ("text", "ticks"),
    [
        ("once[1s:2s] (x >= 0.6)", list(range(10))),
        ("once[0:2s] (x >= 0.6)", []),
        ("historically[1s:2s] (x >= 0.6)", []),  # +inf: holds vacuously
        ("not historically[0.3:1] (x >= 0.6)", [0, 1, 2]),
        ("not prev (x >= 0)", [0]),
        ("x > 0 since[0.2:1] y > 0", [0, 1]),
        ("once[0.1:0.1] once[0.2:0.3] (x > 0)", [0, 1, 2]),
        ("x > 0 and once[0.2:0.2] (y > 0)", [0, 1]),
        ("x > 0 or once[0.2:0.2] (y > 0)", []),  # depends on x
        ("once[0.2:0.4] (x > 0) implies y > 0", []),  # -inf premise: holds
    ],
)
def test_vacant_ticks_by_hand(text: str, ticks: list[int]) -> None:
    assert vacant_ticks(parse_formula(text), P) == ticks


@settings(max_examples=300, deadline=None)
@given(past_formulas, traces(min_len=8, max_len=12))
def test_a_vacant_tick_is_minus_infinity_whatever_the_data(formula, trace) -> None:
    values = reference_robustness(formula, trace, PERIOD)
    for k in vacant_ticks(formula, P):
        if k < len(values):
            assert values[k] == float("-inf"), (k, values)


def test_check_warns_on_the_issue_reproductions() -> None:
    case = make_case(
        stl_node("Sn1", "once[1s:2s] (els >= 0.6)"),
        hazard_node("CSn1", "historically[1s:2s] (els < 1.0 and ess > 5.0)"),
        spi_node("Sn2", "els", ">=", 0.6, for_seconds=1.0),  # once[0:1s]: no finding
    )
    found = sorted(
        (f.code, f.severity, f.message) for f in check_formulas(case) if f.code == "CW050"
    )
    assert found == [
        (
            "CW050",
            "warning",
            "the hazard of node CSn1 reads as present at the first 10 sample(s) "
            "(1s) of every stream and after every data gap, whatever the data: a window there "
            "reads no sample yet (robustness -inf)",
        ),
        (
            "CW050",
            "warning",
            "the spi of node Sn1 is violated at the first 10 sample(s) (1s) of "
            "every stream and after every data gap, whatever the data: a window there reads no "
            "sample yet (robustness -inf)",
        ),
    ]


def test_check_prints_the_warning_with_its_position_and_exits_0(tmp_path, capsys) -> None:
    case = tmp_path / "case.yaml"
    case.write_text(
        "module: {name: t}\nmonitor: {channels: [lav, tfuse]}\n"
        "G1: {text: a, supportedBy: [Sn1]}\n"
        'Sn1:\n  text: e\n  spi: {stl: "once[1s:2s] (els >= 0.6)"}\n'
    )
    assert main(["check", str(case)]) == 0
    out = capsys.readouterr().out
    assert f"{case}:6:" in out and "CW050 warning: the spi of node Sn1 is violated" in out
