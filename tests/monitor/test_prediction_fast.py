"""The motion family in four compiled calls per tick (issue 36) against the per-channel
formulation it replaced, value for value: chpps, ompv, crpps and crpps_mean of random streams
(channels coming and going, gaps, plans of every length, objects tracked or not, repeated and
new ids, standing objects), with the histories starting small so that every buffer grows."""

from __future__ import annotations

import math
from collections import Counter
from itertools import combinations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.families.prediction import MotionPredictionFamily
from casewatch.monitor.family import worst
from casewatch.monitor.frames import ChannelState, Ego, Objects, box_footprint
from casewatch.monitor.history import ObjectHistory, PlanHistory, chpps_frame, tick_rows
from casewatch.monitor.prediction import ompv
from casewatch.monitor.similarity import crpps_inputs
from casewatch.safety_case.model import MetricParams
from casewatch.safety_case.signals import channel_name, pair_name
from tests.monitor.reference_windows import TimedHistory


class _Similarity:
    """What the motion family reads of the similarity family: the tick's crpps inputs."""

    def __init__(self) -> None:
        self.crpps_inputs: list = []


class _Engine:
    def __init__(self, params: MetricParams, channels: list[str]):
        self.params = params
        self.channels = channels
        self.pairs = list(combinations(channels, 2))
        self.coverage: dict = {}
        self.last_arbitration = None
        self.similarity = _Similarity()

    def family(self, kind):
        return self.similarity


class _OldFamily:
    """The motion family before issue 36's second round (commit 985ff6a), verbatim but for the
    engine it reads: per channel a `TimedHistory` of `Objects` and `ompv`, the plans in a
    `PlanHistory` and `chpps_frame`, the outputs by name."""

    def __init__(self, engine: _Engine):
        self.engine = engine
        p = self.params = engine.params
        self.channels = engine.channels
        self.pairs = engine.pairs
        self._plans = PlanHistory(len(self.channels), p.plan_history, p.max_gap)
        self._objects = {c: TimedHistory(None, p.max_gap) for c in self.channels}
        self._crpps_names = {pr: pair_name("crpps", *pr) for pr in self.pairs}
        self._channel_names = {
            c: {m: channel_name(m, c) for m in ("chpps", "ompv")} for c in self.channels
        }
        self._names = [self._channel_names[c] for c in self.channels]
        self._crpps_pair_names = [self._crpps_names[pr] for pr in self.pairs]

    def step(self, t, states, out):
        p = self.params
        plans = self._plans
        lookback = p.ompv_lookback - 1e-9
        ompv_values = []
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
            items = prev.items
            while len(items) > 1 and t - items[1][0] >= lookback:
                items.popleft()
        chpps_values, crpps_fd = chpps_frame(
            plans, t, p.trajectory_decay, self.engine.similarity.crpps_inputs
        )
        self._crpps(crpps_fd, out)
        for metric, values in (("chpps", chpps_values), ("ompv", ompv_values)):
            for names, v in zip(self._names, values, strict=True):
                out[names[metric]] = v
            out[metric] = worst(values, False)

    def _crpps(self, distances, out):
        values = []
        for name, fd in zip(self._crpps_pair_names, distances, strict=True):
            v = None if fd is None else 1.0 / (1.0 + fd)
            out[name] = v
            values.append(v)
        out["crpps"] = worst(values, False)
        if distances and None not in distances:
            if len(distances) == 1:
                mean = float(distances[0])
            else:
                mean = float(np.add.reduce(np.array(distances)) / len(distances))
            out["crpps_mean"] = 1.0 / (1.0 + mean)


def _plan(rng: np.random.Generator) -> np.ndarray:
    n = int(rng.choice([0, 1, 2, 3, 8, 20, 70]))
    dt = np.cumsum(rng.uniform(0.05, 0.3, n)) - rng.uniform(0.0, 0.3)
    xy = np.cumsum(rng.normal(0.0, 1.0, (n, 2)), axis=0) + rng.normal(0.0, 0.3, 2)
    if n and rng.random() < 0.2:
        xy[:] = xy[0]  # standing still: every point in one place
    plan = np.ascontiguousarray(np.column_stack([dt, xy]))
    if rng.random() < 0.03:  # another layout than a reader's: the same values
        plan = np.asfortranarray(plan)
    return plan


def _objects(rng: np.random.Generator, tick: int, tracked: bool) -> Objects:
    k = int(rng.choice([0, 1, 2, 3, 5, 12]))
    p = int(rng.choice([0, 1, 4, 40]))
    # tracked: a few ids, repeated ones too; else new ids every tick
    ids = [str(i) for i in rng.integers(0, 6, k)] if tracked else [f"{tick}-{i}" for i in range(k)]
    pos = rng.uniform(-4.0, 4.0, (k, 2))
    pred = np.zeros((k, p, 3))
    pred_len = rng.integers(0, p + 1, k) if p else np.zeros(k, dtype=np.int64)
    pred_len = pred_len.astype(np.int64)
    for i in range(k):
        n = int(pred_len[i])
        if n:
            dt = np.cumsum(rng.uniform(0.05, 0.3, n)) - rng.uniform(0.0, 0.1)
            xy = pos[i] + np.cumsum(rng.normal(0.0, 0.6, (n, 2)), axis=0)
            pred[i, :n, 0] = dt
            pred[i, :n, 1:] = xy
            pred[i, n:] = pred[i, n - 1]  # padding: the last point repeated
    fp = np.broadcast_to(box_footprint(4.5, 2.0), (k, 4, 2)).copy()
    if rng.random() < 0.05:  # arrays of another kind than a reader's: the same values
        pos, pred = np.asfortranarray(pos), np.asfortranarray(pred)
        pred_len = pred_len.astype(np.int32)
        pos.flags.writeable = False
    return Objects(
        ids=ids,
        cls=["car"] * k,
        pos=pos,
        yaw=np.zeros(k),
        vel=np.zeros((k, 2)),
        footprints=fp,
        pred=pred,
        pred_len=pred_len,
        convex=np.ones(k, dtype=bool),
        half=np.tile([2.25, 1.0], (k, 1)),
    )


