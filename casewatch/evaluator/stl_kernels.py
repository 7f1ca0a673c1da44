"""Compiled loops for the temporal operators of the whole-log STL engine (`vector_eval`).

Every kernel works on the compacted array of one formula's evaluated ticks, with `start[i]`
and `end[i]` the first and one-past-last index of the run of ticks (segment) that tick `i`
belongs to: windows never reach across a segment, as the online monitor restarts there. Bounds
are in samples. Minima and maxima involve no arithmetic, so every value equals rtamt's exactly.

- `past_window`: max (`once`) or min (`historically`) over `i-hi .. i-lo`, a monotonic deque
  per segment (Lemire's streaming filter): O(n) whatever the window.
- `since`: `l since[lo:hi] r`, O(n) by recurrence when unbounded from 0, else O(n * hi).
- `until`: `l until[lo:hi] r`, O(n * hi) (offline formulas only).
Future windows are past windows of the reversed arrays (`vector_eval`).
"""

from __future__ import annotations

import numpy as np

from casewatch.monitor.jit import kernel


@kernel
def past_window(values, start, lo, hi, take_max):  # pragma: no cover - compiled
    """out[i] = max/min of values[j] for j in [max(start[i], i - hi), i - lo]; -inf/+inf
    (the identity) when that range is empty. hi < 0: unbounded (from the segment start)."""
    n = values.shape[0]
    out = np.empty(n)
    empty = -np.inf if take_max else np.inf
    dq = np.empty(n, dtype=np.int64)  # indices, values monotonic from head to tail
    head = 0
    tail = 0
    seg = -1
    for i in range(n):
        if start[i] != seg:  # a new segment: forget everything
            seg = start[i]
            head = 0
            tail = 0
        r = i - lo  # the newest index the window of i takes
        if r >= seg:
            v = values[r]
            while tail > head and (
                (values[dq[tail - 1]] <= v) if take_max else (values[dq[tail - 1]] >= v)
            ):
                tail -= 1
            dq[tail] = r
            tail += 1
        if hi >= 0:
            oldest = max(seg, i - hi)
            while tail > head and dq[head] < oldest:
                head += 1
        out[i] = values[dq[head]] if tail > head else empty
    return out


@kernel
def since(left, right, start, lo, hi):  # pragma: no cover - compiled
    """out[t] = max over s in [max(start[t], t - hi), t - lo] of min(right[s], min of left
    over s+1 .. t); -inf when that range is empty. hi < 0: unbounded."""
    n = left.shape[0]
    out = np.empty(n)
    if lo == 0 and hi < 0:  # S(t) = max(r(t), min(l(t), S(t-1))), S before the segment -inf
        prev = -np.inf
        for t in range(n):
            if start[t] == t:
                prev = -np.inf
            prev = max(right[t], min(left[t], prev))
            out[t] = prev
        return out
    for t in range(n):
        first = start[t] if hi < 0 else max(start[t], t - hi)
        best = -np.inf
        running = np.inf  # min of left over s+1 .. t
        for s in range(t, first - 1, -1):
            if s <= t - lo:
                best = max(best, min(right[s], running))
            running = min(running, left[s])
        out[t] = best
    return out


@kernel
def until(left, right, end, lo, hi):  # pragma: no cover - compiled
    """out[t] = max over s in [t + lo, min(t + hi, end[t] - 1)] of min(right[s], min of left
    over t .. s-1); -inf when that range is empty (the segment's end reads as missing)."""
    n = left.shape[0]
    out = np.empty(n)
    for t in range(n):
        last = min(t + hi, end[t] - 1)
        best = -np.inf
        running = np.inf  # min of left over t .. s-1
        for s in range(t, last + 1):
            if s >= t + lo:
                best = max(best, min(right[s], running))
            running = min(running, left[s])
        out[t] = best
    return out
