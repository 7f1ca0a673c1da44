"""Comfort (spi-reference "Comfort"): hcs from the ego's driven path of the last
`comfort_span` seconds, ppcs from the plan. Keeps each channel's recent ego positions in `ego`,
which the situation family reads for the path driven behind the ego.
"""

from __future__ import annotations

from casewatch.monitor.comfort import hcs, ppcs
from casewatch.monitor.family import Engine, MetricFamily, PoseWindow, worst
from casewatch.monitor.frames import ChannelState
from casewatch.safety_case.signals import channel_name


class ComfortFamily(MetricFamily):
    name = "comfort"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        self.ego = {c: PoseWindow(p.comfort_span, p.max_gap) for c in self.channels}
        self._channel_names = {
            c: {m: channel_name(m, c) for m in ("hcs", "ppcs")} for c in self.channels
        }
        self._hcs_names = [self._channel_names[c]["hcs"] for c in self.channels]
        self._ppcs_names = [self._channel_names[c]["ppcs"] for c in self.channels]

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        p = self.params
        for c in self.channels:
            s = states.get(c)
            if s is None:
                continue
            window = self.ego[c]
            window.push(t, s.ego.x, s.ego.y)
            rows = window.window()
            names = self._channel_names[c]
            out[names["hcs"]] = hcs(rows[:, 0], rows[:, 1:3], p.comfort_span, p.comfort_steepness)
            out[names["ppcs"]] = ppcs(s.plan, p.comfort_span, p.comfort_steepness)
        out["hcs"] = worst([out[n] for n in self._hcs_names], False)
        out["ppcs"] = worst([out[n] for n in self._ppcs_names], False)
