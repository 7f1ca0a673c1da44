"""Run-length recording of a per-tick value: status timelines, data gaps, arbitration.

Per-tick copies would grow with run length; a timeline of intervals grows only with the number
of changes, which keeps an 8-hour run's record small.
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass, field


@dataclass
class Run:
    value: Hashable
    start: float
    end: float
    ticks: int


@dataclass
class RunLength:
    """Appends `(t, value)` ticks, merging equal consecutive values into one `Run`."""

    runs: list[Run] = field(default_factory=list)

    def add(self, t: float, value: Hashable) -> None:
        if self.runs and self.runs[-1].value == value:
            last = self.runs[-1]
            last.end = t
            last.ticks += 1
        else:
            self.runs.append(Run(value, t, t, 1))

    def add_span(self, start: float, end: float, value: Hashable, ticks: int) -> None:
        """Append `ticks` ticks of `value` covering [start, end] at once."""
        if self.runs and self.runs[-1].value == value:
            last = self.runs[-1]
            last.end = end
            last.ticks += ticks
        else:
            self.runs.append(Run(value, start, end, ticks))

    def totals(self) -> dict[Hashable, int]:
        out: dict[Hashable, int] = {}
        for run in self.runs:
            out[run.value] = out.get(run.value, 0) + run.ticks
        return out
