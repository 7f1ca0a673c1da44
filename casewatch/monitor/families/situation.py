"""Situation signals (spi-reference "Situation signals"): leader and follower gaps, headways,
times to collision, ego speed and acceleration, per channel and worst over the channels that
can see the region.
"""

from __future__ import annotations

import math

import numpy as np
from numba.core.errors import TypingError

from casewatch.monitor.families.comfort import ComfortFamily
from casewatch.monitor.family import Engine, KernelOutputs, MetricFamily, PoseWindows
from casewatch.monitor.frames import ChannelState
from casewatch.monitor.situation import (
    GAP_CAP,
    TICK_METRICS,
    ego_half_length,
    ego_half_width,
    situation_tick,
)
from casewatch.safety_case.signals import channel_name

_NO_PLAN = np.zeros((0, 3))
_NO_POINTS = np.zeros((0, 2))
_NO_VALUES = np.zeros(0)


def _absent(behind: bool) -> tuple:
    """`situation_tick`'s row of a channel absent at the tick (its types those of a present
    one: one compiled variant)."""
    return (
        False,
        behind,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        _NO_PLAN,
        _NO_POINTS,
        _NO_VALUES,
        _NO_POINTS,
        _NO_POINTS,
        _NO_VALUES,
    )


_ABSENT = {True: _absent(True), False: _absent(False)}


def _c(a: np.ndarray) -> np.ndarray:
    """`a` as a C-contiguous float array (the same values)."""
    return np.ascontiguousarray(a, dtype=np.float64)


class SituationFamily(MetricFamily):
    name = "situation"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        names = [channel_name(m, c) for c in self.channels for m in TICK_METRICS]
        self._out = KernelOutputs([*names, *TICK_METRICS])
        #: per channel, rows (t, reported speed, 0) of the last second: ego_accel's slope
        self._speeds = PoseWindows(len(self.channels), 1.0, p.max_gap)
        self._comfort: ComfortFamily | None = None
        self._settings = (float(p.lane_half_width), GAP_CAP + 50.0, float(p.max_gap))
        #: set once a tick's arrays came in mixed layouts or types: from then on they are
        #: made C-contiguous floats first (the kernel takes one type for every channel)
        self._normalise = False

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        """spi-reference "Situation signals": leader and follower of each channel's ego, and
        the unsuffixed worst over the channels that can see the region (ahead: every channel;
        behind: the all-round ones). One compiled call for every channel
        (`situation.situation_tick`)."""
        coverage = self.coverage
        chans = []
        all_seeing = True
        for c in self.channels:
            behind = coverage[c].fov_deg >= 360.0
            if not behind:
                all_seeing = False
            s = states.get(c)
            if s is None:
                chans.append(_ABSENT[behind])
                continue
            e = s.ego
            o = s.objects
            half = e.half
            if half is not None:
                hl, hw = half[0], abs(half[1])
            else:
                hl, hw = ego_half_length(e), ego_half_width(e)
            chans.append(
                (
                    True,
                    behind,
                    float(e.x),
                    float(e.y),
                    float(e.yaw),
                    math.hypot(e.vx, e.vy),
                    float(hl),
                    float(hw),
                    s.plan,
                    o.pos,
                    o.yaw,
                    o.half,
                    o.vel,
                    _NO_VALUES,
                )
            )
        if self._normalise:
            chans = [(*ch[:8], *map(_c, ch[8:])) for ch in chans]
        try:
            mask, count, live = self._tick(t, tuple(chans), all_seeing)
        except TypingError:
            if self._normalise:
                raise
            self._normalise = True  # mixed layouts: see __init__
            chans = [(*ch[:8], *map(_c, ch[8:])) for ch in chans]
            mask, count, live = self._tick(t, tuple(chans), all_seeing)
        if mask == -2:  # polygon footprints: their bounding radii too
            chans = [
                ch if not ch[0] else (*ch[:13], _c(states[c].objects.radii))
                for c, ch in zip(self.channels, chans, strict=True)
            ]
            mask, count, live = self._tick(t, tuple(chans), all_seeing)
        self._out.write(out, mask, count)
        if live >= self._speeds.buf.shape[1]:
            self._speeds.make_room(live)

    def _tick(self, t: float, chans: tuple, all_seeing: bool) -> tuple[int, int, int]:
        comfort = self._comfort
        if comfort is None:
            comfort = self._comfort = self.engine.family(ComfortFamily)
        driven = comfort.ego
        speeds = self._speeds
        o = self._out
        half_width, lookahead, max_gap = self._settings
        return situation_tick(  # type: ignore[no-any-return]
            t,
            chans,
            driven.buf,
            driven.start,
            driven.end,
            speeds.buf,
            speeds.start,
            speeds.end,
            half_width,
            lookahead,
            max_gap,
            all_seeing,
            o.vals,
            o.nones,
        )
