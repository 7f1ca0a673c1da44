"""Decimated series keep min/max per bucket and stay bounded."""

from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.evaluator.series import DecimatedSeries


def test_short_series_is_kept_per_tick():
    s = DecimatedSeries(period=0.1, max_points=10)
    for i, v in enumerate([0.5, None, 0.7]):
        s.add(i * 0.1, v)
    assert s.times() == [0.0, 0.1, 0.2]
    assert s.lo == [0.5, None, 0.7] and s.hi == [0.5, None, 0.7]


def test_long_series_is_halved_and_keeps_extremes():
    s = DecimatedSeries(period=0.1, max_points=2)  # at most 4 buckets
    values = [1.0, 2.0, -3.0, 4.0, 5.0, 6.0, 7.0, 0.5]
    for i, v in enumerate(values):
        s.add(round(i * 0.1, 6), v)
    # 8 ticks -> width 0.2 (4 buckets of 2 ticks): (1,2), (-3,4), (5,6), (7,0.5)
    assert abs(s.width - 0.2) < 1e-12
    assert s.lo == [1.0, -3.0, 5.0, 0.5]
    assert s.hi == [2.0, 4.0, 6.0, 7.0]


@settings(max_examples=50, deadline=None)
@given(st.lists(st.one_of(st.none(), st.floats(-10, 10)), min_size=1, max_size=400))
def test_bounded_and_extremes_preserved(values):
    s = DecimatedSeries(period=0.1, max_points=8)
    for i, v in enumerate(values):
        s.add(round(i * 0.1, 6), v)
    assert len(s.lo) <= 16
    present = [v for v in values if v is not None]
    if present:
        assert min(v for v in s.lo if v is not None) == min(present)
        assert max(v for v in s.hi if v is not None) == max(present)
    else:
        assert all(v is None for v in s.lo)