def _stream(seed: int, n_channels: int, ticks: int):
    """(t, states, crpps inputs) of a random stream."""
    rng = np.random.default_rng(seed)
    channels = [f"c{i}" for i in range(n_channels)]
    tracked = {c: bool(rng.random() < 0.8) for c in channels}
    t = 0.0
    for tick in range(ticks):
        t = round(t + float(rng.choice([0.1, 0.1, 0.1, 0.2, 0.3, 0.7])), 6)
        states = {}
        for c in channels:
            if rng.random() < 0.85:
                ego = Ego(0.0, 0.0, 0.0, 0.0, 0.0, box_footprint(4.5, 2.0))
                states[c] = ChannelState(ego, _plan(rng), _objects(rng, tick, tracked[c]))
        inputs = [
            crpps_inputs(states[a].plan, states[b].plan) if a in states and b in states else None
            for a, b in combinations(channels, 2)
        ]
        yield t, states, inputs


def _same(a: float | None, b: float | None) -> bool:
    if a is None or b is None:
        return a is b
    return type(a) is type(b) and (a == b or (math.isnan(a) and math.isnan(b)))


def _run_both(
    params: MetricParams, n_channels: int, seed: int, ticks: int, small: bool
) -> Counter[str]:
    """Both families over one stream; every output equal. Returns how many values (not None)
    each signal had, by its metric."""
    channels = [f"c{i}" for i in range(n_channels)]
    new_engine, old_engine = _Engine(params, channels), _Engine(params, channels)
    new, old = MotionPredictionFamily(new_engine), _OldFamily(old_engine)
    if small:  # every buffer grows during the stream
        plans = PlanHistory(n_channels, params.plan_history, params.max_gap, width=1)
        plans.coords = np.zeros((1, 2))
        new.use(plans, ObjectHistory(n_channels, slots=2, objects=1, points=1))
    compared: Counter[str] = Counter()
    for t, states, inputs in _stream(seed, n_channels, ticks):
        new_engine.similarity.crpps_inputs = inputs
        old_engine.similarity.crpps_inputs = inputs
        got: dict[str, float | None] = {}
        want: dict[str, float | None] = {}
        new.step(t, states, got)
        old.step(t, states, want)
        want.setdefault("crpps_mean", None)  # the old family left it to the engine's blank
        assert got.keys() == want.keys(), t
        for name, v in want.items():
            assert _same(got[name], v), (t, name, got[name], v)
            if v is not None:
                compared[name.split("_")[0] if name != "crpps_mean" else name] += 1
    return compared


@settings(max_examples=60, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.sampled_from([1, 2, 3]),
    st.sampled_from([0.1, 0.25, 0.5]),
    st.sampled_from([0.0, 0.5]),
    st.sampled_from([1, 3, 10]),
    st.booleans(),
)
def test_the_tick_equals_the_per_channel_formulation(
    seed, n_channels, lookback, standing, history, small
):
    params = MetricParams(
        ompv_lookback=lookback,
        standing_motion=standing,
        plan_history=history,
        prediction_tolerance=1.0,
        pairing_gate=3.0,
    )
    _run_both(params, n_channels, seed, 40, small)


def test_a_long_stream_compares_values_of_every_kind():
    """Enough ticks that chpps, ompv (tracked and not), crpps and crpps_mean all have values
    (the property test's streams are short)."""
    params = MetricParams(ompv_lookback=0.5, standing_motion=0.5)
    compared = _run_both(params, 3, 5, 400, small=True)
    assert min(compared[m] for m in ("chpps", "ompv", "crpps", "crpps_mean")) > 50, compared


def test_ids_forgotten_beyond_the_limit_change_nothing(monkeypatch):
    monkeypatch.setattr(ObjectHistory, "ID_LIMIT", 8)
    params = MetricParams(ompv_lookback=0.3)
    assert _run_both(params, 2, 17, 300, small=False)["ompv"] > 100


def test_object_history_grows_keeping_its_observations_in_order():
    h = ObjectHistory(1, slots=2, objects=1, points=1)
    h.count[0], h.head[0] = 2, 0  # a full ring whose newest observation is in slot 0
    h.times[0] = [2.0, 1.0]
    h.codes[0, :, 0] = [20, 10]
    h.fit(3, 45)
    assert h.times.shape == (1, 4) and h.pos.shape[2] == 6 and h.pred.shape[2] == 45
    assert h.times[0, :2].tolist() == [1.0, 2.0] and h.codes[0, :2, 0].tolist() == [10, 20]
    assert (h.count[0], h.head[0]) == (2, 1)


def test_ids_become_equal_numbers():
    h = ObjectHistory(1)
    assert h.codes_of(["a", "b", "a"]).tolist() == [0, 1, 0]
    assert h.codes_of([]).dtype == np.int64
    assert h.codes_of(["c", "b"]).tolist() == [2, 1]


def test_rows_of_the_output():
    assert tick_rows(2, 1) == {"chpps": 0, "ompv": 2, "crpps": 4, "worst": 5, "size": 9}


@pytest.mark.parametrize("bad", [(1, 1, 0, 1), (1, 1, 1, 0)])
def test_object_history_refuses_sizes_it_cannot_hold(bad):
    with pytest.raises(ValueError, match="ObjectHistory"):
        ObjectHistory(*bad)
