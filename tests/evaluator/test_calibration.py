"""SPI calibration (evaluator.calibration) on hand-built saved signals: the persistence sweep,
the refusal at a cliff, the minimum of nominal hours, loosen-only unless asked, the Poisson
bound and the detection of injected faults, each against figures computed by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.evaluator.calibration import (
    CalibrationLog,
    _levels,
    calibration_sweep,
    choose,
    poisson_upper,
    violated_at,
)
from casewatch.evaluator.faults import FaultLabel
from casewatch.evaluator.signal_store import SavedSignals, nominal_only
from casewatch.evaluator.tuning import Knob, violations
from casewatch.spec.ast import Compare, Num, Signal

PERIOD = 0.1
HOUR = 36000  # ticks


def saved(x: np.ndarray, name: str = "els") -> SavedSignals:
    t = np.round(np.arange(len(x)) * PERIOD, 6)
    return SavedSignals("log", t, [name], np.asarray(x, dtype=float)[:, None], PERIOD, 0.5)


def spi(value: float, duration: float = 0.0, op: str = ">=", signal: str = "els") -> Knob:
    """An SPI `signal op value` held `for: duration` (merge_gap 0, no minimum duration)."""
    return Knob(
        "Sn1",
        "Sn1",
        "s",
        "spi",
        f"{signal} {op} {value}",
        Compare(op, Signal(signal), Num(value)),
        (),
        signal,
        op,
        True,
        value,
        "for",
        duration,
        0.0,
        0.0,
    )


def dips(base: float, n: int, spans: list[tuple[int, int, float]]) -> np.ndarray:
    """`base` everywhere, `value` on ticks [start, start + length)."""
    x = np.full(n, base)
    for start, length, value in spans:
        x[start : start + length] = value
    return x


def test_poisson_upper_bound_is_the_exact_garwood_bound():
    # chi2.ppf(0.95, 2k + 2) / 2: 0 -> -ln 0.05, 1 -> 4.7439, 2 -> 6.2958, 10 -> 16.962
    assert poisson_upper(0) == pytest.approx(-math.log(0.05), rel=1e-9)
    assert poisson_upper(1) == pytest.approx(4.743865, abs=1e-5)
    assert poisson_upper(2) == pytest.approx(6.295794, abs=1e-5)
    assert poisson_upper(10) == pytest.approx(16.962219, abs=1e-4)
    # the defining property, at a count where no table is needed: P(N <= 3 | bound) = 0.05
    mean = poisson_upper(3, 0.9)
    assert sum(math.exp(-mean) * mean**i / math.factorial(i) for i in range(4)) == pytest.approx(
        0.1, abs=1e-9
    )
    with pytest.raises(ValueError):
        poisson_upper(-1)


@settings(max_examples=150, deadline=None)
@given(
    st.lists(
        st.one_of(st.none(), st.sampled_from([0.0, 0.2, 0.5, 0.55, 0.9])), min_size=1, max_size=40
    ),
    st.sampled_from([">=", ">", "<=", "<"]),
    st.sampled_from([0.0, 0.2, 0.5, 1.0]),
    st.sampled_from([0.0, 0.2, 0.5, 0.55, 0.9, 1.0]),
)
def test_one_level_per_duration_splits_ticks_as_the_evaluator_does(values, op, duration, th):
    """`_levels` + `violated_at` (one robustness pass for all thresholds) equals the tuning
    path that evaluates the formula at each threshold, gaps (None) included."""
    x = np.array([np.nan if v is None else v for v in values])
    log = saved(x)
    knob = spi(0.5, duration, op)
    want = violations(knob, log, th, duration)
    got = violated_at(knob, _levels(knob, log, duration), th)
    np.testing.assert_array_equal(got, want)


def faulty_hour() -> CalibrationLog:
    """One hour of els = 0.9 with four 0.3 s ghost dips to 0.5 (ticks 1000, 5000, 9000,
    13000), a nominal 2 s dip to 0.3 (tick 20000), and three injected faults (margin 0):
    a localisation drift (els 0.4 for 3 s, ticks 30000-30030), a frozen channel that leaves
    els at 0.9 (t 3200-3202), and an object drop with els 0.45 (t 3400-3402), whose family
    does not list els."""
    x = dips(
        0.9,
        HOUR,
        [
            (1000, 3, 0.5),
            (5000, 3, 0.5),
            (9000, 3, 0.5),
            (13000, 3, 0.5),
            (20000, 20, 0.3),
            (30000, 31, 0.4),
            (34000, 21, 0.45),
        ],
    )
    faults = [
        FaultLabel("localisation_drift", 3000.0, 3003.0, "lav", 1),
        FaultLabel("frozen_channel", 3200.0, 3202.0, "tfuse", 2),
        FaultLabel("object_drop", 3400.0, 3402.0, "lav", 3),
    ]
    whole = saved(x)
    return CalibrationLog(nominal_only(whole, faults, 0.0), whole, faults, "faulty")


def test_persistence_before_loosening_with_bound_and_detection():
    log = faulty_hour()
    sw = calibration_sweep(spi(0.6), [log])
    # the faults' ticks are not nominal: 31 + 21 + 21 of 36000
    assert sw.ticks == HOUR - 73 and sw.hours == pytest.approx((HOUR - 73) / 36000)
    # candidates: every distinct nominal value (0.3, 0.5, 0.9) and the original 0.6
    assert sw.thresholds == [0.3, 0.5, 0.6, 0.9]
    assert sw.durations == [0.0, 0.5, 1.0, 1.5, 2.0, 3.0]
    assert [f["fault"] for f in sw.faults] == ["localisation_drift", "frozen_channel"]
    row = choose(sw, per_hour=2.0, min_hours=0.5)
    hours = (HOUR - 73) / 36000
    # original: 4 ghosts + the nominal dip = 5 episodes, over a budget of 2/h
    assert row["original"]["episodes"] == 5 and row["original_over_budget"]
    assert row["original"]["per_hour"] == pytest.approx(5 / hours)
    # the threshold stays at 0.6; `for: 0.5s` (6 ticks) lets the 3-tick ghosts through
    # unreported and keeps the 20-tick dip: 1 episode an hour
    assert row["status"] == "calibrated"
    chosen = row["chosen"]
    assert (chosen["threshold"], chosen["for"], chosen["episodes"]) == (0.6, 0.5, 1)
    assert chosen["per_hour"] == pytest.approx(1 / hours)
    assert chosen["per_hour_upper"] == pytest.approx(4.743865 / hours, abs=1e-4)
    # the drift (0.4 for 31 ticks) is detected, the frozen channel (els stays 0.9) is not
    assert (chosen["detected"], chosen["detection"]) == (1, 0.5) and row["faults"] == 2
    assert row["margin"] == 0.0
    curve = {(p["threshold"], p["for"]): p for p in row["curve"]}
    # for: 3 s (31 ticks) still sees the 31-tick drift, no longer the 20-tick nominal dip
    assert (curve[(0.6, 3.0)]["episodes"], curve[(0.6, 3.0)]["detected"]) == (0, 1)
    # x >= 0.3 can never fire here (0.3 is the lowest nominal value)
    assert not curve[(0.3, 0.0)]["fires"] and curve[(0.5, 0.0)]["fires"]
    assert curve[(0.3, 0.0)]["detected"] == 0


def test_a_cliff_is_refused_with_its_reason_and_the_original_kept():
    # els drops to exactly 0.0 for 4 s four times an hour: no `for:` up to 3 s filters it, and
    # the only threshold below every drop, >= 0.0, can never fire
    x = dips(0.9, HOUR, [(s, 40, 0.0) for s in (2000, 10000, 18000, 26000)])
    log = saved(x)
    sw = calibration_sweep(spi(0.5, 1.0), [CalibrationLog(log, log)])
    assert sw.thresholds == [0.0, 0.5, 0.9]
    row = choose(sw, per_hour=2.0, min_hours=0.5)
    assert row["status"] == "not calibratable" and row["original_over_budget"]
    assert (row["chosen"]["threshold"], row["chosen"]["for"]) == (0.5, 1.0)
    assert row["reason"] == (
        "no threshold that can fire keeps 2/h: els is exactly 0 on 160 nominal ticks (0.4%), "
        "and every threshold above 0 fires there; quietest that can fire: >= 0.5 for 3 s at "
        "4.0/h"
    )
    assert row["faults"] == 0 and row["chosen"]["detection"] is None


def test_too_few_nominal_hours_calibrate_nothing():
    log = saved(dips(0.9, 9000, [(100, 20, 0.3)]))  # a quarter of an hour
    row = choose(calibration_sweep(spi(0.6), [CalibrationLog(log, log)]), 0.0, min_hours=0.5)
    assert row["status"] == "not calibrated"
    assert row["reason"] == (
        "0.25 h of nominal driving with a value of els, fewer than the 0.5 h asked (--min-hours)"
    )
    assert row["chosen"] == row["original"] and row["original"]["episodes"] == 1
    assert row["original"]["per_hour_upper"] == pytest.approx(4.743865 / 0.25, abs=1e-4)


def test_only_loosens_unless_asked_to_tighten():
    # one hour at 0.9 with a 1 s dip to 0.7 and a 1 s dip to 0.8; the original `els >= 0.6`
    # never fires
    log = saved(dips(0.9, HOUR, [(1000, 10, 0.7), (2000, 10, 0.8)]))
    sw = calibration_sweep(spi(0.6), [CalibrationLog(log, log)])
    kept = choose(sw, per_hour=1.0)
    assert kept["status"] == "kept" and kept["chosen"] == kept["original"]
    assert kept["reason"] == "the original keeps the budget"
    # --tighten: the strictest threshold that can fire within 1/h is 0.9 (`x < 0.9` on both
    # dips), which needs `for: 1s` (11 ticks) to let the 10-tick dips through
    tight = choose(sw, per_hour=1.0, tighten=True)
    assert tight["status"] == "calibrated"
    assert (tight["chosen"]["threshold"], tight["chosen"]["for"]) == (0.9, 1.0)
    assert tight["chosen"]["episodes"] == 0 and tight["margin"] == pytest.approx(0.3)
    # at `for: 0s` the strictest within 1/h is 0.8: only the dip to 0.7 fires
    curve = {(p["threshold"], p["for"]): p["episodes"] for p in tight["curve"]}
    assert (curve[(0.8, 0.0)], curve[(0.9, 0.0)], curve[(0.9, 0.5)]) == (1, 2, 2)


def test_upper_bound_spis_loosen_upwards():
    # `els_var <= 0.05` is violated above its threshold; one hour at 0.01 with two 4 s rises to
    # 0.08 and one to 0.2: no `for:` up to 3 s filters a 4 s rise, so the threshold moves, up
    log = saved(dips(0.01, HOUR, [(1000, 40, 0.08), (2000, 40, 0.08), (3000, 40, 0.2)]), "els_var")
    sw = calibration_sweep(spi(0.05, 0.0, "<=", "els_var"), [CalibrationLog(log, log)])
    assert sw.thresholds == [0.01, 0.05, 0.08, 0.2]
    row = choose(sw, per_hour=1.0)
    assert row["original"]["episodes"] == 3 and row["status"] == "calibrated"
    # `x > 0.08` fires on the rise to 0.2 only; `x > 0.2` would never fire
    assert (row["chosen"]["threshold"], row["chosen"]["for"]) == (0.08, 0.0)
    assert row["chosen"]["episodes"] == 1 and row["margin"] == pytest.approx(-0.03)


def test_an_spi_without_a_nominal_value_is_not_calibrated_and_stops_nothing():
    log = saved(np.full(100, np.nan))
    row = choose(calibration_sweep(spi(0.6), [CalibrationLog(log, log)]), 1.0, min_hours=0.0)
    assert row["status"] == "not calibrated" and row["hours"] == 0
    assert row["reason"] == "no nominal tick with a value of els"
