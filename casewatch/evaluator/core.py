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

from casewatch.evaluator.episodes import ClosedEpisode, EpisodeTracker
from casewatch.evaluator.gaps import ClosedGap, GapTracker
from casewatch.evaluator.intervals import RunLength
from casewatch.evaluator.odd_check import OddCheck
from casewatch.evaluator.result import (
    ConditionStats,
    DataGap,
    Episode,
    EpisodeOpen,
    FormulaStats,
    FormulaTally,
    NearMiss,
    NodeStatus,
    OddChange,
    OddSummary,
    Series,
    StatusInterval,
    TraceStep,
)
from casewatch.evaluator.series import DecimatedSeries
from casewatch.evaluator.status import OddVerdict, StatusPropagator, Verdict, worst_status
from casewatch.safety_case.model import Case, OddValue
from casewatch.spec.model import CompiledFormula, CompiledSpec

#: Builds an object with rtamt's online interface (`update(i, [(name, value)])`, `reset()`);
#: `reset()` must work before the first update (it starts every run of samples).
MonitorFactory = Callable[[CompiledFormula, float], Any]

#: The conditions of a stream that reports none.
NO_CONDITIONS: Mapping[str, OddValue] = {}

#: What a data gap names while a `sum` window fills after a restart (docs/formulas.md).
WARMING_UP = "(sum window filling)"
#: What a data gap names at a violated tick of an SPI whose `for:` has not yet passed since
#: the (re)start: the violation has not lasted `for:` of data (docs/formulas.md).
PERSISTING = "(for window filling)"

#: What a data gap names for the ticks of a jump in frame time longer than `max_gap`.
NO_FRAMES = "(no frames)"

#: What a data gap names at a tick whose robustness is not a number (a division 0 / 0 of
#: signals, `inf - inf`): neither a pass nor a violation (docs/formulas.md).
UNDEFINED = "(not a number)"

#: Receives each episode at its onset and when it closes, and each data gap when it closes.
EventSink = Callable[[Episode | EpisodeOpen | NearMiss | DataGap | OddChange], None]


def rtamt_monitor(formula: CompiledFormula, period: float) -> Any:
    from casewatch.spec.emit import build_rtamt_monitor

    return build_rtamt_monitor(formula, period)


@dataclass
class Feed:
    """One monitor and where it stands: samples since its last reset, and whether it must be
    reset before its next update (after a tick without its inputs)."""

    formula: CompiledFormula
    monitor: Any
    index: int = 0
    fresh: bool = True


