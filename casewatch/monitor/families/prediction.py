"""Plans and predictions over time (spi-reference "Motion and plans"): chpps (a channel's plan
against its own earlier plans), ompv (objects against their earlier predictions), and crpps /
crpps_mean, whose Fréchet distances share one GEOS call with chpps's.
"""

from __future__ import annotations

import numpy as np

from casewatch.monitor.families.similarity import SimilarityFamily
from casewatch.monitor.family import Engine, MetricFamily, TimedHistory, worst
from casewatch.monitor.frames import ChannelState
from casewatch.monitor.history import PlanHistory, chpps_frame
from casewatch.monitor.prediction import ompv
from casewatch.safety_case.signals import channel_name, pair_name


class MotionPredictionFamily(MetricFamily):
    name = "motion_prediction"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        self._plans = PlanHistory(len(self.channels), p.plan_history, p.max_gap)
        # ompv compares with the objects of `ompv_lookback` seconds ago: the history is pruned
        # by time in step, whatever the frame rate
        self._objects = {c: TimedHistory(None, p.max_gap) for c in self.channels}
        self._crpps_names = {pr: pair_name("crpps", *pr) for pr in self.pairs}
        self._channel_names = {
            c: {m: channel_name(m, c) for m in ("chpps", "ompv")} for c in self.channels
        }
        self._names = [self._channel_names[c] for c in self.channels]
        self._crpps_pair_names = [self._crpps_names[pr] for pr in self.pairs]

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        p = self.params
        # chpps: every channel's plan joins its packed history first, then one compiled cut of
        # all channels' plan pairs and one GEOS call for them together with the crpps inputs
        # the similarity family left (so this family's timing includes crpps's Fréchet
        # distances).
        plans = self._plans
        lookback = p.ompv_lookback - 1e-9
        ompv_values: list[float | None] = []
        for i, c in enumerate(self.channels):
            s = states.get(c)
            value = None
            if s is None:
                ompv_values.append(value)
                continue
            if len(s.plan):
                plans.push(i, t, s.plan)
            prev = self._objects[c]
            if prev.recent(t):
                # spi-reference "ompv" Decision: the newest observation at least ompv_lookback
                # old (the study's previous frame when the lookback is one period)
                for tp, objs in reversed(prev.items):
                    if t - tp >= lookback:
                        value = ompv(
                            objs,
                            t - tp,
                            s.objects,
                            p.prediction_tolerance,
                            p.pairing_gate,
                            p.standing_motion,
                        )
                        break
            ompv_values.append(value)
            prev.push(t, s.objects)
            # keep one observation at least ompv_lookback old, and everything newer
            items = prev.items
            while len(items) > 1 and t - items[1][0] >= lookback:
                items.popleft()
        chpps_values, crpps_fd = chpps_frame(
            plans, t, p.trajectory_decay, self.engine.family(SimilarityFamily).crpps_inputs
        )
        self._crpps(crpps_fd, out)
        for metric, values in (("chpps", chpps_values), ("ompv", ompv_values)):
            for names, v in zip(self._names, values, strict=True):
                out[names[metric]] = v
            out[metric] = worst(values, False)

    def _crpps(self, distances: list[float | None], out: dict[str, float | None]) -> None:
        """crpps per pair, its worst, and crpps_mean = inv(mean fd), from the pairs' Fréchet
        distances (None: a channel absent or a plan empty)."""
        values: list[float | None] = []
        for name, fd in zip(self._crpps_pair_names, distances, strict=True):
            v = None if fd is None else 1.0 / (1.0 + fd)
            out[name] = v
            values.append(v)
        out["crpps"] = worst(values, False)
        # Decision: no value when any pair has none.
        if distances and None not in distances:
            if len(distances) == 1:  # the sum of one value is that value
                mean = float(distances[0])  # type: ignore[arg-type]
            else:
                mean = float(np.add.reduce(np.array(distances)) / len(distances))  # np.mean's
            out["crpps_mean"] = 1.0 / (1.0 + mean)
