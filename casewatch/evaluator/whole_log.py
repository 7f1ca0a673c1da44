"""Episodes, data gaps, tallies, plot series and node statuses of a whole log, from its arrays.

The whole-log path (`session.WholeLogJudge`) knows every formula's robustness at every tick
once the log is read (`stl_engines.evaluate_whole_log`). Replaying the ticks through
`Evaluator.step` one by one costs a Python call per formula and tick although most ticks change
nothing; this module computes what that replay computes from whole arrays instead: per formula
a verdict per tick (`ok`, `violated`, `no-data` with its reasons, `outside-assumption`), then
the episodes, near misses and data gaps from the ticks where something starts or ends, the
tallies per combination of conditions, the decimated plot series, the ODD verdicts and the
node statuses (propagated once per distinct combination of verdicts, run-length per node).

It fills an `Evaluator` as `step` per tick would have left it (counters, trackers with what is
still open for `finish`, records, timelines) and hands its events to `on_event` in the replay's
order: per tick, each formula's gap, closed episode, onset and near miss, then the ODD changes.
The replay (`replay_ticks`) stays for what this does not cover (times that do not increase,
robustness that does not line up with the ticks): identity with it is the rule, checked on
every bundled drive and on random inputs (tests/evaluator/test_whole_log.py).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from casewatch.evaluator.core import (
    NO_FRAMES,
    PERSISTING,
    UNDEFINED,
    WARMING_UP,
    Evaluator,
    FormulaState,
)
from casewatch.evaluator.episodes import ClosedEpisode, EpisodeTracker, OpenEpisode
from casewatch.evaluator.gaps import ClosedGap, OpenGap
from casewatch.evaluator.intervals import Run
from casewatch.evaluator.odd_check import OddCheck
from casewatch.evaluator.result import FormulaTally, OddChange
from casewatch.evaluator.series import DecimatedSeries
from casewatch.evaluator.signal_store import Columns
from casewatch.evaluator.status import OddVerdict
from casewatch.safety_case.model import OddRange, OddValue
from casewatch.spec.model import CompiledFormula

#: Verdict codes per tick.
OK, VIOLATED, NO_DATA, OUTSIDE = 0, 1, 2, 3
_VERDICT = ("ok", "violated", "no-data", "outside-assumption")
_ODD: tuple[OddVerdict, ...] = ("inside", "outside", "unknown")

#: An event of the replay: (tick, formula or ODD check, part of the tick, (kind, what)).
Event = tuple[int, int, int, tuple[str, Any]]

#: Conditions per tick as the points where they change: (first tick, the mapping).
ConditionChanges = Sequence[tuple[int, Mapping]]


class NotReplayable(Exception):
    """The arrays do not line up as the replay would read them; replay tick by tick."""


# -- per formula: the verdict of every tick -----------------------------------------------------


@dataclass
class Ticks:
    """The log's tick times and where frames are missing between two ticks."""

    t: np.ndarray  # (n,) increasing
    times: list[float]  # the same, as Python floats
    broken: np.ndarray  # (n,) bool: a jump over max_gap before tick i (`_stream_gap`)
    skipped: np.ndarray  # (n,) int64: the ticks that jump stands for (0 elsewhere)
    period: float

    @classmethod
    def of(cls, t: np.ndarray, period: float, max_gap: float) -> Ticks:
        times = t.tolist()
        n = len(times)
        broken = np.zeros(n, dtype=bool)
        skipped = np.zeros(n, dtype=np.int64)
        if n > 1:
            broken[1:] = np.diff(t) > max_gap + 1e-9
            for i in np.flatnonzero(broken).tolist():
                skipped[i] = max(1, round((times[i] - times[i - 1]) / period) - 1)
        return cls(t, times, broken, skipped, period)


