"""Bounded, decimated time series for the report's plots.

A live run has no known length, so the bucket width starts at one sampling period and doubles
(merging neighbouring buckets) whenever the series would exceed `2 * max_points` buckets. Each
bucket keeps the minimum and maximum value, so a short dip below a threshold survives
decimation. Memory stays O(max_points) however long the run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class DecimatedSeries:
    period: float
    max_points: int = 1000
    t0: float | None = None
    width: float = 0.0
    lo: list[float | None] = field(default_factory=list)
    hi: list[float | None] = field(default_factory=list)

    def add(self, t: float, value: float | None) -> None:
        if self.t0 is None:
            self.t0 = t
            self.width = self.period
        index = math.floor((t - self.t0) / self.width + 1e-9)
        while index >= 2 * self.max_points:
            self._halve()
            index = math.floor((t - self.t0) / self.width + 1e-9)
        if index >= len(self.lo):
            grow = index + 1 - len(self.lo)
            self.lo.extend([None] * grow)
            self.hi.extend([None] * grow)
        if value is None or not math.isfinite(value):
            return
        lo, hi = self.lo[index], self.hi[index]
        self.lo[index] = value if lo is None else min(lo, value)
        self.hi[index] = value if hi is None else max(hi, value)

    def _halve(self) -> None:
        self.width *= 2
        lo, hi = self.lo, self.hi
        self.lo = [_pick(min, lo[i : i + 2]) for i in range(0, len(lo), 2)]
        self.hi = [_pick(max, hi[i : i + 2]) for i in range(0, len(hi), 2)]

    def times(self) -> list[float]:
        if self.t0 is None:
            return []
        return [round(self.t0 + i * self.width, 6) for i in range(len(self.lo))]


def _pick(fn, values: list[float | None]) -> float | None:
    present = [v for v in values if v is not None]
    return fn(present) if present else None
