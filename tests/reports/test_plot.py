"""Plot and status-strip geometry."""

from __future__ import annotations

import math
import warnings

from casewatch.evaluator.result import Series, StatusInterval
from casewatch.reports.plot import MAX_BUCKETS, nice_ticks, plot_series, status_strip


def test_nice_ticks() -> None:
    assert nice_ticks(0.0, 10.0, 5) == [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
    assert nice_ticks(0.13, 0.87, 4) == [0.2, 0.4, 0.6, 0.8]


def test_rebucketing_keeps_extremes() -> None:
    n = 3 * MAX_BUCKETS  # 3 buckets fold into one
    lo = [0.5] * n
    hi = [0.5] * n
    lo[1234] = -2.0  # a single dip must survive decimation
    series = Series(
        formula_id="f",
        quantity="signal",
        name="els",
        bucket=0.1,
        t=[i * 0.1 for i in range(n)],
        lo=lo,
        hi=hi,
        reference=0.6,
    )
    plot = plot_series(series, [], [], 0.1)
    assert plot.buckets == MAX_BUCKETS
    # y axis spans the dip: min -2.0, max 0.6 (threshold), padded by 8 % of 2.6
    labels = [float(t.label) for t in plot.y_ticks]
    assert min(labels) <= -2.0
    assert plot.reference_y is not None
    assert plot.top < plot.reference_y < plot.top + plot.inner_h


def test_status_strip_keeps_a_short_violation_visible() -> None:
    # 1000 s run on 100 px: 10 s per pixel; a 0.1 s violation at t=500 still colours column 50
    timeline = [
        StatusInterval(status="satisfied", start=0.0, end=499.9, ticks=5000),
        StatusInterval(status="violated", start=500.0, end=500.0, ticks=1),
        StatusInterval(status="satisfied", start=500.1, end=999.9, ticks=4999),
    ]
    rects = status_strip(timeline, 0.0, 1000.0, 0.1, 100)
    violated = [r for r in rects if r.status == "violated"]
    assert len(violated) == 1 and violated[0].x == 50.0 and violated[0].w == 1.0
    assert sum(r.w for r in rects) == 100.0


def test_status_strip_leaves_out_times_that_are_not_finite() -> None:
    # a damaged result (the fuzz tests mutate run folders): a NaN interval is left out, the
    # others keep their columns; a run span that is not finite draws nothing
    timeline = [
        StatusInterval(status="satisfied", start=0.0, end=49.9, ticks=500),
        StatusInterval(status="violated", start=math.nan, end=60.0, ticks=1),
        StatusInterval(status="violated", start=50.0, end=99.9, ticks=500),
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "invalid value encountered in cast"
        rects = status_strip(timeline, 0.0, 100.0, 0.1, 10)
        assert [(r.x, r.w, r.status) for r in rects] == [
            (0.0, 5.0, "satisfied"),
            (5.0, 5.0, "violated"),
        ]
        assert status_strip(timeline, 0.0, math.inf, 0.1, 10) == []


def robustness(values: list[float]) -> Series:
    return Series(
        formula_id="CSn2",
        quantity="robustness",
        name="robustness",
        bucket=0.1,
        t=[i * 0.1 for i in range(len(values))],
        lo=values,
        hi=values,
        reference=0.0,
    )


def test_a_saturated_robustness_is_clipped_so_its_dip_below_zero_shows() -> None:
    """Tailgating robustness: 59 with no lead vehicle, 0.4 behind one, -0.5 when too close.
    On a 0-60 axis the dip is 2 px deep; clipped at 3 x 0.5 it takes a third of the plot."""
    values = [59.0] * 600 + [0.4] * 300 + [-0.5] * 30 + [0.4] * 270
    plot = plot_series(robustness(values), [], [], 0.1)
    assert plot.clipped_above == "1.5"
    labels = [float(t.label) for t in plot.y_ticks]
    assert min(labels) <= -0.4 and max(labels) <= 2.0
    zero = plot.reference_y
    assert zero is not None and zero - plot.top > 0.5 * plot.inner_h  # zero well inside
    # the dip from 0 to -0.5 is over 30 px deep (on the 0-60 axis it was 1.4 px)
    (a, va), (b, vb) = [(t.pos, float(t.label)) for t in plot.y_ticks[:2]]
    assert 0.5 * abs(a - b) / abs(vb - va) > 30
    # a robustness that stays within reach is not clipped
    assert plot_series(robustness([0.05] * 50 + [-2.1] * 10), [], [], 0.1).clipped_above == ""
    # signals are never clipped
    signal = robustness(values).model_copy(update={"quantity": "signal", "name": "lead_thw"})
    assert plot_series(signal, [], [], 0.1).clipped_above == ""
