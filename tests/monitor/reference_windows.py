"""The per-frame histories the metric families kept before issue 36 (the families now keep
them in preallocated arrays their kernels update: `family.PoseWindows`,
`history.ObjectHistory`, the similarity ELS ring): kept here as the reference the property
tests hold those to, tick for tick."""

from __future__ import annotations

from collections import deque

import numpy as np


class TimedHistory:
    """A deque of (t, value) that restarts when a sample comes more than `max_gap` after the
    previous one."""

    __slots__ = ("items", "max_gap")

    def __init__(self, size: int | None, max_gap: float):
        self.items: deque = deque(maxlen=size)
        self.max_gap = max_gap

    def push(self, t: float, value: object) -> None:
        if self.items and t - self.items[-1][0] > self.max_gap + 1e-9:
            self.items.clear()
        self.items.append((t, value))

    def recent(self, t: float) -> bool:
        """True when the last sample is within max_gap of t."""
        return bool(self.items) and t - self.items[-1][0] <= self.max_gap + 1e-9


class PoseWindow:
    """A channel's samples (t, a, b) of the last `span` seconds, oldest first, in one growable
    array (rows `start:end`), restarting like `TimedHistory` when a sample comes more than `max_gap`
    after the previous one: ego positions (t, x, y) for hcs and the driven path, reported
    speeds (t, v, 0) for ego_accel. The kernels read column views of it: no per-frame array
    building, whatever the frame rate."""

    __slots__ = ("buf", "end", "max_gap", "span", "start")

    def __init__(self, span: float, max_gap: float, capacity: int = 64):
        self.buf = np.empty((capacity, 3))
        self.start = 0
        self.end = 0
        self.span = span
        self.max_gap = max_gap

    def push(self, t: float, x: float, y: float) -> None:
        buf = self.buf
        if self.end > self.start and t - buf[self.end - 1, 0] > self.max_gap + 1e-9:
            self.start = self.end = 0
        if self.end == len(buf):
            live = buf[self.start : self.end].copy()
            if len(live) * 2 > len(buf):
                self.buf = buf = np.empty((2 * len(buf), 3))
            buf[: len(live)] = live
            self.start, self.end = 0, len(live)
        row = buf[self.end]  # three float writes: cheaper than a tuple to array
        row[0] = t
        row[1] = x
        row[2] = y
        self.end += 1
        # keep the newest sample at or before t - span: it tells that the span is covered
        limit = t - self.span + 1e-9
        while self.end - self.start > 1 and buf[self.start + 1, 0] <= limit:
            self.start += 1

    def window(self) -> np.ndarray:
        """(n, 3) rows [t, x, y], oldest first (a view)."""
        return self.buf[self.start : self.end]
