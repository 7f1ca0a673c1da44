"""Comfort (spi-reference "Comfort"): hcs from the ego's driven path of the last
`comfort_span` seconds, ppcs from the plan. Keeps each channel's recent ego positions in `ego`
(`family.PoseWindows`, window i for channel i), which the situation family reads for the path
driven behind the ego.
"""

from __future__ import annotations

import numpy as np

from casewatch.monitor.comfort import _projection, comfort_tick
from casewatch.monitor.family import Engine, KernelOutputs, MetricFamily, PoseWindows
from casewatch.monitor.frames import ChannelState
from casewatch.safety_case.signals import channel_name

_NO_PLAN = np.zeros((0, 3))


class ComfortFamily(MetricFamily):
    name = "comfort"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        self.ego = PoseWindows(len(self.channels), p.comfort_span, p.max_gap)
        metrics = ("hcs", "ppcs")
        names = [channel_name(m, c) for c in self.channels for m in metrics]
        self._out = KernelOutputs([*names, *metrics])
        self._absent = (False, 0.0, 0.0, _NO_PLAN)
        self._settings = (float(p.comfort_span), float(p.max_gap), float(p.comfort_steepness))
        #: `_projection(h)` for the h the plans have needed (`comfort_tick`'s table)
        self._projs = np.zeros((1, 4, 1))
        self._have = np.zeros(1, dtype=np.bool_)

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        """One compiled call for every channel (`comfort.comfort_tick`)."""
        absent = self._absent
        chans = []
        for c in self.channels:
            s = states.get(c)
            if s is None:
                chans.append(absent)
            else:
                e = s.ego
                chans.append((True, float(e.x), float(e.y), s.plan))
        args = tuple(chans)
        w = self.ego
        o = self._out
        span, max_gap, steepness = self._settings
        while True:
            mask, count, live = comfort_tick(
                t,
                args,
                w.buf,
                w.start,
                w.end,
                span,
                max_gap,
                steepness,
                self._projs,
                self._have,
                o.vals,
                o.nones,
            )
            if mask != -2:
                break
            self._add_projection(count)
        o.write(out, mask, count)
        if live >= w.buf.shape[1]:
            w.make_room(live)

    def _add_projection(self, h: int) -> None:
        """Put `_projection(h)` in the kernel's table (grown to hold it)."""
        if h >= len(self._have):
            size = max(h + 1, 2 * len(self._have))
            projs = np.zeros((size, 4, 2 * size + 1))
            projs[: len(self._have), :, : self._projs.shape[2]] = self._projs
            have = np.zeros(size, dtype=np.bool_)
            have[: len(self._have)] = self._have
            self._projs, self._have = projs, have
        self._projs[h, :, : 2 * h + 1] = _projection(h)
        self._have[h] = True
