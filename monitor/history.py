"""Metrics over a channel's (or pair's) recent past: els_var and chpps.

The state (windows of values, stored plans) lives in `monitor.engine`; these are the pure
computations over it.
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections.abc import Sequence

import numpy as np
import shapely

from monitor.similarity import frechet

#: Tolerance [s] when clipping plans to their common time range: frame times and dt values are
#: decimal numbers, so `dt - age` lands a few ulps off the grid.
TIME_EPS = 1e-9


def els_var(window: Sequence[float], size: int) -> float | None:
    """Sample variance (divisor n - 1) of the last `size` ELS values; None until full."""
    if len(window) < size:
        return None
    return float(np.var(np.asarray(window[-size:], dtype=float), ddof=1))


def frechet_many(pairs: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """Discrete Fréchet distances of many (P, Q) point-sequence pairs, one GEOS call for all
    pairs whose sequences have at least two points."""
    out = np.empty(len(pairs))
    multi = [k for k, (p, q) in enumerate(pairs) if len(p) > 1 and len(q) > 1]
    for k, (p, q) in enumerate(pairs):
        if len(p) == 1 or len(q) == 1:
            out[k] = frechet(p, q)
    if multi:
        ps = [pairs[k][0] for k in multi]
        qs = [pairs[k][1] for k in multi]
        la = shapely.linestrings(
            np.concatenate(ps), indices=np.repeat(np.arange(len(ps)), [len(p) for p in ps])
        )
        lb = shapely.linestrings(
            np.concatenate(qs), indices=np.repeat(np.arange(len(qs)), [len(q) for q in qs])
        )
        out[multi] = shapely.frechet_distance(la, lb)
    return out


def chpps(
    current: np.ndarray, stored: Sequence[tuple[float, np.ndarray]], decay: float
) -> float | None:
    """Channel Planned Path Similarity.

    `current` (N, 3) plan; `stored` the earlier plans, most recent first, as (age [s], plan).
    Stored plan j (rank j = 1 most recent) is shifted into the current time base (dt - age),
    both plans are clipped to their common time range, f_j = inv(fd). Score = weighted mean
    with w_j = k^(j-1) over the stored plans that overlap; None when none overlaps.
    """
    if len(current) == 0:
        return None
    cur_dt = current[:, 0].tolist()  # bisect on lists: far cheaper than numpy calls per plan
    c0, c1 = cur_dt[0], cur_dt[-1]
    pairs: list[tuple[np.ndarray, np.ndarray]] = []
    weights: list[float] = []
    for rank, (age, plan) in enumerate(stored):
        if len(plan) == 0:
            continue
        sdt = plan[:, 0].tolist()
        lo = max(c0, sdt[0] - age) - TIME_EPS
        hi = min(c1, sdt[-1] - age) + TIME_EPS
        if lo > hi:
            continue
        # Both dt columns are sorted: the common range is one slice of each.
        a = bisect_left(cur_dt, lo)
        b = bisect_right(cur_dt, hi)
        sa = bisect_left(sdt, lo + age)
        sb = bisect_right(sdt, hi + age)
        if a >= b or sa >= sb:
            continue  # Decision: a common range with no sample of one plan is no overlap
        pairs.append((current[a:b, 1:3], plan[sa:sb, 1:3]))
        # Decision: j is the rank among stored plans (1 = most recent), skipped ones included.
        weights.append(decay**rank)
    if not pairs:
        return None
    f = 1.0 / (1.0 + frechet_many(pairs))
    w = np.asarray(weights)
    return float(f @ w / w.sum())
