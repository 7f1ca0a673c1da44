"""`sum[a:b](e)` in the whole-log numpy engine: restarts at gaps, the same bits as rtamt's
expansion, and `--stl-engine both` end to end on a case with sums."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from casewatch.cli import main
from casewatch.evaluator.vector_eval import robustness
from casewatch.spec.emit import period_fraction, to_rtamt
from casewatch.spec.parser import parse_formula, parse_rtamt
from tests.evaluator.streams import SMALL_CASE, write_stream
from tests.evaluator.test_stl_engines import rtamt_per_segment
from tests.spec.strategies import PERIOD, SIGNALS

INF = np.inf
P = period_fraction(PERIOD)


def test_hand_computed_with_a_gap_and_a_time_jump() -> None:
    # segments: ticks 0-2, 4-5 (x has no value at 3), 6-7 (0.7 s jump before tick 6)
    x = np.array([1.0, 2.0, 4.0, np.nan, 8.0, 16.0, 32.0, 64.0])
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 1.2, 1.3])
    got = robustness(parse_formula("sum[0:0.1](x) <= 10"), {"x": x}, t, 0.1, 0.5)
    # x_t + x_t-1 inside a segment, +inf at each segment's first tick
    want = [-INF, 7.0, 4.0, np.nan, -INF, -14.0, -INF, -86.0]
    np.testing.assert_array_equal(got, want)
    got = robustness(parse_formula("sum[0.1:0.2](x) <= 10"), {"x": x}, t, 0.1, 0.5)
    np.testing.assert_array_equal(got, [-INF, -INF, 7.0, np.nan, -INF, -INF, -INF, -INF])
    got = robustness(parse_formula("sum[0:0](x) <= 10"), {"x": x}, t, 0.1, 0.5)
    np.testing.assert_array_equal(got, 10 - x)


FORMULAS = [
    "sum[0:0.4](abs(x - y)) <= 5",
    "sum[0.1:0.3](x * 0.5) + y > 1",
    "sum[0:0.2](sum[0:0.1](x) + y) - z >= 0",
    "-sum[0:0.3](x) != 1 or once[0:0.3](sum[0:0.1](abs(z)) <= 4)",
    "historically[0.1:0.2](sum[0:0.2](y) < 3) and prev (sum[0:0.1](x) >= sum[0:0](y))",
]


@pytest.mark.parametrize("text", FORMULAS)
def test_same_bits_as_rtamt_and_as_the_expansion(text: str) -> None:
    rng = np.random.default_rng(7)
    n = 60
    trace = {name: np.round(rng.uniform(-5, 5, n), 3) for name in SIGNALS}
    trace["x"][[9, 30, 31]] = np.nan  # gaps: the monitor restarts after each
    t = np.round(np.cumsum(np.where(np.arange(n) == 45, 0.9, 0.1)), 6)  # and after a jump
    formula = parse_formula(text)
    ours = robustness(formula, trace, t, PERIOD, max_gap=0.5)
    # the whole-log engine reads the compiled rtamt text back: the expansion, `prev` by `prev`
    expanded = robustness(parse_rtamt(to_rtamt(formula, P), PERIOD), trace, t, PERIOD, 0.5)
    theirs = rtamt_per_segment(formula, {k: trace[k] for k in SIGNALS}, t, max_gap=0.5)
    np.testing.assert_array_equal(ours, expanded)
    np.testing.assert_array_equal(ours, theirs)
    assert np.isinf(ours).any() and np.isfinite(ours).any()


def test_the_engines_agree_end_to_end_on_a_case_with_sums(tmp_path: Path) -> None:
    """Both engines through the evaluator's gaps and restarts (tfuse, hence els, is missing
    from 5.0 to 5.5 s)."""
    case_text = SMALL_CASE.replace(
        'hazard: {when: "speed > 20"}',
        'hazard: {when: "sum[0:0.4](els) < 2 and sum[0.1:0.3](speed) < 60"}',
    ).replace(
        'spi: {signal: els, threshold: ">= 0.6"}',
        'spi: {stl: "sum[0:0.2](els) >= 1.8"}',
    )
    assert case_text != SMALL_CASE
    case = tmp_path / "case.yaml"
    case.write_text(case_text)
    stream = write_stream(tmp_path / "s.jsonl")
    results = {}
    for engine in ("rtamt", "numpy", "both"):
        out = tmp_path / engine
        code = main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(out),
                "--format",
                "none",
                "--quiet",
                "--stl-engine",
                engine,
            ]
        )
        assert code in (0, 1), engine  # 3 would be an engine disagreement
        results[engine] = json.loads((out / "result.json").read_text())["episodes"]
    assert results["rtamt"] == results["numpy"] == results["both"] != []
    # els drops to 1/3 from 2.0 to 3.0 s: three samples sum to 1 < 1.8, five to 5/3 < 2
    assert {e["formula_id"] for e in results["rtamt"]} >= {"CSn1", "Sn1"}


def test_an_incomplete_sum_window_is_no_data_not_a_violation(tmp_path: Path) -> None:
    """`sum[0:0.2](els) <= 5` holds whenever it has three samples (els <= 1); rtamt's +inf
    terms before that would read as violations. The evaluator reports those ticks as a data
    gap naming the filling window, at the start and after tfuse's dropout (5.0-5.5 s), and
    every engine agrees."""
    case_text = SMALL_CASE.replace(
        'spi: {signal: els, threshold: ">= 0.6"}', 'spi: {stl: "sum[0:0.2](els) <= 5"}'
    )
    case = tmp_path / "case.yaml"
    case.write_text(case_text)
    stream = write_stream(tmp_path / "s.jsonl")
    seen = []
    for engine in ("rtamt", "numpy", "both"):
        out = tmp_path / engine
        code = main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(out),
                "--format",
                "none",
                "--quiet",
                "--stl-engine",
                engine,
            ]
        )
        assert code in (0, 1), engine
        result = json.loads((out / "result.json").read_text())
        assert [e for e in result["episodes"] if e["formula_id"] == "Sn1"] == []
        gaps = [
            (g["start"], g["end"], g["missing"])
            for g in result["data_gaps"]
            if g["formula_id"] == "Sn1"
        ]
        assert gaps[0] == (0.0, 0.1, ["(sum window filling)"])
        # the dropout (els missing 5.0-5.5 s) and the two ticks of a filling window after it
        # are one gap
        assert (5.0, 5.7, ["(sum window filling)", "els"]) in gaps
        stats = next(f for f in result["formulas"] if f["id"] == "Sn1")
        seen.append((gaps, stats["ticks_evaluated"], stats["ticks_no_data"]))
    assert seen[0] == seen[1] == seen[2]
