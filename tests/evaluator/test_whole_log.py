"""The whole-log path's episodes, gaps, tallies, series and statuses from whole arrays
(`evaluator.whole_log`) against what replaying every tick through `Evaluator.step` gives:
each piece against the object it replaces on random inputs, and the whole on random logs of a
case with every feature (`for:`, a `sum`, a contract with an assumption, near-miss margins, a
hazard challenging a goal, an ODD with layered and signal attributes, time jumps), value for
value and event for event."""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path
from tempfile import mkdtemp

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from casewatch import api
from casewatch.evaluator.core import Evaluator
from casewatch.evaluator.episodes import EpisodeTracker
from casewatch.evaluator.series import DecimatedSeries
from casewatch.evaluator.session import _no_monitor, replay_ticks
from casewatch.evaluator.signal_store import Columns
from casewatch.evaluator.stl_engines import PrecomputedMonitor, evaluate_whole_log, input_names
from casewatch.evaluator.whole_log import (
    NotReplayable,
    buckets,
    episode_runs,
    first_reaching,
    judge_whole_log,
    series_bounds,
)

PERIOD = 0.1

CASE = """
module: {name: whole-log}
monitor:
  channels: [lav, tfuse]
  period: 0.1s
  merge_gap: 0.3s
  min_duration: 0.2s
  signals: {a: a, b: b, c: c, d: d, speed: speed}
G1:
  text: Root
  inContextOf: [C1]
  supportedBy: [S1]
C1:
  text: The domain
  odd:
    name: dom
    attributes:
      environment.weather: [clear, rain]
      environment.light: [day]
      speed: {max: 25}
    combinations:
      - {environment.weather: clear, environment.light: day}
      - {environment.weather: rain, environment.light: day}
S1:
  text: Over the parts
  supportedBy: [G2, G3, G4]
G2:
  text: A and B
  supportedBy: [Sn1, Sn2]
Sn1:
  text: a high enough
  spi: {signal: a, threshold: ">= 0.5", for: 0.3s, warn: 0.2}
Sn2:
  text: b summed
  spi: {stl: "sum[0s:0.2s](b) <= 2", merge_gap: 0s, min_duration: 0s}
G3:
  text: Contract
  supportedBy: [Sn3]
Sn3:
  text: d small where c positive
  contract: {assume: "c > 0", guarantee: "d < 1", warn: 0.3, merge_gap: 0.5s}
G4:
  text: Not yet
  undeveloped: true
CSn1:
  text: a low and b high
  challenges: [G2]
  hazard: {when: "a < 0.2 and b > 0.5", min_duration: 0s}
"""


@cache
def prepared() -> tuple:
    path = Path(mkdtemp()) / "case.yaml"
    path.write_text(CASE)
    return api.prepare(path)


# -- the pieces ---------------------------------------------------------------------------------

steps = st.lists(st.sampled_from([0.1, 0.1, 0.1, 0.1, 0.2, 0.35, 1.0]), min_size=0, max_size=80)
values = st.one_of(
    st.none(),
    st.sampled_from([-math.inf, math.inf, -0.0, 0.0, -1.0, 0.05, 0.5]),
    st.floats(-3, 3, allow_nan=False),
)


def _times(gaps: list[float]) -> list[float]:
    t, out = 0.0, []
    for g in gaps:
        t = round(t + g, 6)
        out.append(t)
    return out


