"""Issue 31, item 1: an SPI's `for:` across gaps and at the start of a stream. A violation
counts once it has lasted `for:` of data; after a restart (a gap, a time jump) the count begins
afresh, and the ticks before it has lasted `for:` are no data, never a violation. The same on
the rtamt engine, the numpy engine and `spec.reference_eval.reference_verdicts`."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.evaluator.core import PERSISTING, Evaluator, rtamt_monitor
from casewatch.evaluator.signal_store import Columns
from casewatch.evaluator.stl_engines import CheckedMonitor, PrecomputedMonitor, evaluate_whole_log
from casewatch.spec.compiler import compile_case
from casewatch.spec.parser import parse_rtamt
from casewatch.spec.reference_eval import reference_verdicts
from tests.spec.cases import make_case, spi_node

PERIOD = 0.1
NaN = math.nan


def compiled(for_seconds: float | None):
    case = make_case(
        spi_node("Sn1", "speed", "<=", 20.0, for_seconds=for_seconds),
        signals={"speed": "ego speed, m/s"},
    )
    spec, findings = compile_case(case)
    assert spec is not None, findings
    return case, spec


def judge(case, spec, speeds: list[float], engine: str) -> tuple[list[str], Evaluator]:
    """Sn1's status at every tick (a NaN speed is a tick without it), on one engine."""
    t = [round(i * PERIOD, 6) for i in range(len(speeds))]
    rows = [{"speed": None if math.isnan(v) else v} for v in speeds]
    columns = Columns(["speed"])
    for ti, row in zip(t, rows, strict=True):
        columns.add(ti, row)
    whole = evaluate_whole_log(spec, columns, case.monitor.metrics.max_gap)
    found: list = []

    def factory(f, period):
        if engine == "numpy":
            return PrecomputedMonitor(whole.values[f.id])
        if engine == "both":
            return CheckedMonitor(rtamt_monitor(f, period), f, whole, found, [0])
        return rtamt_monitor(f, period)

    evaluator = Evaluator(case, spec, monitor_factory=factory)
    statuses = [evaluator.step(ti, row)["Sn1"] for ti, row in zip(t, rows, strict=True)]
    evaluator.finish()
    assert found == []
    return statuses, evaluator


def reference_statuses(spec, speeds: list[float]) -> list[str]:
    formula = spec.formulas[0]
    values = reference_verdicts(
        parse_rtamt(formula.rtamt, PERIOD),
        {"speed": speeds},
        PERIOD,
        formula.warmup_ticks,
        formula.persist_ticks,
    )
    return ["no-data" if math.isnan(v) else "violated" if v < 0 else "satisfied" for v in values]


# 0.0 and 0.1 too fast (two ticks: shorter than `for: 0.3s`), no speed at 0.5, then too fast
# from 0.6 to 1.0: the violation has lasted 0.3 s (four samples) at 0.9
SPEEDS = [30, 30, 10, 10, 10, NaN, 30, 30, 30, 30, 30, 10, 10, 10]


@pytest.mark.parametrize("engine", ["rtamt", "numpy", "both"])
def test_a_violation_counts_once_it_has_lasted_for_of_data(engine: str) -> None:
    case, spec = compiled(0.3)
    assert spec.formulas[0].persist_ticks == 3
    statuses, evaluator = judge(case, spec, [float(v) for v in SPEEDS], engine)
    assert statuses == [
        "no-data",
        "no-data",
        "satisfied",
        "satisfied",
        "satisfied",
        "no-data",
        "no-data",
        "no-data",
        "no-data",
        "violated",
        "violated",
        "satisfied",
        "satisfied",
        "satisfied",
    ]
    assert [(e.start, e.end, e.ticks) for e in evaluator.episodes] == [(0.9, 1.0, 2)]
    gaps = [(g.start, g.end, g.missing) for g in evaluator.data_gaps]
    assert gaps == [(0.0, 0.1, [PERSISTING]), (0.5, 0.8, [PERSISTING, "speed"])]
    (stats,) = evaluator.formula_stats()
    assert (stats.ticks_evaluated, stats.ticks_violated, stats.ticks_no_data) == (8, 2, 6)


def test_without_for_the_first_violated_tick_counts_at_once() -> None:
    case, spec = compiled(None)
    assert spec.formulas[0].persist_ticks == 0
    statuses, evaluator = judge(case, spec, [float(v) for v in SPEEDS], "rtamt")
    assert statuses[:2] == ["violated", "violated"] and statuses[6] == "violated"
    assert [(e.start, e.end) for e in evaluator.episodes] == [(0.0, 1.0)]


def test_a_satisfied_tick_inside_the_first_for_is_a_pass() -> None:
    """A pass needs no history: one sample within the threshold satisfies `once[0:for]`."""
    case, spec = compiled(1.0)
    statuses, _ = judge(case, spec, [10.0, 30.0, 30.0, 10.0], "rtamt")
    assert statuses == ["satisfied", "satisfied", "satisfied", "satisfied"]


def test_a_violation_shorter_than_for_after_every_gap_never_counts() -> None:
    """One lost message every 4 ticks: the 3 violated ticks between never last 0.3 s."""
    case, spec = compiled(0.3)
    speeds = [30.0, 30.0, 30.0, NaN] * 10
    for engine in ("rtamt", "numpy"):
        statuses, evaluator = judge(case, spec, speeds, engine)
        assert set(statuses) == {"no-data"} and evaluator.episodes == []


@settings(max_examples=60, deadline=None)
@given(
    st.sampled_from([None, 0.1, 0.3, 1.0]),
    st.lists(st.sampled_from([5.0, 15.0, 25.0, 35.0, NaN]), min_size=1, max_size=40),
)
def test_both_engines_judge_as_the_reference_evaluator(for_seconds, speeds) -> None:
    case, spec = compiled(for_seconds)
    want = reference_statuses(spec, speeds)
    for engine in ("rtamt", "numpy"):
        got, _ = judge(case, spec, speeds, engine)
        assert got == want, (engine, for_seconds, speeds)


def test_reference_verdicts_by_hand() -> None:
    got = reference_verdicts(
        parse_rtamt("once[0:0.2] (x >= 1.0)", PERIOD),
        {"x": [0.0, 0.0, 0.0, 2.0, NaN, 0.0, 0.0, 0.0]},
        PERIOD,
        persist_ticks=2,
    )
    np.testing.assert_array_equal(got, [NaN, NaN, -1.0, 1.0, NaN, NaN, NaN, -1.0])
