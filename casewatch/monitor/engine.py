"""`MetricEngine`: every built-in signal, tick by tick, with the history the metrics need.

The engine gathers inputs per channel / pair, calls the metric families and names the outputs
exactly as `safety_case.signals.builtin_signals` does. It judges nothing. History (ELS window,
stored plans, previous objects, ego positions) is kept per channel or pair and restarts when the
time since its last sample exceeds `max_gap`, which covers both a gap between frames and a channel
absent for too long.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Mapping
from itertools import combinations
from time import perf_counter

import numpy as np

from casewatch.monitor.comfort import hcs, ppcs
from casewatch.monitor.coverage import common_view
from casewatch.monitor.frames import ChannelState, Coverage, Frame
from casewatch.monitor.history import PlanHistory, chpps_frame, els_var
from casewatch.monitor.lone import LoneAges, benefit_of_doubt
from casewatch.monitor.prediction import ompv
from casewatch.monitor.resample import hold_standing, resample_objects, resample_plan, smooth_plan
from casewatch.monitor.safety_score import arbitrate, safety_matrix
from casewatch.monitor.similarity import (
    compare_objects,
    crpps_inputs,
    ego_similarities,
    ets,
    plan_lateral,
)
from casewatch.monitor.situation import (
    GAP_CAP,
    TIME_CAP,
    acceleration,
    ego_half_length,
    headway,
    neighbours,
    time_to_collision,
)
from casewatch.monitor.world import WORLD_SIGNALS
from casewatch.safety_case.model import MetricParams
from casewatch.safety_case.signals import (
    PAIR_METRICS,
    SAFETY_SCORE,
    SITUATION_METRICS,
    WORST_IS_MAX,
    builtin_signals,
    channel_name,
    pair_name,
)

#: Metric families, as the benchmark reports them.
FAMILIES = ("resampling", "similarity", "motion_prediction", "comfort", "situation", "safety_score")


def _worst(values: list[float | None], use_max: bool) -> float | None:
    """The unsuffixed signal. Decision: when any component has no value, the worst is unknown,
    so the unsuffixed signal has no value either (missing data is never hidden by a min)."""
    if not values or any(v is None for v in values):
        return None
    return max(values) if use_max else min(values)  # type: ignore[type-var]


class _Timed:
    """A deque of (t, value) that restarts when a sample comes more than `max_gap` after the
    previous one."""

    __slots__ = ("items", "max_gap")

    def __init__(self, size: int | None, max_gap: float):
        self.items: deque = deque(maxlen=size)
        self.max_gap = max_gap

    def push(self, t: float, value: object) -> None:
        if self.items and t - self.items[-1][0] > self.max_gap + 1e-9:
            self.items.clear()
        self.items.append((t, value))

    def recent(self, t: float) -> bool:
        """True when the last sample is within max_gap of t."""
        return bool(self.items) and t - self.items[-1][0] <= self.max_gap + 1e-9


class _PoseWindow:
    """A channel's samples (t, a, b) of the last `span` seconds, oldest first, in one growable
    array (rows `start:end`), restarting like `_Timed` when a sample comes more than `max_gap`
    after the previous one: ego positions (t, x, y) for hcs and the driven path, reported
    speeds (t, v, 0) for ego_accel. The kernels read column views of it: no per-frame array
    building, whatever the frame rate."""

    __slots__ = ("buf", "end", "max_gap", "span", "start")

    def __init__(self, span: float, max_gap: float, capacity: int = 64):
        self.buf = np.empty((capacity, 3))
        self.start = 0
        self.end = 0
        self.span = span
        self.max_gap = max_gap

    def push(self, t: float, x: float, y: float) -> None:
        buf = self.buf
        if self.end > self.start and t - buf[self.end - 1, 0] > self.max_gap + 1e-9:
            self.start = self.end = 0
        if self.end == len(buf):
            live = buf[self.start : self.end].copy()
            if len(live) * 2 > len(buf):
                self.buf = buf = np.empty((2 * len(buf), 3))
            buf[: len(live)] = live
            self.start, self.end = 0, len(live)
        buf[self.end] = (t, x, y)
        self.end += 1
        # keep the newest sample at or before t - span: it tells that the span is covered
        limit = t - self.span + 1e-9
        while self.end - self.start > 1 and buf[self.start + 1, 0] <= limit:
            self.start += 1

    def window(self) -> np.ndarray:
        """(n, 3) rows [t, x, y], oldest first (a view)."""
        return self.buf[self.start : self.end]


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
        self.last_arbitration: str | None = None
        self.last_t: float | None = None
        #: Seconds spent per family in the last step (the benchmark reads this).
        self.timings: dict[str, float] = dict.fromkeys(FAMILIES, 0.0)
        p = params
        self._els = {pr: _Timed(p.els_window, p.max_gap) for pr in self.pairs}
        #: per pair, the ages of each side's unpaired objects (spi-reference "Unpaired objects")
        self._lone = {
            pr: (LoneAges(p.pairing_gate, p.max_gap), LoneAges(p.pairing_gate, p.max_gap))
            for pr in self.pairs
        }
        self._plans = PlanHistory(len(self.channels), p.plan_history, p.max_gap)
        # ompv compares with the objects of `ompv_lookback` seconds ago: the history is pruned
        # by time in _motion_prediction, whatever the frame rate
        self._objects = {c: _Timed(None, p.max_gap) for c in self.channels}
        self._ego = {c: _PoseWindow(p.comfort_span, p.max_gap) for c in self.channels}
        #: crpps Fréchet inputs per pair of the current step (None: no value), see _similarity
        self._crpps_inputs: list[tuple[np.ndarray, np.ndarray] | None] = []
        # Signal names, built once: per pair {metric: name}, per channel {metric: name}.
        self._pair_names = {pr: {m: pair_name(m, *pr) for m in PAIR_METRICS} for pr in self.pairs}
        self._channel_names = {
            c: {m: channel_name(m, c) for m in ("chpps", "ompv", "hcs", "ppcs", SAFETY_SCORE)}
            for c in self.channels
        }
        self._ss_names = {(i, j): pair_name(SAFETY_SCORE, i, j) for i in channels for j in channels}
        self._hcs_names = [self._channel_names[c]["hcs"] for c in self.channels]
        self._situation_names = {
            c: {m: channel_name(m, c) for m in SITUATION_METRICS} for c in self.channels
        }
        #: per channel, rows (t, reported speed, 0) of the last second: ego_accel's slope
        self._speeds = {c: _PoseWindow(1.0, p.max_gap) for c in self.channels}
        self._ppcs_names = [self._channel_names[c]["ppcs"] for c in self.channels]

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
        self.last_t = frame.t
        out: dict[str, float | None] = dict.fromkeys(self.signal_names)
        start = perf_counter()
        states = self._resampled(frame)
        self.timings["resampling"] = perf_counter() - start
        self._timed("similarity", self._similarity, frame.t, states, out)
        self._timed("motion_prediction", self._motion_prediction, frame.t, states, out)
        self._timed("comfort", self._comfort, frame.t, states, out)
        self._timed("situation", self._situation, frame.t, states, out)
        self._timed("safety_score", self._safety, frame.t, states, out)
        if frame.world is not None:
            out.update(frame.world)
        for key, val in frame.signals.items():
            # a world input may also come as a scalar signal (a bag topic, a script), unless
            # the frame's `world` reported it
            if key not in out or (key in WORLD_SIGNALS and out[key] is None):
                out[key] = val
        return out

    def _timed(
        self,
        family: str,
        fn: Callable[[float, dict[str, ChannelState], dict[str, float | None]], None],
        t: float,
        states: dict[str, ChannelState],
        out: dict[str, float | None],
    ) -> None:
        start = perf_counter()
        fn(t, states, out)
        self.timings[family] = perf_counter() - start

    def _resampled(self, frame: Frame) -> dict[str, ChannelState]:
        """The frame's channels with plans and predictions on the canonical time grid
        (spi-reference "Resampling"): every metric below reads these, never the raw samples."""
        step = self.params.resample_step
        still = self.params.plan_standstill
        span = self.params.plan_smoothing
        return {
            c: ChannelState(
                s.ego,
                hold_standing(resample_plan(smooth_plan(s.plan, span), step), still),
                resample_objects(s.objects, step),
            )
            for c, s in frame.channels.items()
        }

    # -- families -------------------------------------------------------------------------

    def _similarity(
        self, t: float, st: dict[str, ChannelState], out: dict[str, float | None]
    ) -> None:
        p = self.params
        # crpps needs a Fréchet distance: its inputs wait for the motion family's GEOS call
        self._crpps_inputs = []
        per_pair: dict[str, list[float | None]] = {m: [] for m in PAIR_METRICS if m != "crpps"}
        for a, b in self.pairs:
            sa, sb = st.get(a), st.get(b)
            vals: dict[str, float | None] = dict.fromkeys(PAIR_METRICS)
            window = self._els[(a, b)]
            if sa is not None and sb is not None:
                vals.update(ego_similarities(sa, sb))
                # spi-reference "Channel coverage": only objects both channels can see
                oa, core_a, ob, core_b = common_view(
                    sa.objects,
                    sa.ego,
                    self.coverage[a],
                    sb.objects,
                    sb.ego,
                    self.coverage[b],
                    p.coverage_margin,
                )
                ranges: tuple[np.ndarray | None, np.ndarray | None] = (None, None)
                if p.ols_range_scale > 0.0:
                    ranges = (
                        np.hypot(oa.pos[:, 0] - sa.ego.x, oa.pos[:, 1] - sa.ego.y),
                        np.hypot(ob.pos[:, 0] - sb.ego.x, ob.pos[:, 1] - sb.ego.y),
                    )
                cmp = compare_objects(
                    oa,
                    ob,
                    p.pairing_gate,
                    p.trajectory_decay,
                    core_a,
                    core_b,
                    p.standing_motion,
                    *ranges,
                    p.ols_range_scale,
                    p.ots_time_scale,
                )
                ages_a, ages_b = self._lone[(a, b)]
                age_a = ages_a.update(t, oa.pos, oa.vel, cmp.lone_a)
                age_b = ages_b.update(t, ob.pos, ob.vel, cmp.lone_b)
                vals.update(
                    cmp.scores(
                        benefit_of_doubt(age_a, p.lone_horizon),
                        benefit_of_doubt(age_b, p.lone_horizon),
                    )
                )
                vals["lone_age"] = max(age_a.max(initial=0.0), age_b.max(initial=0.0))
                shift = (sa.ego.x - sb.ego.x, sa.ego.y - sb.ego.y)
                vals["ets"] = ets(
                    sa.plan, sb.plan, p.trajectory_decay, shift if p.ets_relative == 1 else None
                )
                vals["plan_lat"] = plan_lateral(
                    sa.plan,
                    sb.plan,
                    shift,
                    (sa.ego.yaw, sb.ego.yaw),
                    p.plan_lat_horizon,
                )
                self._crpps_inputs.append(crpps_inputs(sa.plan, sb.plan))
                window.push(t, vals["els"])
                vals["els_var"] = els_var([v for _, v in window.items], p.els_window)
            else:
                self._crpps_inputs.append(None)
                for side in self._lone[(a, b)]:
                    side.reset()
            del vals["crpps"]
            names = self._pair_names[(a, b)]
            for m, v in vals.items():
                out[names[m]] = v
                per_pair[m].append(v)
        for m, values in per_pair.items():
            out[m] = _worst(values, m in WORST_IS_MAX)

    def _crpps(self, distances: list[float | None], out: dict[str, float | None]) -> None:
        """crpps per pair, its worst, and crpps_mean = inv(mean fd), from the pairs' Fréchet
        distances (None: a channel absent or a plan empty)."""
        values: list[float | None] = []
        for (a, b), fd in zip(self.pairs, distances, strict=True):
            v = None if fd is None else 1.0 / (1.0 + fd)
            out[self._pair_names[(a, b)]["crpps"]] = v
            values.append(v)
        out["crpps"] = _worst(values, False)
        # Decision: no value when any pair has none.
        if distances and all(d is not None for d in distances):
            mean = float(np.add.reduce(np.array(distances)) / len(distances))  # np.mean's sum
            out["crpps_mean"] = 1.0 / (1.0 + mean)

    def _motion_prediction(
        self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]
    ) -> None:
        p = self.params
        # chpps: every channel's plan joins its packed history first, then one compiled cut of
        # all channels' plan pairs and one GEOS call for them together with the crpps inputs
        # the similarity family left (so this family's timing includes crpps's Fréchet
        # distances).
        plans = self._plans
        ompv_values: dict[str, float | None] = dict.fromkeys(self.channels)
        for i, c in enumerate(self.channels):
            s = states.get(c)
            if s is None:
                continue
            if len(s.plan):
                plans.push(i, t, s.plan)
            prev = self._objects[c]
            if prev.recent(t):
                # spi-reference "ompv" Decision: the newest observation at least ompv_lookback
                # old (the study's previous frame when the lookback is one period)
                old = [(tp, objs) for tp, objs in prev.items if t - tp >= p.ompv_lookback - 1e-9]
                if old:
                    tp, objs = old[-1]
                    ompv_values[c] = ompv(
                        objs,
                        t - tp,
                        s.objects,
                        p.prediction_tolerance,
                        p.pairing_gate,
                        p.standing_motion,
                    )
            prev.push(t, s.objects)
            # keep one observation at least ompv_lookback old, and everything newer
            while len(prev.items) > 1 and t - prev.items[1][0] >= p.ompv_lookback - 1e-9:
                prev.items.popleft()
        chpps_list, crpps_fd = chpps_frame(plans, t, p.trajectory_decay, self._crpps_inputs)
        self._crpps(crpps_fd, out)
        chpps_values = dict(zip(self.channels, chpps_list, strict=True))
        for metric, values in (("chpps", chpps_values), ("ompv", ompv_values)):
            for c, v in values.items():
                out[self._channel_names[c][metric]] = v
            out[metric] = _worst(list(values.values()), False)

    def _comfort(
        self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]
    ) -> None:
        p = self.params
        for c in self.channels:
            s = states.get(c)
            if s is None:
                continue
            window = self._ego[c]
            window.push(t, s.ego.x, s.ego.y)
            rows = window.window()
            names = self._channel_names[c]
            out[names["hcs"]] = hcs(rows[:, 0], rows[:, 1:3], p.comfort_span, p.comfort_steepness)
            out[names["ppcs"]] = ppcs(s.plan, p.comfort_span, p.comfort_steepness)
        out["hcs"] = _worst([out[n] for n in self._hcs_names], False)
        out["ppcs"] = _worst([out[n] for n in self._ppcs_names], False)

    def _situation(
        self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]
    ) -> None:
        """spi-reference "Situation signals": leader and follower of each channel's ego, and
        the unsuffixed worst over the channels that can see the region (ahead: every channel;
        behind: the all-round ones)."""
        p = self.params
        reach = GAP_CAP + 50.0
        behind_seeing = [c for c in self.channels if self.coverage[c].fov_deg >= 360.0]
        for c in self.channels:
            s = states.get(c)
            if s is None:
                continue
            ego = s.ego
            speed = math.hypot(ego.vx, ego.vy)
            names = self._situation_names[c]
            driven = self._ego[c].window()[:-1, 1:3] if c in behind_seeing else None
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
        for metric in SITUATION_METRICS:
            seeing = behind_seeing if metric.startswith("follow_") else self.channels
            values = [out[self._situation_names[c][metric]] for c in seeing]
            out[metric] = _worst(values, metric in WORST_IS_MAX) if seeing else None

    def _accel(self, channel: str, t: float, speed: float) -> float | None:
        """spi-reference ego_accel: slope of the channel's reported speed over the last second
        (the window restarts after `max_gap` without the channel, like every history)."""
        window = self._speeds[channel]
        window.push(t, speed, 0.0)
        rows = window.window()
        return acceleration(rows[:, 0], rows[:, 1])

    def _safety(
        self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]
    ) -> None:
        matrix = safety_matrix(
            self.channels, states, self.params.pet_ref, self.params.plan_standstill > 0
        )
        per_channel: list[float | None] = []
        for ij, v in matrix.items():
            out[self._ss_names[ij]] = v
        for i in self.channels:
            v = _worst([matrix[(i, j)] for j in self.channels], False)
            out[self._channel_names[i][SAFETY_SCORE]] = v
            per_channel.append(v)
        out[SAFETY_SCORE] = _worst(list(matrix.values()), False)
        self.last_arbitration = arbitrate(self.channels, matrix, self.last_arbitration)