@dataclass
class Verdicts:
    """One formula's verdict at every tick: the code, the robustness where judged (NaN
    elsewhere) and, at a tick without data, what was missing (bits of `names`)."""

    code: np.ndarray  # int8 (n,)
    robustness: np.ndarray  # float64 (n,)
    reasons: np.ndarray  # int64 (n,)
    names: list[str]


def _feed(
    formula: CompiledFormula,
    values: np.ndarray,
    columns: Columns,
    ticks: Ticks,
    bit: Mapping[str, int],
) -> tuple[np.ndarray, np.ndarray]:
    """What `Evaluator._feed` returns at every tick for one monitor: (robustness, NaN where
    there is none; the bits of what is missing, 0 where there is a value). The monitor is
    updated where every input is finite, its k-th update gives `values[k]`, and its sample
    count restarts after a tick without its inputs and after a jump in time."""
    n = len(ticks.times)
    present = np.ones(n, dtype=bool)
    reasons = np.zeros(n, dtype=np.int64)
    for name in formula.signals:
        if name in columns.names:
            finite = np.isfinite(columns.column(name))
        else:
            finite = np.zeros(n, dtype=bool)
        reasons[~finite] |= bit[name]
        present &= finite
    index = np.flatnonzero(present)
    if len(index) != len(values):
        raise NotReplayable(f"{formula.id}: {len(values)} values for {len(index)} updates")
    robustness = np.full(n, np.nan)
    if not len(index):
        return robustness, reasons
    restart = np.ones(len(index), dtype=bool)
    restart[1:] = (np.diff(index) != 1) | ticks.broken[index[1:]]
    order = np.arange(len(index))
    position = order - np.maximum.accumulate(np.where(restart, order, 0)) + 1
    warming = position <= formula.warmup_ticks
    persisting = ~warming & (values < 0) & (position <= formula.persist_ticks)
    undefined = ~warming & ~persisting & np.isnan(values)
    why = np.zeros(len(index), dtype=np.int64)
    why[warming] = bit[WARMING_UP]
    why[persisting] = bit[PERSISTING]
    why[undefined] = bit[UNDEFINED]
    reasons[index] = why
    judged = why == 0
    robustness[index[judged]] = values[judged]
    return robustness, reasons


def _check_updates(formula: CompiledFormula, values: np.ndarray, columns: Columns) -> None:
    """`NotReplayable` unless the monitor of `formula` has one value per tick where every
    input is finite (the ticks `_feed` updates it at)."""
    present = np.ones(columns.n, dtype=bool)
    for name in formula.signals:
        if name not in columns.names:
            present[:] = False
            break
        present &= np.isfinite(columns.column(name))
    updates = int(present.sum())
    if updates != len(values):
        raise NotReplayable(f"{formula.id}: {len(values)} values for {updates} updates")


def verdicts(
    formula: CompiledFormula, values: Mapping[str, np.ndarray], columns: Columns, ticks: Ticks
) -> Verdicts:
    """`Evaluator._judge`'s verdict at every tick, from the formula's (and its assumption's)
    robustness at their evaluated ticks (`WholeLog.values`)."""
    names = list(
        dict.fromkeys(
            [
                *(s for g in formula.monitored() for s in g.signals),
                WARMING_UP,
                PERSISTING,
                UNDEFINED,
                NO_FRAMES,
            ]
        )
    )
    if len(names) > 62:
        raise NotReplayable(f"{formula.id}: {len(names)} reasons do not fit a bit mask")
    bit = {name: 1 << k for k, name in enumerate(names)}
    rho, missing = _feed(formula, values[formula.id], columns, ticks, bit)
    code = np.where(missing != 0, NO_DATA, np.where(rho < 0, VIOLATED, OK)).astype(np.int8)
    reasons = missing
    if formula.assumption is not None:
        holds, unknown = _feed(
            formula.assumption, values[formula.assumption.id], columns, ticks, bit
        )
        outside = (unknown == 0) & (holds < 0)
        code[outside] = OUTSIDE
        code[unknown != 0] = NO_DATA
        reasons = np.where(unknown != 0, unknown | missing, np.where(outside, 0, missing))
        rho = np.where(code <= VIOLATED, rho, np.nan)
    reasons = np.where(code == NO_DATA, reasons, 0)
    return Verdicts(code, rho, reasons, names)


