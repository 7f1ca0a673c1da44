"""Where the ego was during a run, and the few per-tick values the scores read.

The evaluator sees signal values, not positions; a violation map needs each episode's position
(`Episode.x`, `y`) and the driven path (`RunResult.track`), and the scores need a handful of
signals per tick. This keeps them as float arrays: a few floats a tick.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from casewatch.evaluator.result import Episode
from casewatch.evaluator.scoring import TICK_SIGNALS
from casewatch.evaluator.signal_store import float_rows, room_for
from casewatch.monitor.frames import Frame

#: The most points of `RunResult.track` (a long drive's path is decimated evenly).
TRACK_POINTS = 2000


class DriveLog:
    """Per tick, where the ego was (the trusted channel's estimate, or the first channel
    present) and the few signals the scores read: float arrays (doubled when full), a few
    floats a tick. A tick waits as one tuple (t, x, y, the signals) and every `BLOCK` ticks
    they go into the arrays in one `np.fromiter` (as `signal_store.Columns` does, and why);
    every reader flushes first."""

    #: Ticks that wait as tuples before one conversion (see `signal_store.Columns.BLOCK`).
    BLOCK = 32

    def __init__(self) -> None:
        self.n = 0
        #: per tick its time (its own array: `place` searches it), and x, y, then the
        #: TICK_SIGNALS values (NaN: none); `_stored` rows filled
        self._t = np.empty(1024)
        self._data = np.empty((1024, 2 + len(TICK_SIGNALS)))
        self._stored = 0
        self._rows: list[tuple[Any, ...]] = []

    def add(self, frame: Frame, trusted: str | None, values: dict) -> None:
        channels = frame.channels
        state = channels.get(trusted) if trusted else None
        if state is None and channels:
            state = next(iter(channels.values()))
        if state is not None:
            ego = state.ego
            row = (frame.t, ego.x, ego.y, *map(values.get, TICK_SIGNALS))
        else:
            row = (frame.t, math.nan, math.nan, *map(values.get, TICK_SIGNALS))
        rows = self._rows
        rows.append(row)
        self.n += 1
        if len(rows) >= self.BLOCK:
            self._flush()

    def _flush(self) -> None:
        """The waiting ticks into the array, in one conversion (None as NaN, every other
        value as float(), as a row assignment converts them)."""
        rows = self._rows
        if not rows:
            return
        start = self._stored
        stop = start + len(rows)
        self._t = room_for(self._t, stop)
        self._data = room_for(self._data, stop)
        block = float_rows(rows, 1 + self._data.shape[1])
        self._t[start:stop] = block[:, 0]
        self._data[start:stop] = block[:, 1:]
        self._stored = stop
        self._rows = []

    def _filled(self) -> tuple[np.ndarray, np.ndarray]:
        """Every tick's time and row (x, y, the signals), the waiting ones flushed."""
        self._flush()
        return self._t[: self.n], self._data[: self.n]

    @property
    def t(self) -> list[float]:
        return self._filled()[0].tolist()

    @property
    def x(self) -> list[float]:
        return self._filled()[1][:, 0].tolist()

    @property
    def y(self) -> list[float]:
        return self._filled()[1][:, 1].tolist()

    def times(self) -> np.ndarray:
        return self._filled()[0].copy()

    def columns(self) -> dict[str, np.ndarray]:
        values = self._filled()[1][:, 2:]
        return {name: values[:, j].copy() for j, name in enumerate(TICK_SIGNALS)}

    def place(self, episodes: list[Episode]) -> None:
        """Each episode's position: the ego's at its first tick."""
        if not self.n:
            return
        t, data = self._filled()
        for e in episodes:
            k = min(int(np.searchsorted(t, e.start - 1e-9)), self.n - 1)
            x, y = data[k, :2].tolist()
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
