"""`MetricEngine`: every built-in signal, tick by tick, with the history the metrics need.

The engine resamples each frame once, steps every registered metric family
(`casewatch.monitor.registry`) and passes the frame's world inputs and scalar signals through;
the families name their outputs exactly as `safety_case.signals.builtin_signals` does. It judges
nothing. Each family keeps the history it needs (ELS window, stored plans, previous objects, ego
positions) per channel or pair; a history restarts when the time since its last sample exceeds
`max_gap`, which covers both a gap between frames and a channel absent for too long.
"""

from __future__ import annotations

from collections.abc import Mapping
from itertools import combinations
from time import perf_counter
from typing import TypeVar

import numpy as np

from casewatch.monitor.family import MetricFamily
from casewatch.monitor.frames import ChannelState, Coverage, Frame
from casewatch.monitor.registry import FAMILIES as REGISTERED
from casewatch.monitor.resample import objects_on_grid, plan_settings, prepare_channel
from casewatch.monitor.world import WORLD_SIGNALS
from casewatch.safety_case.model import MetricParams
from casewatch.safety_case.signals import builtin_signals

#: Metric families, as the benchmark reports them: resampling, then each registered family.
FAMILIES = ("resampling", *(family.name for family in REGISTERED))

F = TypeVar("F", bound=MetricFamily)

_FLOAT = np.dtype(np.float64)


class MetricEngine:
    """Stateful metric computation for one stream.

    `step(frame)` returns a value (float, or None for "no value") for every name of
    `builtin_signals(channels)`, plus the frame's scalar `signals` passed through. The
    recommended channel of the tick is `last_arbitration` / `arbitration()`, kept out of the
    float dict because the evaluator feeds that dict to STL.
    """

    def __init__(
        self,
        params: MetricParams,
        channels: list[str],
        coverage: Mapping[str, Coverage] | None = None,
    ):
        if len(set(channels)) != len(channels) or not channels:
            raise ValueError(f"channels must be a non-empty list of distinct names: {channels}")
        self.params = params
        self.channels = list(channels)
        #: What each channel can see (spi-reference "Channel coverage"); all-round when absent.
        self.coverage = {c: (coverage or {}).get(c, Coverage()) for c in self.channels}
        self.pairs = list(combinations(self.channels, 2))
        self.signal_names = list(builtin_signals(self.channels))
        #: every signal with no value: each step's output starts as a copy (cheaper than
        #: dict.fromkeys over the names every tick)
        self._blank: dict[str, float | None] = dict.fromkeys(self.signal_names)
        self.last_arbitration: str | None = None
        self.last_t: float | None = None
        #: Seconds spent per family in the last step (the benchmark reads this).
        self.timings: dict[str, float] = dict.fromkeys(FAMILIES, 0.0)
        self.families = [family(self) for family in REGISTERED]
        self._by_type: dict[type[MetricFamily], MetricFamily] = {type(f): f for f in self.families}
        self._steps = [(f.step, f.name) for f in self.families]
        p = params
        #: `resample.prepare_channel`'s settings
        self._grid = plan_settings(p.plan_smoothing, p.resample_step, p.plan_standstill)

    def family(self, kind: type[F]) -> F:
        """The engine's instance of a registered family (a family reads another's state)."""
        return self._by_type[kind]  # type: ignore[return-value]

    def arbitration(self) -> str | None:
        """The channel recommended at the last step (argmax of ss_i), or None."""
        return self.last_arbitration

    def reset(self) -> None:
        """Forget all history (a new stream)."""
        self.__init__(self.params, self.channels, self.coverage)  # type: ignore[misc]

    def step(self, frame: Frame) -> dict[str, float | None]:
        if self.last_t is not None and frame.t <= self.last_t:
            raise ValueError(
                f"frame t = {frame.t:g} (line {frame.line}) does not increase strictly "
                f"(previous t = {self.last_t:g})"
            )
        t = self.last_t = frame.t
        out = self._blank.copy()
        timings = self.timings
        # one clock read between two stages: each stage's time is the difference
        clock = perf_counter
        start = clock()
        states = self._resampled(frame)
        now = clock()
        timings["resampling"] = now - start
        for step, name in self._steps:
            step(t, states, out)
            start, now = now, clock()
            timings[name] = now - start
        if frame.world is not None:
            out.update(frame.world)
        signals = frame.signals
        # out's view first: `isdisjoint` then walks the frame's few signals and looks each up
        # in out; the other way round it walks all of out's names (about 1 us a tick)
        if out.keys().isdisjoint(signals):
            out.update(signals)  # the loop below, when no key is already there
        else:
            for key, val in signals.items():
                # a world input may also come as a scalar signal (a bag topic, a script),
                # unless the frame's `world` reported it
                if key not in out or (key in WORLD_SIGNALS and out[key] is None):
                    out[key] = val
        return out

    def _resampled(self, frame: Frame) -> dict[str, ChannelState]:
        """The frame's channels with plans and predictions on the canonical time grid
        (spi-reference "Resampling"): every metric below reads these, never the raw samples.
        One compiled call per channel (`resample.prepare_channel`); the plans come out as
        C-contiguous float arrays, which the families' kernels take for every channel."""
        half, smooth, step, radius = self._grid
        states = {}
        for c, s in frame.channels.items():
            plan = s.plan
            objects = s.objects
            if plan.dtype is not _FLOAT or plan.ndim != 2:
                plan = np.ascontiguousarray(plan, dtype=_FLOAT)
            plan, start = prepare_channel(
                plan, objects.pred, objects.pred_len, half, smooth, step, radius
            )
            if start != 1:
                objects = objects_on_grid(objects, start, step)
            states[c] = ChannelState(s.ego, plan, objects)
        return states