@given(
    gaps=steps,
    data=st.data(),
    merge_gap=st.sampled_from([0.0, 0.05, 0.1, 0.3, 1.0]),
    min_duration=st.sampled_from([0.0, 0.1, 0.25, 0.5]),
)
@settings(max_examples=400, deadline=None)
def test_episode_runs_are_what_the_tracker_forms(gaps, data, merge_gap, min_duration):
    times = _times(gaps)
    rho = data.draw(st.lists(values, min_size=len(times), max_size=len(times)))
    tracker = EpisodeTracker(merge_gap, min_duration, PERIOD)
    closed, onsets = [], []
    for i, (t, r) in enumerate(zip(times, rho, strict=True)):
        done = tracker.step(t, r)
        if done is not None:
            closed.append((i, done))
        if r is not None and r < 0:
            opened = tracker.onset()
            if opened is not None:
                onsets.append((i, opened.start))
    t = np.array(times, dtype=float)
    value = np.array([np.nan if r is None else r for r in rho], dtype=float)
    runs = episode_runs(t, value < 0, value, merge_gap, min_duration, PERIOD)
    kept = [e for e in range(len(runs.closes)) if runs.closes[e] >= 0 and not runs.dropped[e]]
    assert [(int(runs.closes[e]), times[runs.first[e]], times[runs.last[e]]) for e in kept] == [
        (i, c.start, c.end) for i, c in closed
    ]
    assert [(int(runs.ticks[e]), float(runs.worst[e]), times[runs.t_worst[e]]) for e in kept] == [
        (c.ticks, c.worst_robustness, c.t_worst) for _, c in closed
    ]
    assert [(int(o), times[runs.first[e]]) for e, o in enumerate(runs.onset) if o >= 0] == onsets
    assert int((runs.dropped & (runs.closes >= 0)).sum()) == tracker.dropped
    still = tracker.current
    open_ = [e for e in range(len(runs.closes)) if runs.closes[e] < 0]
    assert (still is None) == (not open_)
    if still is not None:
        e = open_[0]
        assert (still.start, still.end, still.ticks) == (
            times[runs.first[e]],
            times[runs.last[e]],
            runs.ticks[e],
        )


@given(gaps=steps, span=st.sampled_from([-1e-9, 0.1 - 1e-9, 0.3 - 1e-9, 0.7, 5.0]))
@settings(max_examples=200, deadline=None)
def test_first_reaching_uses_the_trackers_subtraction(gaps, span):
    t = np.array(_times(gaps), dtype=float)
    index = np.arange(len(t))
    expected = [
        next((j for j in range(i + 1, len(t)) if t[j] - t[i] >= span), len(t)) for i in index
    ]
    assert first_reaching(t, index, span).tolist() == expected


def test_first_reaching_by_hand():
    t = np.array([0.0, 0.1, 0.2, 0.30000000000000004, 0.4, 1.5])
    # 0.3 - 0.0 reaches 0.3 - 1e-9; 0.4 is the first tick 0.35 past 0.0; nothing reaches 2 s
    assert first_reaching(t, np.array([0, 0, 4]), 0.3 - 1e-9).tolist() == [3, 3, 5]
    assert first_reaching(t, np.array([0, 1]), 0.35).tolist() == [4, 5]
    assert first_reaching(t, np.array([0]), 2.0).tolist() == [6]


@given(
    gaps=st.lists(st.sampled_from([0.1, 0.1, 0.2, 0.7, 3.3]), min_size=1, max_size=300),
    data=st.data(),
    points=st.integers(1, 6),
)
@settings(max_examples=300, deadline=None)
def test_series_buckets_are_decimated_series(gaps, data, points):
    times = _times(gaps)
    drawn = data.draw(st.lists(values, min_size=len(times), max_size=len(times)))
    series = DecimatedSeries(PERIOD, points)
    for t, v in zip(times, drawn, strict=True):
        series.add(t, v)
    b = buckets(np.array(times), PERIOD, points)
    lo, hi = series_bounds(b, np.array([np.nan if v is None else v for v in drawn], dtype=float))
    assert b.width == series.width
    assert b.size == len(series.lo)
    # repr: 0.0 and -0.0 are told apart
    assert [repr(x) for x in lo] == [repr(x) for x in series.lo]
    assert [repr(x) for x in hi] == [repr(x) for x in series.hi]


def test_series_keeps_the_first_of_equal_zeros():
    b = buckets(np.array([0.0, 0.1, 0.2, 0.3]), PERIOD, 1)  # two buckets of 0.2 s
    lo, hi = series_bounds(b, np.array([0.0, -0.0, -0.0, 0.0]))
    assert b.width == 0.2
    assert [repr(x) for x in lo] == ["0.0", "-0.0"]
    assert [repr(x) for x in hi] == ["0.0", "-0.0"]


# -- the whole log ------------------------------------------------------------------------------

CONDITIONS = [
    {"environment.weather": "clear", "environment.light": "day"},
    {"environment.weather": "rain", "environment.light": "day"},
    {"environment.weather": "snow", "environment.light": "day"},
    {"environment.weather": "clear", "environment.light": "night"},
    {"environment.weather": "clear"},
    {},
]

