"""Where the ego was during a run, and the few per-tick values the scores read.

The evaluator sees signal values, not positions; a violation map needs each episode's position
(`Episode.x`, `y`) and the driven path (`RunResult.track`), and the scores need a handful of
signals per tick. This keeps them as plain lists: a few floats a tick.
"""

from __future__ import annotations

import math

import numpy as np

from casewatch.evaluator.result import Episode
from casewatch.evaluator.scoring import TICK_SIGNALS
from casewatch.monitor.frames import Frame

#: The most points of `RunResult.track` (a long drive's path is decimated evenly).
TRACK_POINTS = 2000


class DriveLog:
    """Per tick, where the ego was (the trusted channel's estimate, or the first channel
    present) and the few signals the scores read: plain lists, a few floats a tick."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.x: list[float] = []
        self.y: list[float] = []
        self.values: dict[str, list[float]] = {name: [] for name in TICK_SIGNALS}

    def add(self, frame: Frame, trusted: str | None, values: dict) -> None:
        state = frame.channels.get(trusted) if trusted else None
        if state is None and frame.channels:
            state = next(iter(frame.channels.values()))
        self.t.append(frame.t)
        self.x.append(state.ego.x if state is not None else math.nan)
        self.y.append(state.ego.y if state is not None else math.nan)
        for name, column in self.values.items():
            v = values.get(name)
            column.append(math.nan if v is None else float(v))

    def times(self) -> np.ndarray:
        return np.asarray(self.t, dtype=float)

    def columns(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v, dtype=float) for k, v in self.values.items()}

    def place(self, episodes: list[Episode]) -> None:
        """Each episode's position: the ego's at its first tick."""
        if not self.t:
            return
        t = self.times()
        for e in episodes:
            k = min(int(np.searchsorted(t, e.start - 1e-9)), len(t) - 1)
            if math.isfinite(self.x[k]):
                e.x, e.y = round(self.x[k], 3), round(self.y[k], 3)

    def track(self) -> list[list[float]]:
        keep = [k for k in range(len(self.t)) if math.isfinite(self.x[k])]
        step = max(1, math.ceil(len(keep) / TRACK_POINTS))
        picked = keep[::step]
        if keep and picked[-1] != keep[-1]:
            picked.append(keep[-1])
        return [[round(self.t[k], 6), round(self.x[k], 3), round(self.y[k], 3)] for k in picked]
