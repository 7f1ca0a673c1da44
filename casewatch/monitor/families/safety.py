"""The safety score (spi-reference "Safety score"): each channel's plan against each channel's
world model, ss per ordered pair, per channel and worst; and the arbitration it recommends.
"""

from __future__ import annotations

from casewatch.monitor.family import Engine, MetricFamily, worst
from casewatch.monitor.frames import ChannelState
from casewatch.monitor.safety_score import arbitrate, safety_matrix
from casewatch.safety_case.signals import SAFETY_SCORE, channel_name, pair_name


class SafetyFamily(MetricFamily):
    name = "safety_score"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        channels = self.channels
        self._ss_names = {(i, j): pair_name(SAFETY_SCORE, i, j) for i in channels for j in channels}
        self._channel_names = {c: {SAFETY_SCORE: channel_name(SAFETY_SCORE, c)} for c in channels}

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        matrix = safety_matrix(
            self.channels, states, self.params.pet_ref, self.params.plan_standstill > 0
        )
        per_channel: list[float | None] = []
        for ij, v in matrix.items():
            out[self._ss_names[ij]] = v
        for i in self.channels:
            v = worst([matrix[(i, j)] for j in self.channels], False)
            out[self._channel_names[i][SAFETY_SCORE]] = v
            per_channel.append(v)
        out[SAFETY_SCORE] = worst(list(matrix.values()), False)
        engine = self.engine
        engine.last_arbitration = arbitrate(self.channels, matrix, engine.last_arbitration)