signal = st.one_of(
    st.just(math.nan),
    st.sampled_from([math.inf, -math.inf, 0.0, 0.2, 0.5, 0.6, 1.0, 30.0]),
    st.floats(-2, 2, allow_nan=False),
)


@st.composite
def logs(draw) -> tuple[list[float], list[dict], list[tuple[int, dict]]]:
    gaps = draw(st.lists(st.sampled_from([0.1] * 12 + [0.2, 0.5, 1.7]), min_size=0, max_size=120))
    times = _times(gaps)
    names = ["a", "b", "c", "d", "speed"]
    rows = []
    sticky = {n: draw(signal) for n in names}
    for _ in times:  # values that mostly persist, as signals do
        for n in names:
            if draw(st.integers(0, 5)) == 0:
                sticky[n] = draw(signal)
        rows.append(dict(sticky))
    changes: list[tuple[int, dict]] = []
    for i in range(len(times)):
        if i == 0 or draw(st.integers(0, 15)) == 0:
            changes.append((i, dict(CONDITIONS[draw(st.integers(0, len(CONDITIONS) - 1))])))
    return times, rows, changes


def judged(times, rows, changes, fast: bool, points: int = 1000) -> tuple[Evaluator, list]:
    case, spec = prepared()
    columns = Columns(input_names(spec))
    for t, row in zip(times, rows, strict=True):
        columns.add(t, {k: (None if math.isnan(v) else v) for k, v in row.items()})
    whole = evaluate_whole_log(spec, columns, case.monitor.metrics.max_gap)
    events: list = []

    def precomputed(f, period):
        return PrecomputedMonitor(whole.values[f.id])

    evaluator = Evaluator(
        case,
        spec,
        on_event=events.append,
        monitor_factory=_no_monitor if fast else precomputed,
        series_points=points,
    )
    if fast:
        judge_whole_log(evaluator, columns, changes, whole.values)
    else:
        replay_ticks(evaluator, columns, changes)
    evaluator.finish()
    return evaluator, events


def outputs(evaluator: Evaluator) -> dict:
    return {
        "formulas": [s.model_dump() for s in evaluator.formula_stats()],
        "episodes": [e.model_dump() for e in evaluator.episodes],
        "near": [e.model_dump() for e in evaluator.near_misses],
        "gaps": [g.model_dump() for g in evaluator.data_gaps],
        "status": [s.model_dump() for s in evaluator.node_statuses()],
        "series": [repr(s.model_dump()) for s in evaluator.series()],
        "conditions": [c.model_dump() for c in evaluator.condition_stats()],
        "odd": [repr(o.model_dump()) for o in evaluator.odd_summaries()],  # key order counts
        "odd_last": [c.last for c in evaluator.odd_checks],
        "ticks": (evaluator.ticks, evaluator.last_t),
    }


@given(log=logs())
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_whole_log_is_the_replay(log):
    times, rows, changes = log
    fast, fast_events = judged(times, rows, changes, fast=True)
    slow, slow_events = judged(times, rows, changes, fast=False)
    assert outputs(fast) == outputs(slow)
    assert [repr(e) for e in fast_events] == [repr(e) for e in slow_events]


@given(log=logs(), points=st.integers(1, 8))
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_whole_log_is_the_replay_with_decimated_series(log, points):
    """Few plot points: the bucket width doubles while the log is judged."""
    times, rows, changes = log
    fast, _ = judged(times, rows, changes, fast=True, points=points)
    slow, _ = judged(times, rows, changes, fast=False, points=points)
    assert [repr(s.model_dump()) for s in fast.series()] == [
        repr(s.model_dump()) for s in slow.series()
    ]