@dataclass
class FormulaState:
    """Everything the evaluator tracks for one formula."""

    formula: CompiledFormula
    monitor: Any
    episodes: EpisodeTracker
    series: DecimatedSeries
    assume: Feed | None = None  # a contract's assumption
    ticks_outside: int = 0  # a contract's ticks outside its assumption
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
        # the contexts that state an ODD, checked every tick (docs/odd.md)
        self.odd_checks = [OddCheck(n.id, n.odd) for n in case.nodes.values() if n.odd]
        self.tallies: dict[tuple, dict[str, FormulaTally]] = {}
        self.tally_ticks: dict[tuple, int] = {}
        self.tally_spans: dict[tuple, list[list[float]]] = {}
        self._conditions_key: tuple[int, tuple] | None = None
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
                assume=(
                    Feed(f.assumption, monitor_factory(f.assumption, spec.period))
                    if f.assumption is not None
                    else None
                ),
            )
            for f in spec.formulas
        ]
        self.near_misses: list[NearMiss] = []
        self.propagator = StatusPropagator(
            case, {f.node_id: f.id for f in spec.formulas}, [c.node_id for c in self.odd_checks]
        )
        self.timelines = {node_id: RunLength() for node_id in case.nodes}
        self.episodes: list[Episode] = []
        self.data_gaps: list[DataGap] = []
        self.last_t: float | None = None
        self.ticks = 0
        self.stl_seconds = 0.0  # time spent inside rtamt updates
        self._traces: dict[str, list[list[TraceStep]]] = {}

    # -- per tick ---------------------------------------------------------------------------

    def step(
        self,
        t: float,
        values: Mapping[str, float | None],
        conditions: Mapping[str, OddValue] = NO_CONDITIONS,
    ) -> dict[str, str]:
        """Judge one tick under the reported `conditions` (flattened `meta.odd` with the
        frames' updates: the same mapping object until they change); returns every node's
        status at `t`."""
        if self.last_t is not None and t - self.last_t > self.max_gap + 1e-9:
            self._stream_gap(self.last_t, t)
        self.last_t = t
        self.ticks += 1
        verdicts: dict[str, Verdict] = {}
        for state in self.states:
            verdicts[state.formula.id] = self._judge(state, t, values)
        self._tally(t, conditions, verdicts)
        odd: dict[str, OddVerdict] = {}
        for check in self.odd_checks:
            before = check.last[0]  # "inside" before the first tick
            odd[check.node_id] = check.judge(conditions, values)
            if check.last[0] != before and self.on_event is not None:
                self.on_event(
                    OddChange(
                        node_id=check.node_id,
                        t=round(t, 6),
                        state=check.last[0],
                        because=check.last[1],
                    )
                )
        statuses = self.propagator.statuses(verdicts, odd)
        for node_id, status in statuses.items():
            self.timelines[node_id].add(t, status)
        return statuses

    def _feed(
        self, feed: Feed | FormulaState, values: Mapping[str, float | None]
    ) -> tuple[float, list[str]]:
        """Update one monitor with this tick's inputs: (robustness, []) or, when an input has
        no value (the monitor is not updated and restarts when data returns), a `sum`
        window is still filling after a restart, or a violation has not yet lasted the SPI's
        `for:` since the restart (it is updated), (nan, what is missing)."""
        inputs: list[tuple[str, float]] = []
        missing: list[str] = []
        for name in feed.formula.signals:
            value = values.get(name)
            if value is None or not math.isfinite(value):
                missing.append(name)
            else:
                inputs.append((name, float(value)))
        if missing:
            feed.fresh = True
            return math.nan, missing
        if feed.fresh:
            feed.monitor.reset()  # build_rtamt_monitor's monitors reset before any update too
            feed.index = 0
            feed.fresh = False
        started = time.perf_counter()
        robustness = float(feed.monitor.update(feed.index, inputs))
        self.stl_seconds += time.perf_counter() - started
        feed.index += 1
        if feed.index <= feed.formula.warmup_ticks:
            return math.nan, [WARMING_UP]
        if robustness < 0 and feed.index <= feed.formula.persist_ticks:
            return math.nan, [PERSISTING]
        if math.isnan(robustness):  # 0 / 0 of two signals, inf - inf: no verdict either way
            return math.nan, [UNDEFINED]
        return robustness, []

    def _judge(self, state: FormulaState, t: float, values: Mapping[str, float | None]) -> Verdict:
        formula = state.formula
        robustness, missing = self._feed(state, values)
        if state.assume is not None:
            holds, unknown = self._feed(state.assume, values)
            if unknown:
                return self._no_verdict(state, t, sorted({*unknown, *missing}))
            if holds < 0:
                return self._outside_assumption(state, t)
        if missing:
            return self._no_verdict(state, t, missing)
        shown = values.get(formula.signal) if formula.signal else None
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

    def _outside_assumption(self, state: FormulaState, t: float) -> Verdict:
        """A contract's tick where its assumption fails: not judged, neither pass nor
        violation; an open episode may still merge across it."""
        state.ticks_outside += 1
        self._emit_gap(state, state.gaps.close())
        self._emit_episode(state, state.episodes.step(t, math.inf))
        if state.near is not None:
            self._emit_near(state, state.near.step(t, math.inf))
        state.series.add(t, None)
        return "outside-assumption"

    def _tally(
        self, t: float, conditions: Mapping[str, OddValue], verdicts: Mapping[str, Verdict]
    ) -> None:
        """Count each formula's verdict under the current combination of conditions, and
        extend the stretch of time spent under it."""
        cached = self._conditions_key
        if cached is None or cached[0] != id(conditions):
            key = tuple(sorted(conditions.items()))
            if cached is None or cached[1] != key:
                self.tally_spans.setdefault(key, []).append([t, t])
            cached = self._conditions_key = (id(conditions), key)
        tally = self.tallies.get(cached[1])
        if tally is None:
            tally = self.tallies[cached[1]] = {f.id: FormulaTally() for f in self.spec.formulas}
            self.tally_ticks[cached[1]] = 0
        self.tally_ticks[cached[1]] += 1
        self.tally_spans[cached[1]][-1][1] = t
        for formula_id, verdict in verdicts.items():
            counts = tally[formula_id]
            if verdict == "ok":
                counts.evaluated += 1
            elif verdict == "violated":
                counts.evaluated += 1
                counts.violated += 1
            elif verdict == "outside-assumption":
                counts.outside_assumption += 1
            else:
                counts.no_data += 1

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
            state.gaps.missing(t - self.period, [NO_FRAMES], skipped, start=last_t + self.period)
            state.ticks_no_data += skipped
            state.fresh = True
            if state.assume is not None:  # a contract's assumption restarts too
                state.assume.fresh = True
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
            formula_id=formula.id,
            node_id=formula.node_id,
            kind=formula.kind,
            start=round(closed.start, 6),
            end=round(closed.end, 6),
            ticks=closed.ticks,
            least_robustness=round(closed.worst_robustness + formula.warn, 12),
            t_least=round(closed.t_worst, 6),
            warn=formula.warn,
            trace=self._trace(formula.node_id),
        )
        self.near_misses.append(near)
        if self.on_event is not None:
            self.on_event(near)

    def _emit_onset(self, state: FormulaState, t: float) -> None:
        opened = state.episodes.onset()
        if opened is not None:
            self._announce(state, opened.start, t)

    def _announce(self, state: FormulaState, start: float, t: float) -> None:
        """Report at `t` the onset of the episode that started at `start`."""
        if self.on_event is None:
            return
        formula = state.formula
        self.on_event(
            EpisodeOpen(
                formula_id=formula.id,
                node_id=formula.node_id,
                kind=formula.kind,
                start=round(start, 6),
                t=round(t, 6),
                trace=self._trace(formula.node_id),
            )
        )

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
        """The node's paths to the root, fresh lists of steps built once per node (a long run
        has thousands of events; nothing changes a step once made)."""
        steps = self._traces.get(node_id)
        if steps is None:
            steps = self._traces[node_id] = [
                [TraceStep(id=step.id, text=step.text) for step in path]
                for path in self.spec.traces.get(node_id, [])
            ]
        return [list(path) for path in steps]

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
                assumption=s.formula.assumption.source if s.formula.assumption else None,
                contract_use=s.formula.contract_use,
                ticks_outside_assumption=s.ticks_outside,
                rule=s.formula.rule,
            )
            for s in self.states
        ]

    def condition_stats(self) -> list[ConditionStats]:
        """Per combination of reported conditions, its ticks and each formula's tally."""
        return [
            ConditionStats(
                attributes=dict(key),
                ticks=self.tally_ticks[key],
                formulas=tally,
                spans=[[round(a, 6), round(b, 6)] for a, b in self.tally_spans[key]],
            )
            for key, tally in self.tallies.items()
        ]

    def odd_summaries(self) -> list[OddSummary]:
        return [
            OddSummary(
                node_id=c.node_id,
                name=c.spec.name,
                inside=c.counts["inside"],
                outside=c.counts["outside"],
                unknown=c.counts["unknown"],
                outside_by=dict(c.outside_by),
                unknown_by=dict(c.unknown_by),
            )
            for c in self.odd_checks
        ]

    def node_statuses(self) -> list[NodeStatus]:
        out = []
        for node_id, timeline in self.timelines.items():
            intervals = [
                StatusInterval(
                    status=r.value, start=round(r.start, 6), end=round(r.end, 6), ticks=r.ticks
                )
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
        # every formula's series has the same buckets (each tick adds to all): round once
        times: dict[tuple[float | None, float, int], list[float]] = {}
        for s in self.states:
            f = s.formula
            as_signal = f.signal is not None and f.threshold is not None
            reference = 0.0
            if f.signal is not None and f.threshold is not None:
                reference = float(f.threshold.split()[-1])
            key = (s.series.t0, s.series.width, len(s.series.lo))
            if key not in times:
                times[key] = s.series.times()
            out.append(
                Series(
                    formula_id=f.id,
                    quantity="signal" if as_signal else "robustness",
                    name=f.signal if as_signal else "robustness",
                    bucket=s.series.width or self.period,
                    t=list(times[key]),
                    lo=s.series.lo,
                    hi=s.series.hi,
                    reference=reference,
                )
            )
        return out
