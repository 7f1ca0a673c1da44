"""Where the ego was during a run, and the few per-tick values the scores read.

The evaluator sees signal values, not positions; a violation map needs each episode's position
(`Episode.x`, `y`) and the driven path (`RunResult.track`), and the scores need a handful of
signals per tick. This keeps them as float arrays: a few floats a tick.
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
    present) and the few signals the scores read: preallocated float arrays (doubled when
    full), a few floats a tick, one row written per tick."""

    def __init__(self) -> None:
        self.n = 0
        self._t = np.empty(1024)
        self._xy = np.empty((1024, 2))
        self._values = np.empty((1024, len(TICK_SIGNALS)))

    def add(self, frame: Frame, trusted: str | None, values: dict) -> None:
        n = self.n
        if n == len(self._t):
            self._t = np.concatenate([self._t, np.empty(n)])
            self._xy = np.concatenate([self._xy, np.empty_like(self._xy)])
            self._values = np.concatenate([self._values, np.empty_like(self._values)])
        state = frame.channels.get(trusted) if trusted else None
        if state is None and frame.channels:
            state = next(iter(frame.channels.values()))
        self._t[n] = frame.t
        self._xy[n] = (state.ego.x, state.ego.y) if state is not None else _NO_POSITION
        # None is stored as NaN, every other value as float()
        self._values[n] = list(map(values.get, TICK_SIGNALS))
        self.n = n + 1

    @property
    def t(self) -> list[float]:
        return self._t[: self.n].tolist()

    @property
    def x(self) -> list[float]:
        return self._xy[: self.n, 0].tolist()

    @property
    def y(self) -> list[float]:
        return self._xy[: self.n, 1].tolist()

    def times(self) -> np.ndarray:
        return self._t[: self.n].copy()

    def columns(self) -> dict[str, np.ndarray]:
        values = self._values[: self.n]
        return {name: values[:, j].copy() for j, name in enumerate(TICK_SIGNALS)}

    def place(self, episodes: list[Episode]) -> None:
        """Each episode's position: the ego's at its first tick."""
        if not self.n:
            return
        t = self._t[: self.n]
        for e in episodes:
            k = min(int(np.searchsorted(t, e.start - 1e-9)), self.n - 1)
            x, y = self._xy[k].tolist()
            if math.isfinite(x):
                e.x, e.y = round(x, 3), round(y, 3)

    def track(self) -> list[list[float]]:
        t, x, y = self.t, self.x, self.y
        keep = [k for k in range(len(t)) if math.isfinite(x[k])]
        step = max(1, math.ceil(len(keep) / TRACK_POINTS))
        picked = keep[::step]
        if keep and picked[-1] != keep[-1]:
            picked.append(keep[-1])
        return [[round(t[k], 6), round(x[k], 3), round(y[k], 3)] for k in picked]


_NO_POSITION = (math.nan, math.nan)
