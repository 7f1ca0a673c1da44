"""Situation signals (spi-reference "Situation signals"): leader and follower gaps, headways,
times to collision, ego speed and acceleration, per channel and worst over the channels that
can see the region.
"""

from __future__ import annotations

import math

from casewatch.monitor.families.comfort import ComfortFamily
from casewatch.monitor.family import Engine, MetricFamily, PoseWindow, worst
from casewatch.monitor.frames import ChannelState
from casewatch.monitor.situation import (
    GAP_CAP,
    TIME_CAP,
    acceleration,
    ego_half_length,
    headway,
    neighbours,
    time_to_collision,
)
from casewatch.safety_case.signals import SITUATION_METRICS, WORST_IS_MAX, channel_name


class SituationFamily(MetricFamily):
    name = "situation"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        self._situation_names = {
            c: {m: channel_name(m, c) for m in SITUATION_METRICS} for c in self.channels
        }
        #: per metric: its channel names, whether its worst is the max, whether it is behind
        self._worst_of = [
            (
                metric,
                [self._situation_names[c][metric] for c in self.channels],
                metric in WORST_IS_MAX,
                metric.startswith("follow_"),
            )
            for metric in SITUATION_METRICS
        ]
        #: per channel, rows (t, reported speed, 0) of the last second: ego_accel's slope
        self._speeds = {c: PoseWindow(1.0, p.max_gap) for c in self.channels}

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        """spi-reference "Situation signals": leader and follower of each channel's ego, and
        the unsuffixed worst over the channels that can see the region (ahead: every channel;
        behind: the all-round ones)."""
        p = self.params
        reach = GAP_CAP + 50.0
        behind_seeing = [c for c in self.channels if self.coverage[c].fov_deg >= 360.0]
        driven_paths = self.engine.family(ComfortFamily).ego
        for c in self.channels:
            s = states.get(c)
            if s is None:
                continue
            ego = s.ego
            speed = math.hypot(ego.vx, ego.vy)
            names = self._situation_names[c]
            driven = driven_paths[c].window()[:-1, 1:3] if c in behind_seeing else None
            lead, follower = neighbours(
                ego, s.plan, driven, s.objects, p.lane_half_width, ego_half_length(ego), reach
            )
            out[names["ego_speed"]] = speed
            out[names["ego_accel"]] = self._accel(c, t, speed)
            out[names["lead_gap"]] = lead.gap
            out[names["lead_speed"]] = lead.speed if lead.present else 0.0
            # no leader: the caps (nothing to tailgate), not a headway to the look-ahead's end
            out[names["lead_thw"]] = headway(lead.gap, speed) if lead.present else TIME_CAP
            out[names["lead_ttc"]] = (
                time_to_collision(lead.gap, speed - lead.speed) if lead.present else TIME_CAP
            )
            if follower is not None:
                # the path behind points away from the ego: a follower closing in moves against it
                towards = max(-follower.speed, 0.0)
                out[names["follow_gap"]] = follower.gap
                out[names["follow_speed"]] = towards
                if follower.present:
                    out[names["follow_thw"]] = headway(follower.gap, towards)
                    out[names["follow_ttc"]] = time_to_collision(follower.gap, towards - speed)
                else:
                    out[names["follow_thw"]] = out[names["follow_ttc"]] = TIME_CAP
        all_seeing = len(behind_seeing) == len(self.channels)
        for metric, seeing, use_max, behind in self._worst_of:
            if behind and not all_seeing:
                seeing = [self._situation_names[c][metric] for c in behind_seeing]
            out[metric] = worst([out[n] for n in seeing], use_max) if seeing else None

    def _accel(self, channel: str, t: float, speed: float) -> float | None:
        """spi-reference ego_accel: slope of the channel's reported speed over the last second
        (the window restarts after `max_gap` without the channel, like every history)."""
        window = self._speeds[channel]
        window.push(t, speed, 0.0)
        rows = window.window()
        return acceleration(rows[:, 0], rows[:, 1])