# -- episodes -----------------------------------------------------------------------------------


def first_reaching(t: np.ndarray, index: np.ndarray, span: float) -> np.ndarray:
    """For each tick `index[k]`, the first later tick j with `t[j] - t[index[k]] >= span`
    (len(t) when none), computed with that very subtraction."""
    n = len(t)
    if not len(index):
        return index.copy()
    base = t[index]
    j = np.searchsorted(t, base + span, side="left")
    j = np.maximum(j, index + 1)
    # the sum rounds, the subtraction the tracker computes decides: move to its first tick
    while True:
        back = (j > index + 1) & (t[np.minimum(j, n) - 1] - base >= span)
        if not back.any():
            break
        j = np.where(back, j - 1, j)
    while True:
        inside = j < n
        ahead = np.zeros(len(j), dtype=bool)
        ahead[inside] = t[j[inside]] - base[inside] < span
        if not ahead.any():
            break
        j = np.where(ahead, j + 1, j)
    return j


@dataclass
class EpisodeRuns:
    """The episodes an `EpisodeTracker` forms from one formula's ticks, per episode (arrays):
    its first and last violating tick, violating ticks, worst value and its tick, the tick
    that closes it (-1: still open at the end), whether it is dropped (shorter than
    `min_duration`) and the tick its onset is reported at (-1: never)."""

    first: np.ndarray
    last: np.ndarray
    ticks: np.ndarray
    worst: np.ndarray
    t_worst: np.ndarray
    closes: np.ndarray
    dropped: np.ndarray
    onset: np.ndarray


def episode_runs(
    t: np.ndarray,
    violated: np.ndarray,
    value: np.ndarray,
    merge_gap: float,
    min_duration: float,
    period: float,
) -> EpisodeRuns:
    """What `EpisodeTracker.step` (every tick, `value` at the violated ones) and `onset`
    (after each violated tick) produce, without stepping it: two violated ticks a < b belong
    to one episode unless a tick between them is `merge_gap` past a (the tracker closes the
    episode there) or the clean time between them is at least `merge_gap`."""
    v = np.flatnonzero(violated)
    n = len(t)
    if not len(v):
        empty = np.zeros(0, dtype=np.int64)
        return EpisodeRuns(
            empty, empty, empty, np.zeros(0), empty, empty, empty.astype(bool), empty
        )
    reach = first_reaching(t, v, merge_gap - 1e-9)  # the tick a non-violation closes at
    nxt = np.append(v[1:], n)
    closed_between = reach < nxt
    separation = t[v[1:]] - (t[v[:-1]] + period)
    split_at_next = (separation > 1e-9) & (separation >= merge_gap - 1e-9)
    split = closed_between.copy()
    split[:-1] |= split_at_next
    closes = np.where(closed_between, reach, nxt)
    # episodes: a new one starts after every split
    ends = np.flatnonzero(split)
    if not len(ends) or ends[-1] != len(v) - 1:
        ends = np.append(ends, len(v) - 1)
    starts = np.concatenate([[0], ends[:-1] + 1])
    first, last = v[starts], v[ends]
    count = ends - starts + 1
    vals = value[v]
    worst = np.minimum.reduceat(vals, starts)
    group = np.repeat(np.arange(len(starts)), count)
    at_worst = np.flatnonzero(vals == worst[group])
    _, pick = np.unique(group[at_worst], return_index=True)
    t_worst = v[at_worst[pick]]
    close_tick = np.where(split[ends], closes[ends], -1)
    close_tick[-1] = reach[ends[-1]] if reach[ends[-1]] < n else -1
    duration = (t[last] - t[first]) + period
    short = duration < min_duration - 1e-9
    dropped = short & (close_tick >= 0)
    long_enough = (t[v] - t[first][group]) + period >= min_duration - 1e-9
    reached = np.flatnonzero(long_enough)
    onset = np.full(len(starts), -1, dtype=np.int64)
    groups_on, pick_on = np.unique(group[reached], return_index=True)
    onset[groups_on] = v[reached[pick_on]]
    return EpisodeRuns(first, last, count, worst, t_worst, close_tick, dropped, onset)


