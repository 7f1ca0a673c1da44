"""Label interval rules (examples/sim/labels.py), by hand and by property."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from examples.sim.labels import intervals


def test_runs_merge_across_short_gaps_and_short_runs_drop() -> None:
    t = np.round(np.arange(0, 6.0, 0.1), 1)
    mask = np.zeros(len(t), dtype=bool)
    mask[(t >= 1.0) & (t <= 1.5)] = True  # 0.5 s
    mask[(t >= 2.0) & (t <= 2.6)] = True  # 0.4 s after the first: merges -> [1.0, 2.6]
    mask[(t >= 4.0) & (t <= 4.5)] = True  # alone and 0.5 s long: dropped
    assert intervals(t, mask) == [(1.0, 2.6)]
    # with no minimum duration the short run stays, and a gap of exactly 1.4 s does not merge
    assert intervals(t, mask, min_duration=0.0) == [(1.0, 2.6), (4.0, 4.5)]


def test_empty_mask_gives_no_interval() -> None:
    assert intervals(np.arange(5) * 0.1, np.zeros(5, dtype=bool)) == []


@settings(max_examples=60, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=200))
def test_intervals_are_sorted_disjoint_and_bounded_by_true_ticks(bits: list[bool]) -> None:
    t = np.arange(len(bits)) * 0.1
    mask = np.array(bits)
    out = intervals(t, mask)
    for a, b in out:
        assert b - a >= 1.0 - 1e-9
        ia, ib = round(a / 0.1), round(b / 0.1)
        assert mask[ia] and mask[ib]
    for (_, b), (c, _) in pairwise(out):
        assert c - b >= 1.0 - 1e-9
