"""The judging loop: metric values in, robustness, episodes, gaps and node statuses out.

One rtamt online monitor per compiled formula is fed each tick. A tick where any input of a
formula has no value is a data gap for that formula: the monitor is NOT updated (rtamt would
silently reuse the last value) and it is reset when data returns, so past-time windows never
span a gap. A jump in frame time longer than `max_gap` is a gap for every formula.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from evaluator.episodes import ClosedEpisode, EpisodeTracker
from evaluator.gaps import ClosedGap, GapTracker
from evaluator.intervals import RunLength
from evaluator.result import (
    DataGap,
    Episode,
    EpisodeOpen,
    FormulaStats,
    NearMiss,
    NodeStatus,
    Series,
    StatusInterval,
    TraceStep,
)
from evaluator.series import DecimatedSeries
from evaluator.status import StatusPropagator, Verdict, worst_status
from safety_case.model import Case
from spec.model import CompiledFormula, CompiledSpec

#: Builds an object with rtamt's online interface (`update(i, [(name, value)])`, `reset()`);
#: `reset()` must work before the first update (it starts every run of samples).
MonitorFactory = Callable[[CompiledFormula, float], Any]

#: What a data gap names while a `sum` window fills after a restart (docs/formulas.md).
WARMING_UP = "(sum window filling)"

#: Receives each episode at its onset and when it closes, and each data gap when it closes.
EventSink = Callable[[Episode | EpisodeOpen | NearMiss | DataGap], None]


def rtamt_monitor(formula: CompiledFormula, period: float) -> Any:
    from spec.emit import build_rtamt_monitor

    return build_rtamt_monitor(formula, period)


@dataclass
class FormulaState:
    """Everything the evaluator tracks for one formula."""

    formula: CompiledFormula
    monitor: Any
    episodes: EpisodeTracker
    series: DecimatedSeries
    gaps: GapTracker = field(default_factory=GapTracker)
    index: int = 0  # samples fed to the monitor since its last reset
    fresh: bool = True  # the monitor must be reset before its next update
    ticks_evaluated: int = 0
    ticks_violated: int = 0
    ticks_no_data: int = 0
    near: EpisodeTracker | None = None  # near misses, for a formula with a warning margin
    worst: float | None = None
    t_worst: float | None = None


class Evaluator:
    """Judges one run, tick by tick. Call `step` per frame, then `finish` once."""

    def __init__(
        self,
        case: Case,
        spec: CompiledSpec,
        on_event: EventSink | None = None,
        monitor_factory: MonitorFactory = rtamt_monitor,
        series_points: int = 1000,
    ):
        self.case = case
        self.spec = spec
        self.period = spec.period
        self.max_gap = case.monitor.metrics.max_gap
        self.on_event = on_event
        self.states = [
            FormulaState(
                formula=f,
                monitor=monitor_factory(f, spec.period),
                episodes=EpisodeTracker(f.merge_gap, f.min_duration, spec.period),
                series=DecimatedSeries(spec.period, series_points),
                near=EpisodeTracker(f.merge_gap, f.min_duration, spec.period) if f.warn else None,
            )
            for f in spec.formulas
        ]
        self.near_misses: list[NearMiss] = []
        self.propagator = StatusPropagator(case, {f.node_id: f.id for f in spec.formulas})
        self.timelines = {node_id: RunLength() for node_id in case.nodes}
        self.episodes: list[Episode] = []
        self.data_gaps: list[DataGap] = []
        self.last_t: float | None = None
        self.ticks = 0
        self.stl_seconds = 0.0  # time spent inside rtamt updates

    # -- per tick ---------------------------------------------------------------------------

    def step(self, t: float, values: Mapping[str, float | None]) -> dict[str, str]:
        """Judge one tick; returns every node's status at `t`."""
        if self.last_t is not None and t - self.last_t > self.max_gap + 1e-9:
            self._stream_gap(self.last_t, t)
        self.last_t = t
        self.ticks += 1
        verdicts: dict[str, Verdict] = {}
        for state in self.states:
            verdicts[state.formula.id] = self._judge(state, t, values)
        statuses = self.propagator.statuses(verdicts)
        for node_id, status in statuses.items():
            self.timelines[node_id].add(t, status)
        return statuses

    def _judge(self, state: FormulaState, t: float, values: Mapping[str, float | None]) -> Verdict:
        formula = state.formula
        inputs: list[tuple[str, float]] = []
        missing: list[str] = []
        for name in formula.signals:
            value = values.get(name)
            if value is None or not math.isfinite(value):
                missing.append(name)
            else:
                inputs.append((name, float(value)))
        shown = values.get(formula.signal) if formula.signal else None
        if missing:
            state.fresh = True
            return self._no_verdict(state, t, missing)
        if state.fresh:
            state.monitor.reset()  # build_rtamt_monitor's monitors reset before any update too
            state.index = 0
            state.fresh = False
        started = time.perf_counter()
        robustness = float(state.monitor.update(state.index, inputs))
        self.stl_seconds += time.perf_counter() - started
        state.index += 1
        if state.index <= formula.warmup_ticks:
            # a `sum` window still filling after a restart: no verdict (the monitor is fed)
            return self._no_verdict(state, t, [WARMING_UP])
        self._emit_gap(state, state.gaps.close())
        state.ticks_evaluated += 1
        if state.worst is None or robustness < state.worst:
            state.worst, state.t_worst = robustness, t
        violated = robustness < 0
        if violated:
            state.ticks_violated += 1
        self._emit_episode(state, state.episodes.step(t, robustness))
        self._emit_onset(state, t)
        if state.near is not None:
            # inside the margin: how far below it (negative), else clear of it
            inside = 0.0 <= robustness < formula.warn
            self._emit_near(state, state.near.step(t, robustness - formula.warn if inside else 1.0))
        state.series.add(t, float(shown) if formula.signal and shown is not None else robustness)
        return "violated" if violated else "ok"

    def _no_verdict(self, state: FormulaState, t: float, missing: list[str]) -> Verdict:
        """A tick without a verdict for `state`'s formula: a data gap naming what is missing."""
        state.ticks_no_data += 1
        state.gaps.missing(t, missing)
        self._emit_episode(state, state.episodes.step(t, None))
        if state.near is not None:
            self._emit_near(state, state.near.step(t, None))
        state.series.add(t, None)
        return "no-data"

    def _stream_gap(self, last_t: float, t: float) -> None:
        """Frames are missing between `last_t` and `t`: a gap for every formula."""
        skipped = max(1, round((t - last_t) / self.period) - 1)
        for state in self.states:
            state.gaps.missing(
                t - self.period, ["(no frames)"], skipped, start=last_t + self.period
            )
            state.ticks_no_data += skipped
            state.fresh = True
        for timeline in self.timelines.values():
            timeline.add_span(last_t + self.period, t - self.period, "no-data", skipped)

    # -- events -----------------------------------------------------------------------------

    def _emit_episode(self, state: FormulaState, closed: ClosedEpisode | None) -> None:
        if closed is None:
            return
        formula = state.formula
        episode = Episode(
            formula_id=formula.id,
            node_id=formula.node_id,
            kind=formula.kind,
            start=round(closed.start, 6),
            end=round(closed.end, 6),
            ticks=closed.ticks,
            worst_robustness=closed.worst_robustness,
            t_worst=round(closed.t_worst, 6),
            trace=self._trace(formula.node_id),
        )
        self.episodes.append(episode)
        if self.on_event is not None:
            self.on_event(episode)

    def _emit_near(self, state: FormulaState, closed: ClosedEpisode | None) -> None:
        if closed is None:
            return
        formula = state.formula
        near = NearMiss(
            formula_id=formula.id, node_id=formula.node_id, kind=formula.kind,
            start=round(closed.start, 6), end=round(closed.end, 6), ticks=closed.ticks,
            least_robustness=round(closed.worst_robustness + formula.warn, 12),
            t_least=round(closed.t_worst, 6), warn=formula.warn,
            trace=self._trace(formula.node_id),
        )  # fmt: skip
        self.near_misses.append(near)
        if self.on_event is not None:
            self.on_event(near)

    def _emit_onset(self, state: FormulaState, t: float) -> None:
        opened = state.episodes.onset()
        if opened is None or self.on_event is None:
            return
        formula = state.formula
        self.on_event(EpisodeOpen(
            formula_id=formula.id, node_id=formula.node_id, kind=formula.kind,
            start=round(opened.start, 6), t=round(t, 6), trace=self._trace(formula.node_id),
        ))  # fmt: skip

    def _emit_gap(self, state: FormulaState, closed: ClosedGap | None) -> None:
        if closed is None:
            return
        gap = DataGap(
            formula_id=state.formula.id,
            node_id=state.formula.node_id,
            start=round(closed.start, 6),
            end=round(closed.end, 6),
            ticks=closed.ticks,
            missing=closed.missing,
        )
        self.data_gaps.append(gap)
        if self.on_event is not None:
            self.on_event(gap)

    def _trace(self, node_id: str) -> list[list[TraceStep]]:
        return [
            [TraceStep(id=step.id, text=step.text) for step in path]
            for path in self.spec.traces.get(node_id, [])
        ]

    # -- end of run -------------------------------------------------------------------------

    def finish(self) -> None:
        """Close every open episode and gap (emitting them)."""
        for state in self.states:
            self._emit_episode(state, state.episodes.finish())
            if state.near is not None:
                self._emit_near(state, state.near.finish())
            self._emit_gap(state, state.gaps.close())
        self.episodes.sort(key=lambda e: (e.start, e.formula_id))
        self.near_misses.sort(key=lambda e: (e.start, e.formula_id))
        self.data_gaps.sort(key=lambda g: (g.start, g.formula_id))

    def formula_stats(self) -> list[FormulaStats]:
        return [
            FormulaStats(
                id=s.formula.id,
                node_id=s.formula.node_id,
                node_text=s.formula.node_text,
                kind=s.formula.kind,
                source=s.formula.source,
                rtamt=s.formula.rtamt,
                signal=s.formula.signal,
                threshold=s.formula.threshold,
                signals=list(s.formula.signals),
                ticks_evaluated=s.ticks_evaluated,
                ticks_violated=s.ticks_violated,
                ticks_no_data=s.ticks_no_data,
                episodes=s.episodes.closed,
                episodes_dropped=s.episodes.dropped,
                worst_robustness=s.worst,
                t_worst=None if s.t_worst is None else round(s.t_worst, 6),
                merge_gap=s.formula.merge_gap,
                min_duration=s.formula.min_duration,
            )
            for s in self.states
        ]

    def node_statuses(self) -> list[NodeStatus]:
        out = []
        for node_id, timeline in self.timelines.items():
            intervals = [
                StatusInterval(status=r.value, start=round(r.start, 6), end=round(r.end, 6),
                               ticks=r.ticks)
                for r in timeline.runs
            ]
            totals = {str(k): v for k, v in timeline.totals().items()}
            out.append(
                NodeStatus(
                    node_id=node_id,
                    worst=worst_status(list(totals)),
                    timeline=intervals,
                    ticks=totals,
                )
            )
        return out

    def series(self) -> list[Series]:
        out = []
        for s in self.states:
            f = s.formula
            as_signal = f.signal is not None and f.threshold is not None
            reference = 0.0
            if as_signal:
                reference = float(f.threshold.split()[-1])
            out.append(
                Series(
                    formula_id=f.id,
                    quantity="signal" if as_signal else "robustness",
                    name=f.signal if as_signal else "robustness",
                    bucket=s.series.width or self.period,
                    t=s.series.times(),
                    lo=s.series.lo,
                    hi=s.series.hi,
                    reference=reference,
                )
            )
        return out