# -- data gaps ----------------------------------------------------------------------------------


@dataclass
class GapRun:
    """One data gap of a formula: the tick that closes it (n: still open), and its record."""

    closes: int
    start: float
    end: float
    ticks: int
    reasons: int


def gap_runs(v: Verdicts, ticks: Ticks) -> list[GapRun]:
    """What `GapTracker` records: the ticks without data and the jumps in time between two
    judged (or outside-assumption) ticks form one gap, closed at the second of those."""
    times, broken, skipped, period = ticks.times, ticks.broken, ticks.skipped, ticks.period
    n = len(times)
    closer = np.flatnonzero(v.code != NO_DATA)
    previous = np.concatenate([[-1], closer[:-1]]) if len(closer) else closer
    nothing = (closer - previous == 1) & ~broken[closer] if len(closer) else closer.astype(bool)
    closing = [(int(c), int(p)) for c, p in zip(closer[~nothing], previous[~nothing], strict=True)]
    last = int(closer[-1]) if len(closer) else -1
    if last < n - 1:
        closing.append((n, last))
    no_frames = 1 << v.names.index(NO_FRAMES)
    out = []
    for c, p in closing:
        j = p + 1
        start = times[j - 1] + period if broken[j] else times[j]
        end = times[c] - period if c < n and broken[c] else times[c - 1]
        upto = min(c + 1, n)
        count = (c - j) + int(skipped[j:upto].sum())
        reasons = int(np.bitwise_or.reduce(v.reasons[j:c])) if c > j else 0
        if broken[j:upto].any():
            reasons |= no_frames
        out.append(GapRun(c, start, end, count, reasons))
    return out


def _named(reasons: int, names: list[str]) -> set[str]:
    return {name for k, name in enumerate(names) if reasons >> k & 1}


# -- plot series --------------------------------------------------------------------------------


@dataclass
class Buckets:
    """Where `DecimatedSeries.add` puts each tick once the whole log is in: the final bucket
    width and each tick's bucket (the width doubles as the ticks go; a tick added at an
    earlier width sits in its bucket halved once per doubling after it)."""

    width: float
    index: np.ndarray  # (n,) int64, non-decreasing
    size: int  # buckets of the series


def buckets(t: np.ndarray, period: float, max_points: int) -> Buckets:
    n = len(t)
    index = np.zeros(n, dtype=np.int64)
    if not n:
        return Buckets(0.0, index, 0)
    t0, width, level = float(t[0]), period, 0
    levels = np.zeros(n, dtype=np.int64)
    i = 0
    while i < n:
        at = np.floor((t[i:] - t0) / width + 1e-9).astype(np.int64)
        over = np.flatnonzero(at >= 2 * max_points)
        stop = n if not len(over) else i + int(over[0])
        index[i:stop] = at[: stop - i]
        levels[i:stop] = level
        if stop == n:
            break
        while math.floor((float(t[stop]) - t0) / width + 1e-9) >= 2 * max_points:
            width *= 2
            level += 1
        i = stop
    index >>= level - levels
    return Buckets(width, index, int(index.max()) + 1)


