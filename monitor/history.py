"""Metrics over a channel's (or pair's) recent past: els_var and chpps.

The state (windows of values, stored plans) lives in `monitor.engine`; these are the pure
computations over it.
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections.abc import Sequence

import numpy as np
import shapely

from monitor.jit import kernel
from monitor.similarity import frechet

#: Tolerance [s] when clipping plans to their common time range: frame times and dt values are
#: decimal numbers, so `dt - age` lands a few ulps off the grid.
TIME_EPS = 1e-9


def els_var(window: Sequence[float], size: int) -> float | None:
    """Sample variance (divisor n - 1) of the last `size` ELS values; None until full."""
    if len(window) < size:
        return None
    return _sample_variance(np.array(window[-size:], dtype=float))


@kernel
def _sample_variance(x):  # pragma: no cover - compiled
    """np.var(x, ddof=1)'s arithmetic (mean first, then the squared deviations)."""
    n = x.shape[0]
    total = 0.0
    for v in x:
        total += v
    mean = total / n
    ss = 0.0
    for v in x:
        ss += (v - mean) * (v - mean)
    return ss / (n - 1)


def frechet_many(pairs: Sequence[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """Discrete Fréchet distances of many (P, Q) point-sequence pairs, one GEOS call for all
    pairs whose sequences have at least two points.

    All 2m line strings are built by one `shapely.linestrings` call on one concatenated
    coordinate array (P's first, then Q's): building geometries costs per call as much as per
    geometry at these sizes.
    """
    m = len(pairs)
    if m == 0:
        return np.empty(0)
    ps, qs = zip(*pairs, strict=True)
    arrs = ps + qs
    lens = list(map(len, arrs))
    if 1 not in lens:
        lines = shapely.linestrings(np.concatenate(arrs), indices=np.arange(2 * m).repeat(lens))
        return shapely.frechet_distance(lines[:m], lines[m:])
    # A one-point sequence is not a line string: those pairs go to `frechet`, the rest batched.
    out = np.empty(m)
    multi = [k for k in range(m) if lens[k] > 1 and lens[m + k] > 1]
    for k in range(m):
        if lens[k] == 1 or lens[m + k] == 1:
            out[k] = frechet(*pairs[k])
    if multi:
        out[multi] = frechet_many([pairs[k] for k in multi])
    return out


def chpps_pairs(
    current: np.ndarray,
    stored: Sequence[tuple[float, np.ndarray]],
    decay: float,
    current_dt: list[float] | None = None,
    stored_dt: Sequence[list[float]] | None = None,
) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[float]]:
    """The Fréchet inputs of `chpps` and their weights: for each stored plan (age, plan), most
    recent first, that overlaps the current plan, the two point sequences cut to their common
    time range and w_j = k^(j-1). `current_dt` / `stored_dt` are the plans' dt columns as
    lists when the caller already has them (the engine keeps them with the stored plans)."""
    cur_dt = current[:, 0].tolist() if current_dt is None else current_dt
    c0, c1 = cur_dt[0], cur_dt[-1]
    cur_xy = current[:, 1:3]  # sliced once: a 1-d slice of it per pair is cheaper
    pairs: list[tuple[np.ndarray, np.ndarray]] = []
    weights: list[float] = []
    for rank, (age, plan) in enumerate(stored):
        if len(plan) == 0:
            continue
        # bisect on lists: far cheaper than numpy calls per plan
        sdt = plan[:, 0].tolist() if stored_dt is None else stored_dt[rank]
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
        pairs.append((cur_xy[a:b], plan[sa:sb, 1:3]))
        # Decision: j is the rank among stored plans (1 = most recent), skipped ones included.
        weights.append(decay**rank)
    return pairs, weights


@kernel
def _weighted_inv_mean(distances, weights):  # pragma: no cover - compiled
    num = 0.0
    den = 0.0
    for j in range(distances.shape[0]):
        num += weights[j] / (1.0 + distances[j])
        den += weights[j]
    return num / den


def chpps_score(distances: np.ndarray, weights: Sequence[float]) -> float:
    """sum_j w_j inv(fd_j) / sum_j w_j (one compiled call: numpy's version is five)."""
    return _weighted_inv_mean(
        np.asarray(distances, dtype=np.float64), np.asarray(weights, dtype=np.float64)
    )


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
    pairs, weights = chpps_pairs(current, stored, decay)
    if not pairs:
        return None
    return chpps_score(frechet_many(pairs), weights)