def test_the_case_has_what_the_replay_must_match():
    """The random logs reach every kind of record (else the comparison above is hollow)."""
    times = _times([0.1] * 80 + [1.0] + [0.1] * 40)
    rows = []
    for i in range(len(times)):
        a = 0.55 if i % 30 < 10 else (0.1 if i % 30 < 14 else 0.9)
        a = 0.3 if 80 <= i < 82 else a  # violated at once after the jump (tick 80): `for:`
        rows.append(
            {
                "a": a,
                "b": 0.9 if i % 7 == 0 else 0.3,
                "c": -1.0 if 40 <= i < 50 else 1.0,
                "d": 0.8 if i % 11 < 3 else (2.0 if i % 23 == 0 else 0.1),
                "speed": math.nan if 60 <= i < 63 else 10.0,
            }
        )
    changes = [(0, CONDITIONS[0]), (70, CONDITIONS[2]), (90, CONDITIONS[1])]
    fast, events = judged(times, rows, changes, fast=True)
    slow, slow_events = judged(times, rows, changes, fast=False)
    assert outputs(fast) == outputs(slow)
    assert [repr(e) for e in events] == [repr(e) for e in slow_events]
    kinds = {type(e).__name__ for e in events}
    assert kinds == {"Episode", "EpisodeOpen", "NearMiss", "DataGap", "OddChange"}
    stats = {s.id: s for s in fast.formula_stats()}
    assert stats["Sn3"].ticks_outside_assumption == 10  # c <= 0 for ten ticks
    assert any(g.missing == ["(no frames)"] for g in fast.data_gaps)  # the 1 s jump
    assert any("(for window filling)" in g.missing for g in fast.data_gaps)
    assert any(g.missing == ["(sum window filling)"] for g in fast.data_gaps)


def test_times_that_do_not_increase_are_replayed():
    case, spec = prepared()
    columns = Columns(input_names(spec))
    for t in (0.0, 0.1, 0.1, 0.2):
        columns.add(t, {"a": 1.0, "b": 0.0, "c": 1.0, "d": 0.0, "speed": 1.0})
    whole = evaluate_whole_log(spec, columns, case.monitor.metrics.max_gap)
    evaluator = Evaluator(case, spec, monitor_factory=_no_monitor)
    with pytest.raises(NotReplayable):
        judge_whole_log(evaluator, columns, [(0, CONDITIONS[0])], whole.values)
    assert evaluator.ticks == 0 and not evaluator.data_gaps  # nothing was changed


def test_values_that_do_not_line_up_with_the_updates_are_replayed():
    case, spec = prepared()
    columns = Columns(input_names(spec))
    for t in (0.0, 0.1, 0.2):
        columns.add(t, {"a": 0.0, "b": 0.0, "c": 1.0, "d": 0.0, "speed": 1.0})
    whole = evaluate_whole_log(spec, columns, case.monitor.metrics.max_gap)
    short = {**whole.values, "Sn3.assume": whole.values["Sn3.assume"][:2]}
    evaluator = Evaluator(case, spec, monitor_factory=_no_monitor)
    with pytest.raises(NotReplayable, match=r"Sn3\.assume: 2 values for 3 updates"):
        judge_whole_log(evaluator, columns, [(0, CONDITIONS[0])], short)
    assert evaluator.ticks == 0 and not evaluator.episodes  # nothing was changed
    assert all(s.ticks_evaluated == 0 for s in evaluator.states)


def test_a_log_that_cannot_be_judged_from_arrays_is_replayed(monkeypatch, tmp_path):
    """The session falls back to the tick-by-tick replay (`NotReplayable`) with the same
    result and events; the odd-grid drive has contracts, an ODD and condition changes."""
    from casewatch.evaluator import session
    from casewatch.evaluator.offline import result_differences
    from casewatch.evaluator.options import RunOptions, RunSinks

    repo = Path(__file__).resolve().parents[2]
    case, spec = api.prepare(repo / "examples" / "odd" / "contracts-case.yaml")
    stream = repo / "examples" / "data" / "odd-grid" / "odd-rain-medium-night-r0.jsonl.gz"

    def run(name: str):
        events = tmp_path / f"{name}.jsonl"
        options = RunOptions(stl_engine="numpy")
        return session.evaluate_stream(case, spec, stream, options, RunSinks(events_path=events))

    arrays = run("arrays")

    def refuse(*args, **kwargs):
        raise NotReplayable("for the test")

    monkeypatch.setattr(session, "judge_whole_log", refuse)
    replayed = run("replayed")
    assert result_differences(arrays, replayed) == []
    assert arrays.episodes and arrays.data_gaps and arrays.conditions and arrays.odd
    assert (tmp_path / "arrays.jsonl").read_text() == (tmp_path / "replayed.jsonl").read_text()