def series_bounds(b: Buckets, value: np.ndarray) -> tuple[list, list]:
    """Per bucket the least and greatest finite value (None: none), the earliest of equal
    ones (a 0.0 and a -0.0 are equal to `min`), as `DecimatedSeries` keeps them."""
    keep = np.flatnonzero(np.isfinite(value))
    if not len(keep):
        return [None] * b.size, [None] * b.size
    vals = value[keep]
    where = b.index[keep]
    starts = np.flatnonzero(np.concatenate([[True], where[1:] != where[:-1]]))
    owner = where[starts]
    # each bucket's first zero: a bound of zero takes its sign
    zeros = np.flatnonzero(vals == 0)
    group = np.searchsorted(starts, zeros, side="right") - 1
    firsts = (
        np.flatnonzero(np.concatenate([[True], group[1:] != group[:-1]])) if len(zeros) else zeros
    )
    zero_group, first_zero = group[firsts], vals[zeros[firsts]]
    out = []
    for reduce in (np.minimum, np.maximum):
        bound = reduce.reduceat(vals, starts)
        at_zero = bound[zero_group] == 0
        bound[zero_group[at_zero]] = first_zero[at_zero]
        full = np.full(b.size, np.nan)
        full[owner] = bound
        empty = np.isnan(full)  # no value in the bucket: None
        if empty.any():
            boxed = full.astype(object)
            boxed[empty] = None
            out.append(boxed.tolist())
        else:
            out.append(full.tolist())
    return out[0], out[1]


# -- the whole log --------------------------------------------------------------------------------


def _set_tracker(tracker: EpisodeTracker, runs: EpisodeRuns, times: list[float]) -> None:
    """The tracker as stepping it would leave it: counts of closed and dropped episodes, and
    the episode still open (for `finish`)."""
    done = runs.closes >= 0
    tracker.closed += int((done & ~runs.dropped).sum())
    tracker.dropped += int((done & runs.dropped).sum())
    tracker.current = None
    if len(runs.closes) and not done[-1]:
        k = len(runs.closes) - 1
        tracker.current = OpenEpisode(
            times[int(runs.first[k])],
            times[int(runs.last[k])],
            int(runs.ticks[k]),
            float(runs.worst[k]),
            times[int(runs.t_worst[k])],
            announced=bool(runs.onset[k] >= 0),
        )


def _closed(runs: EpisodeRuns, k: int, times: list[float]) -> ClosedEpisode:
    return ClosedEpisode(
        times[int(runs.first[k])],
        times[int(runs.last[k])],
        int(runs.ticks[k]),
        float(runs.worst[k]),
        times[int(runs.t_worst[k])],
    )


def judge_formula(
    evaluator: Evaluator, k: int, v: Verdicts, ticks: Ticks, bucket: Buckets, shown: np.ndarray
) -> list[Event]:
    """Fill formula `k`'s state; returns its events as (tick, order, part, what) for the
    caller to emit in the replay's order."""
    state: FormulaState = evaluator.states[k]
    formula = state.formula
    t, times, period = ticks.t, ticks.times, ticks.period
    code, rho = v.code, v.robustness
    judged = code <= VIOLATED
    violated = code == VIOLATED
    state.ticks_evaluated = int(judged.sum())
    state.ticks_violated = int(violated.sum())
    state.ticks_no_data = int((code == NO_DATA).sum()) + int(ticks.skipped.sum())
    state.ticks_outside = int((code == OUTSIDE).sum())
    if state.ticks_evaluated:
        masked = np.where(judged, rho, np.inf)
        i = int(np.argmin(masked))
        if not judged[i]:  # only +inf was judged: the first judged tick is the worst
            i = int(np.flatnonzero(judged)[0])
        state.worst, state.t_worst = float(rho[i]), times[i]
    events: list[Event] = []
    runs = episode_runs(t, violated, rho, formula.merge_gap, formula.min_duration, period)
    for e in range(len(runs.closes)):
        if runs.closes[e] >= 0 and not runs.dropped[e]:
            events.append((int(runs.closes[e]), k, 1, ("episode", _closed(runs, e, times))))
        if runs.onset[e] >= 0:
            start = times[int(runs.first[e])]
            events.append((int(runs.onset[e]), k, 2, ("onset", (start, times[int(runs.onset[e])]))))
    _set_tracker(state.episodes, runs, times)
    if state.near is not None:
        warn = formula.warn
        inside = judged & (rho >= 0.0) & (rho < warn)
        near = episode_runs(t, inside, rho - warn, formula.merge_gap, formula.min_duration, period)
        for e in range(len(near.closes)):
            if near.closes[e] >= 0 and not near.dropped[e]:
                events.append((int(near.closes[e]), k, 3, ("near", _closed(near, e, times))))
        _set_tracker(state.near, near, times)
    n = len(times)
    state.gaps.current = None
    for gap in gap_runs(v, ticks):
        missing = _named(gap.reasons, v.names)
        if gap.closes < n:
            closed = ClosedGap(gap.start, gap.end, gap.ticks, sorted(missing))
            events.append((gap.closes, k, 0, ("gap", closed)))
        else:
            state.gaps.current = OpenGap(gap.start, gap.end, gap.ticks, missing)
    value = np.where(judged, np.where(np.isnan(shown), rho, shown), np.nan)
    series: DecimatedSeries = state.series
    if n:
        series.t0, series.width = times[0], bucket.width
        series.lo, series.hi = series_bounds(bucket, value)
    return events


