"""Data gaps: ticks where a formula could not be judged because an input had no value.

spi-reference, "Missing data": a tick without a value is never a pass. Each formula's
consecutive no-value ticks become one gap record with the union of the signals that were
missing, closed (and emitted) when data returns.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class OpenGap:
    start: float
    end: float
    ticks: int
    missing: set[str] = field(default_factory=set)


@dataclass
class ClosedGap:
    start: float
    end: float
    ticks: int
    missing: list[str]


@dataclass
class GapTracker:
    current: OpenGap | None = None

    def missing(
        self, t: float, signals: list[str], ticks: int = 1, start: float | None = None
    ) -> None:
        """Record `ticks` tick(s) without value ending at `t` (starting at `start` if given)."""
        if self.current is None:
            self.current = OpenGap(t if start is None else start, t, 0)
        self.current.end = t
        self.current.ticks += ticks
        self.current.missing.update(signals)

    def close(self) -> ClosedGap | None:
        gap, self.current = self.current, None
        if gap is None:
            return None
        return ClosedGap(gap.start, gap.end, gap.ticks, sorted(gap.missing))