def odd_verdicts(
    check: OddCheck, columns: Columns, changes: ConditionChanges, n: int
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """`OddCheck.judge` at every tick: the verdict codes (inside, outside, unknown), the
    index of why into the names returned third (-1: inside), the layered part once per change
    of conditions."""
    code = np.zeros(n, dtype=np.int8)
    why = np.full(n, -1, dtype=np.int64)
    reasons: list[str] = []

    def reason(name: str) -> int:
        if name not in reasons:
            reasons.append(name)
        return reasons.index(name)

    bounds = [*(i for i, _ in changes), n]
    for (i, conditions), j in zip(changes, bounds[1:], strict=True):
        verdict, name = check._layered(conditions)
        if verdict != "inside":
            code[i:j] = _ODD.index(verdict)
            why[i:j] = reason(name) if name is not None else -1
    open_ = code == 0
    for name in check.signals:
        col = columns.column(name) if name in columns.names else np.full(n, np.nan)
        unknown = open_ & ~np.isfinite(col)
        code[unknown], why[unknown] = 2, reason(name)
        open_ &= ~unknown
        outside = open_ & ~_accepts(check.spec.attributes[name], col)
        code[outside], why[outside] = 1, reason(name)
        open_ &= ~outside
    return code, why, reasons


def _accepts(accepted: list[OddValue] | OddRange, col: np.ndarray) -> np.ndarray:
    """`odd_check._accepts` of a signal's float values, elementwise."""
    with np.errstate(invalid="ignore"):
        if isinstance(accepted, OddRange):
            ok = np.ones(len(col), dtype=bool)
            if accepted.min is not None:
                ok &= col >= accepted.min
            if accepted.max is not None:
                ok &= col <= accepted.max
            return ok
        ok = np.zeros(len(col), dtype=bool)
        for a in accepted:
            if type(a) is float:
                ok |= col == a
        return ok


def _tally(
    evaluator: Evaluator, codes: list[np.ndarray], changes: ConditionChanges, times: list[float]
) -> None:
    """`Evaluator._tally` over the whole log: per combination of conditions (in the order they
    first appear) its ticks, the stretches spent under it and each formula's counts."""
    n = len(times)
    bounds = [*(i for i, _ in changes), n]
    previous: tuple | None = None
    for (i, conditions), j in zip(changes, bounds[1:], strict=True):
        if j <= i:
            continue
        key = tuple(sorted(conditions.items()))
        if key != previous:
            evaluator.tally_spans.setdefault(key, []).append([times[i], times[i]])
            previous = key
        tally = evaluator.tallies.get(key)
        if tally is None:
            tally = evaluator.tallies[key] = {f.id: FormulaTally() for f in evaluator.spec.formulas}
            evaluator.tally_ticks[key] = 0
        evaluator.tally_ticks[key] += j - i
        evaluator.tally_spans[key][-1][1] = times[j - 1]
        for state, code in zip(evaluator.states, codes, strict=True):
            counts = np.bincount(code[i:j], minlength=4)
            tallied = tally[state.formula.id]
            tallied.evaluated += int(counts[OK] + counts[VIOLATED])
            tallied.violated += int(counts[VIOLATED])
            tallied.outside_assumption += int(counts[OUTSIDE])
            tallied.no_data += int(counts[NO_DATA])


def _odd(
    evaluator: Evaluator, columns: Columns, changes: ConditionChanges, times: list[float]
) -> tuple[list[np.ndarray], list[Event]]:
    """Every ODD check over the whole log: its counts, what put ticks outside or unknown (in
    the order they first did), its latest verdict, and its changes as events."""
    n = len(times)
    codes, events = [], []
    order = len(evaluator.states)
    for c, check in enumerate(evaluator.odd_checks):
        code, why, names = odd_verdicts(check, columns, changes, n)
        codes.append(code)
        counts = np.bincount(code, minlength=3)
        for k, name in enumerate(_ODD):
            check.counts[name] += int(counts[k])
        for verdict, by in ((1, check.outside_by), (2, check.unknown_by)):
            hit = (code == verdict) & (why >= 0)
            reasons, first, tally = np.unique(why[hit], return_index=True, return_counts=True)
            where = np.flatnonzero(hit)[first]
            for _, r, m in sorted(
                zip(where.tolist(), reasons.tolist(), tally.tolist(), strict=True)
            ):
                by[names[r]] = by.get(names[r], 0) + m
        if n:
            last = int(code[-1])
            check.last = (_ODD[last], names[int(why[-1])] if why[-1] >= 0 else None)
        before = np.concatenate([[0], code[:-1]])  # "inside" before the first tick
        for i in np.flatnonzero(code != before).tolist():
            change = OddChange(
                node_id=check.node_id,
                t=round(times[i], 6),
                state=_ODD[int(code[i])],
                because=names[int(why[i])] if why[i] >= 0 else None,
            )
            events.append((i, order + c, 0, ("odd", change)))
    return codes, events


def _statuses(
    evaluator: Evaluator, codes: list[np.ndarray], odd: list[np.ndarray], ticks: Ticks
) -> None:
    """Every node's timeline: the statuses propagated once per stretch of ticks with the same
    verdicts, the jumps in time as `no-data` spans, equal neighbours merged (`RunLength`)."""
    times, period = ticks.times, ticks.period
    n = len(times)
    if not n:
        return
    table = np.stack([*codes, *odd], axis=1) if codes or odd else np.zeros((n, 0), np.int8)
    change = np.ones(n, dtype=bool)
    change[1:] = (table[1:] != table[:-1]).any(axis=1) | ticks.broken[1:]
    starts = np.flatnonzero(change)
    ends = np.append(starts[1:], n)
    propagator = evaluator.propagator
    ids = [s.formula.id for s in evaluator.states]
    contexts = [c.node_id for c in evaluator.odd_checks]
    nodes = list(evaluator.timelines)
    names: list[str] = ["no-data"]
    index: dict[str, int] = {"no-data": 0}
    # the statuses of each distinct combination of verdicts, propagated once
    if table.shape[1]:
        combos, which = np.unique(table[starts], axis=0, return_inverse=True)
    else:  # nothing judged: one combination
        combos, which = table[:1], np.zeros(len(starts), dtype=np.int64)
    rows = []
    for row in combos.tolist():
        verdicts = {f: _VERDICT[x] for f, x in zip(ids, row, strict=False)}
        odds = {c: _ODD[x] for c, x in zip(contexts, row[len(ids) :], strict=True)}
        statuses = propagator.statuses(verdicts, odds)  # type: ignore[arg-type]
        rows.append([index.setdefault(statuses[node], len(index)) for node in nodes])
    names = list(index)
    per_run = np.array(rows, dtype=np.int64).reshape(len(combos), len(nodes))[which.ravel()]
    # the items a timeline receives in order: a jump's span before its tick, then the ticks
    jumps = np.flatnonzero(ticks.broken[starts])
    k = len(starts) + len(jumps)
    position = np.arange(len(starts)) + np.searchsorted(jumps, np.arange(len(starts)), "right")
    span_at = position[jumps] - 1
    t = ticks.t
    begin, end = np.empty(k), np.empty(k)
    count = np.empty(k, dtype=np.int64)
    begin[position], end[position], count[position] = t[starts], t[ends - 1], ends - starts
    jumped = starts[jumps]
    begin[span_at] = t[jumped - 1] + period  # as `_stream_gap` adds and subtracts
    end[span_at] = t[jumped] - period
    count[span_at] = ticks.skipped[jumped]
    total = np.concatenate([[0], np.cumsum(count)])
    begins, ends_ = begin.tolist(), end.tolist()
    value = np.zeros((k, len(nodes)), dtype=np.int64)  # a span is no-data (0)
    value[position] = per_run
    for col, node in enumerate(nodes):
        v = value[:, col]
        first = np.flatnonzero(np.concatenate([[True], v[1:] != v[:-1]]))
        last = np.append(first[1:] - 1, k - 1)
        evaluator.timelines[node].runs.extend(
            Run(names[x], begins[a], ends_[b], c)
            for x, a, b, c in zip(
                v[first].tolist(),
                first.tolist(),
                last.tolist(),
                (total[last + 1] - total[first]).tolist(),
                strict=True,
            )
        )


def judge_whole_log(
    evaluator: Evaluator,
    columns: Columns,
    changes: ConditionChanges,
    values: Mapping[str, np.ndarray],
) -> None:
    """Bring a fresh `evaluator` to the state `step` at every tick of `columns` (under the
    conditions `changes` gives) would have left it in, with `values` as each monitor's
    robustness at its evaluated ticks, emitting the same events in the same order; `finish`
    then closes what is open as after the replay. `NotReplayable` (before anything is changed)
    when the ticks cannot be judged this way."""
    t = columns.t
    n = len(t)
    if n > 1 and not bool(np.all(np.diff(t) > 0)):
        raise NotReplayable("tick times do not increase")
    if n and (not changes or changes[0][0] != 0):
        raise NotReplayable("the first tick has no conditions")
    for state in evaluator.states:
        for g in state.formula.monitored():
            _check_updates(g, values[g.id], columns)
    ticks = Ticks.of(t, evaluator.period, evaluator.max_gap)
    points = evaluator.states[0].series.max_points if evaluator.states else 1
    bucket = buckets(t, evaluator.period, points)
    events: list[Event] = []
    codes = []  # one formula's verdicts at a time: only their codes are kept
    for k, state in enumerate(evaluator.states):
        v = verdicts(state.formula, values, columns, ticks)
        signal = state.formula.signal
        shown = columns.column(signal) if signal and signal in columns.names else np.full(n, np.nan)
        events += judge_formula(evaluator, k, v, ticks, bucket, shown)
        codes.append(v.code)
    _tally(evaluator, codes, changes, ticks.times)
    odd, odd_events = _odd(evaluator, columns, changes, ticks.times)
    events += odd_events
    _statuses(evaluator, codes, odd, ticks)
    evaluator.ticks += n
    if n:
        evaluator.last_t = ticks.times[-1]
    events.sort(key=lambda e: e[:3])
    for _, k, _, (kind, what) in events:
        if kind == "odd":
            if evaluator.on_event is not None:
                evaluator.on_event(what)
            continue
        state = evaluator.states[k]
        if kind == "episode":
            evaluator._emit_episode(state, what)
        elif kind == "near":
            evaluator._emit_near(state, what)
        elif kind == "gap":
            evaluator._emit_gap(state, what)
        else:
            evaluator._announce(state, *what)
