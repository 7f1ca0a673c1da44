"""The similarity family's one-call tick (`similarity.PairTracker`, issue 36) against the family
as it was before it: the per-pair functions (`common_view`, `compare_objects`, `LoneAges`,
`ObjectComparison.scores`, `ets`, `plan_lateral`, the ELS `TimedHistory` and `els_var`), called
one by one as the old `SimilarityFamily._pair` called them. Random drives of two and three
channels (coverage, gaps, absent channels, unpaired objects coming and going, every metric
option): every signal equal bit for bit, every "no value" a None, and the crpps inputs the
motion family reads the same arrays. Then the tick's numpy equivalents (np.sum's pairwise
summation, benefit_of_doubt's clip) on their own.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.coverage import common_view
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.families.similarity import METRICS, SimilarityFamily
from casewatch.monitor.family import MetricFamily, worst
from casewatch.monitor.frames import ChannelState, Coverage
from casewatch.monitor.history import els_var
from casewatch.monitor.lone import LoneAges, benefit_of_doubt
from casewatch.monitor.similarity import (
    PAIRING_EPS,
    _doubt_sum,
    _pairwise_sum,
    compare_objects,
    crpps_inputs,
    ego_pair,
    ets,
    pair_objects,
    plan_lateral,
    ranges_from,
)
from casewatch.safety_case.model import MetricParams
from casewatch.safety_case.signals import WORST_IS_MAX, pair_name
from tests.monitor.builders import channel, ego, frame, obj
from tests.monitor.reference_windows import TimedHistory


class ReferenceSimilarity(MetricFamily):
    """`SimilarityFamily` as it was before the one-call tick (commit 985ff6a), unchanged but
    for its name."""

    name = "similarity-reference"

    def __init__(self, engine: Any):
        super().__init__(engine)
        p = self.params
        self._els = {pr: TimedHistory(p.els_window, p.max_gap) for pr in self.pairs}
        self._lone = {
            pr: (LoneAges(p.pairing_gate, p.max_gap), LoneAges(p.pairing_gate, p.max_gap))
            for pr in self.pairs
        }
        self.crpps_inputs: list[tuple[np.ndarray, np.ndarray] | None] = []
        self._names = [tuple(pair_name(m, *pr) for m in METRICS) for pr in self.pairs]
        self._use_max = tuple(m in WORST_IS_MAX for m in METRICS)

    def step(self, t: float, st: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        self.crpps_inputs = []
        rows = []
        for (a, b), names in zip(self.pairs, self._names, strict=True):
            sa, sb = st.get(a), st.get(b)
            if sa is not None and sb is not None:
                vals = self._pair(t, a, b, sa, sb)
            else:
                vals = (None,) * len(METRICS)
                self.crpps_inputs.append(None)
                for side in self._lone[(a, b)]:
                    side.reset()
            for name, v in zip(names, vals, strict=True):
                out[name] = v
            rows.append(vals)
        if len(rows) == 1:
            for m, v in zip(METRICS, rows[0], strict=True):
                out[m] = v
            return
        for k, (m, use_max) in enumerate(zip(METRICS, self._use_max, strict=True)):
            out[m] = worst([vals[k] for vals in rows], use_max)

    def _pair(
        self, t: float, a: str, b: str, sa: ChannelState, sb: ChannelState
    ) -> tuple[float | None, ...]:
        p = self.params
        coverage = self.coverage
        els, eos, ego_dist, ego_yaw_diff = ego_pair(sa, sb)
        oa, core_a, ob, core_b = common_view(
            sa.objects,
            sa.ego,
            coverage[a],
            sb.objects,
            sb.ego,
            coverage[b],
            p.coverage_margin,
        )
        ranges: tuple[np.ndarray | None, np.ndarray | None] = (None, None)
        if p.ols_range_scale > 0.0:
            ranges = (
                ranges_from(oa.pos, sa.ego.x, sa.ego.y),
                ranges_from(ob.pos, sb.ego.x, sb.ego.y),
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
        scores = cmp.scores(
            benefit_of_doubt(age_a, p.lone_horizon),
            benefit_of_doubt(age_b, p.lone_horizon),
        )
        lone_age = max(
            age_a.max(initial=0.0) if len(age_a) else 0.0,
            age_b.max(initial=0.0) if len(age_b) else 0.0,
        )
        shift = (sa.ego.x - sb.ego.x, sa.ego.y - sb.ego.y)
        ets_value = ets(
            sa.plan, sb.plan, p.trajectory_decay, shift if p.ets_relative == 1 else None
        )
        plan_lat = plan_lateral(
            sa.plan,
            sb.plan,
            shift,
            (sa.ego.yaw, sb.ego.yaw),
            p.plan_lat_horizon,
        )
        self.crpps_inputs.append(crpps_inputs(sa.plan, sb.plan))
        window = self._els[(a, b)]
        window.push(t, els)
        return (
            els,
            eos,
            ego_dist,
            ego_yaw_diff,
            scores["ocs"],
            scores["ols"],
            scores["oos"],
            scores["oas"],
            scores["ots"],
            lone_age,
            ets_value,
            plan_lat,
            els_var([v for _, v in window.items], p.els_window),
        )


def same(x: float | None, y: float | None) -> bool:
    """x and y are the same value: both None, both NaN, or equal floats of the same sign."""
    if x is None or y is None:
        return x is None and y is None
    if math.isnan(x) or math.isnan(y):
        return math.isnan(x) and math.isnan(y)
    return x == y and math.copysign(1.0, x) == math.copysign(1.0, y)


#: Coverages a channel may declare: all-round, forward cameras, a short all-round range.
COVERAGES = [
    Coverage(),
    Coverage(fov_deg=120.0, range_m=70.0),
    Coverage(fov_deg=200.0, range_m=30.0),
    Coverage(fov_deg=360.0, range_m=25.0),
    Coverage(fov_deg=90.0),
]

#: Metric options: the defaults, the reference case's, and others (short windows, margins).
PARAMS = [
    MetricParams(),
    MetricParams(
        standing_motion=0.5,
        ols_range_scale=50.0,
        ots_time_scale=1.0,
        ets_relative=1,
        plan_smoothing=2.0,
        plan_standstill=1.0,
    ),
    MetricParams(els_window=2, lone_horizon=0.5, coverage_margin=0.0, pairing_gate=1.0),
    MetricParams(els_window=7, coverage_margin=5.0, plan_lat_horizon=0.5, trajectory_decay=1.0),
]


def _prediction(rng: np.random.Generator, x: float, y: float) -> list[list[float]] | None:
    kind = rng.integers(0, 4)
    if kind == 0:
        return None
    if kind == 1:
        return []
    n = int(rng.integers(1, 12))
    step = 0.1 if kind == 2 else 0.5
    first = float(rng.choice([0.0, step]))
    vx, vy = rng.normal(0, 5, 2).tolist()
    if rng.random() < 0.2:
        vx = vy = 0.0  # a standing prediction (standing_motion)
    return [
        [round(first + step * m, 6), x + vx * (first + step * m), y + vy * (first + step * m)]
        for m in range(n)
    ]


def _objects(
    rng: np.random.Generator, world: np.ndarray, vel: np.ndarray, miss: np.ndarray, many: bool
) -> list[dict[str, Any]]:
    """The world's cars seen with noise, each missed with its own probability (`miss`: a car
    one channel hardly ever sees stays unpaired for a while), a ghost now and then."""
    out = []
    cars = zip(world.tolist(), vel.tolist(), miss.tolist(), strict=True)
    for k, ((x, y), (vx, vy), p_miss) in enumerate(cars):
        if rng.random() < p_miss:
            continue
        x += float(rng.normal(0, 0.3))
        y += float(rng.normal(0, 0.3))
        o = obj(
            k,
            x,
            y,
            float(rng.uniform(-7, 7)),
            float(rng.uniform(0.5, 6)),
            float(rng.uniform(0.3, 3)),
            _prediction(rng, x, y),
            vx=vx + float(rng.normal(0, 0.3)),
            vy=vy + float(rng.normal(0, 0.3)),
        )
        if rng.random() < 0.2:
            del o["length"], o["width"]
            n_vert = int(rng.integers(3, 6))
            o["polygon"] = rng.uniform(-3, 3, (n_vert, 2)).tolist()
        out.append(o)
    for k in range(int(rng.integers(0, 12 if many else 3))):
        centre = world.mean(axis=0) if len(world) else np.zeros(2)
        x, y = (centre + rng.uniform(-60, 60, 2)).tolist()
        out.append(obj(f"ghost{k}", x, y, prediction=_prediction(rng, x, y)))
    return out


def _plan(rng: np.random.Generator, x: float, y: float, yaw: float, long: bool) -> list:
    if rng.random() < 0.1:
        return []
    n = int(rng.integers(1, 90 if long else 40))
    step = float(rng.choice([0.1, 0.1, 0.5]))
    first = float(rng.choice([0.0, 0.0, 0.1, 0.3]))
    speed = float(rng.choice([0.0, 10.0, 20.0]))
    bend = float(rng.normal(0, 0.05))
    return [
        [
            round(first + step * m, 6),
            x + speed * (first + step * m) * math.cos(yaw + bend * m),
            y + speed * (first + step * m) * math.sin(yaw + bend * m),
        ]
        for m in range(n)
    ]


def drive(seed: int, channels: list[str], ticks: int, many: bool = False):
    """Frames of a random drive: the world's cars around the ego (which drives at 10 m/s), each
    channel's view of them (noise, misses, ghosts), its ego estimate and its plan; gaps and
    absent channels."""
    rng = np.random.default_rng(seed)
    t = 0.0
    n_world = int(rng.integers(0, 40 if many else 6))
    world = rng.uniform(-50, 50, (n_world, 2))
    vel = np.array([10.0, 0.0]) + rng.normal(0, 3, (n_world, 2))
    # per channel and car: how often the channel misses it
    miss = rng.choice([0.0, 0.1, 0.3, 0.9, 1.0], (len(channels), n_world))
    for _ in range(ticks):
        # 0.5 and 0.5004: on either side of max_gap's edge
        dt = float(rng.choice([0.1, 0.1, 0.1, 0.1, 0.2, 0.3, 0.5, 0.5004, 0.7]))
        t = round(t + dt, 6)
        world = world + vel * dt
        x0, y0, yaw0 = 10.0 * t, 0.0, float(rng.normal(0, 0.3))
        chans = {}
        first_yaw = None
        for i, c in enumerate(channels):
            if rng.random() < 0.05:
                continue  # a dropout
            x = x0 + float(rng.normal(0, 0.5))
            y = y0 + float(rng.normal(0, 0.5))
            yaw = yaw0 + float(rng.normal(0, 0.05))
            if rng.random() < 0.1:
                # the channels disagree about the heading entirely (plan_lat's fallback
                # direction, the mean heading, is then about zero)
                yaw = (first_yaw if first_yaw is not None else yaw0) + math.pi
            if first_yaw is None:
                first_yaw = yaw
            objects = _objects(rng, world, vel, miss[i], many)
            chans[c] = channel(ego(x, y, yaw), _plan(rng, x, y, yaw, many), objects)
        yield frame(t, chans)


def check_drive(
    seed: int, channels: list[str], params: MetricParams, ticks: int = 60, many: bool = False
) -> tuple[int, SimilarityFamily]:
    """Run the family and the reference over a random drive; return the number of ticks at
    which an object had been unpaired for more than one tick (a lone age above 0), and the
    family."""
    rng = np.random.default_rng(seed + 1)
    coverage = {c: COVERAGES[int(rng.integers(0, len(COVERAGES)))] for c in channels}
    engine = MetricEngine(params, channels, coverage)
    family = engine.family(SimilarityFamily)
    reference = ReferenceSimilarity(engine)
    remembered = 0
    for k, f in enumerate(drive(seed, channels, ticks, many)):
        if k == ticks // 2:
            # the run learns the coverage from the stream's header after the engine is built
            engine.coverage = {c: COVERAGES[int(rng.integers(0, len(COVERAGES)))] for c in channels}
        states = engine._resampled(f)
        got: dict[str, float | None] = dict.fromkeys(engine.signal_names)
        want: dict[str, float | None] = dict.fromkeys(engine.signal_names)
        family.step(f.t, states, got)
        reference.step(f.t, states, want)
        assert list(got) == list(want)
        for name in want:
            assert same(got[name], want[name]), (f.t, name, got[name], want[name])
            assert got[name] is None or type(got[name]) is float
        assert len(family.crpps_inputs) == len(reference.crpps_inputs)
        for x, y in zip(family.crpps_inputs, reference.crpps_inputs, strict=True):
            assert (x is None) == (y is None)
            if x is not None and y is not None:
                assert len(x) == len(y) == 2
                for u, v in zip(x, y, strict=True):
                    assert u.dtype == v.dtype and u.shape == v.shape
                    assert np.array_equal(u, v)
        remembered += bool(want["lone_age"])
    return remembered, family


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(range(len(PARAMS))))
def test_two_channels_equal_the_old_family(seed, which):
    check_drive(seed, ["a", "b"], PARAMS[which])


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(range(len(PARAMS))))
def test_three_channels_equal_the_old_family(seed, which):
    """Three pairs: each pair's values and the worst pair's."""
    check_drive(seed, ["a", "b", "c"], PARAMS[which])


@pytest.mark.parametrize("seed", range(4))
def test_many_objects_and_long_plans_grow_the_arrays(seed):
    """More objects than the tracker's first memory holds and plans longer than its first
    weights: it grows and repeats the call, the values still the old family's."""
    _, family = check_drive(seed, ["a", "b"], PARAMS[seed % len(PARAMS)], ticks=40, many=True)
    tracker = family._trackers[0]
    assert tracker.mem_age.shape[1] > 16 and len(tracker.w) > 64


def test_the_drives_remember_unpaired_objects():
    """The random drives do exercise the lone ages (objects unpaired, remembered, found)."""
    counts = [check_drive(s, ["a", "b"], PARAMS[0])[0] for s in range(6)]
    assert sum(counts) > 30, counts


def test_absent_channel_writes_no_value_and_forgets_the_unpaired():
    engine = MetricEngine(MetricParams(), ["a", "b"])
    family = engine.family(SimilarityFamily)
    car = [obj("1", 20.0, 0.0)]
    out: dict[str, float | None] = dict.fromkeys(engine.signal_names, 0.5)
    family.step(0.0, engine._resampled(frame(0.0, {"a": channel(ego(), objects=car)})), out)
    assert all(out[m] is None and out[pair_name(m, "a", "b")] is None for m in METRICS)
    assert family.crpps_inputs == [None]

    def both(t: float):
        return engine._resampled(frame(t, {"a": channel(ego(), objects=car), "b": channel(ego())}))

    family.step(0.1, both(0.1), out)
    family.step(0.2, both(0.2), out)
    assert out["lone_age"] == pytest.approx(0.1)  # unpaired since 0.1
    family.step(0.3, engine._resampled(frame(0.3, {"a": channel(ego(), objects=car)})), out)
    family.step(0.4, both(0.4), out)
    assert out["lone_age"] == 0.0  # the absence forgot it: a new unpaired object
    assert out["els"] == 1.0 and out["ocs"] == 0.5 and out["ets"] is None


# --- the tick's numpy equivalents ---


@st.composite
def sum_cases(draw):
    n = draw(st.integers(0, 700))
    scale = draw(st.sampled_from([1e-8, 1.0, 1e8]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, n) * scale * 10.0 ** rng.integers(-6, 6, n)
    if n and draw(st.booleans()):
        x[rng.random(n) < 0.3] = -0.0
    return x


@settings(max_examples=300, deadline=None)
@given(sum_cases())
def test_pairwise_sum_is_numpys_sum(x):
    """0.0 + the compiled pairwise sum is np.sum, bit for bit, at every length (the leaves
    below 8 and up to 128 values, the halving above)."""
    got = 0.0 + _pairwise_sum(x)
    want = float(np.sum(x))
    assert same(got, want)


@pytest.mark.parametrize("n", [*range(0, 20), 127, 128, 129, 136, 255, 256, 257, 1000, 4099])
def test_pairwise_sum_every_block_boundary(n):
    rng = np.random.default_rng(n)
    x = rng.uniform(0, 1, n) * 10.0 ** rng.integers(-8, 8, n)
    assert same(0.0 + _pairwise_sum(x), float(np.sum(x)))


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.one_of(st.floats(0.0, 10.0), st.sampled_from([0.0, 0.5, 1.0, 2.0, 2.5])),
        min_size=1,
        max_size=200,
    ),
    st.sampled_from([0.1, 0.5, 1.0, 2.0, 3.3, 60.0]),
)
def test_doubt_sum_is_the_benefit_of_doubt_summed(ages, horizon):
    """The tick's share of the benefit of the doubt: np.sum(benefit_of_doubt(age, horizon))."""
    age = np.array(ages)
    assert same(_doubt_sum(age, horizon), float(np.sum(benefit_of_doubt(age, horizon))))


def test_hand_computed_tick():
    """One tick by hand: a car both channels see 1 m apart, one only A sees (unpaired)."""
    engine = MetricEngine(MetricParams(), ["a", "b"])
    family = engine.family(SimilarityFamily)
    plan = [[0.1 * k, 1.0 * k, 0.0] for k in range(31)]
    a = channel(ego(), plan, [obj("1", 20.0, 0.0), obj("2", -30.0, 5.0)])
    b = channel(ego(0.0, 1.0), plan, [obj("9", 21.0, 0.0)])
    out: dict[str, float | None] = dict.fromkeys(engine.signal_names)
    family.step(0.0, engine._resampled(frame(0.0, {"a": a, "b": b})), out)
    assert out["els"] == 0.5 and out["eos"] == 1.0 and out["ego_dist"] == 1.0
    assert out["ocs"] == 0.5  # one unpaired object on one side: 1 / (1 + 1)
    # the pair's ols 1 / (1 + 1); the unpaired car, first seen, keeps the benefit of the
    # doubt: the pairs' mean again, so (0.5 + 0.5) / 2
    assert out["ols"] == 0.5
    assert out["lone_age"] == 0.0 and out["els_var"] is None
    assert out["ets"] == 1.0  # the same plan in the world (ets_relative 0)
    # plan_lat moves plan B by ego A - ego B first: 1 m to the side at every point
    assert out["plan_lat"] == 1.0


def reference_pairing(pos_a: np.ndarray, pos_b: np.ndarray, gate: float):
    """`_pair_kernel` as it was before its squared-distance prefilter, in plain Python: every
    distance's square root, the candidates within gate + 1e-9 in (A, B) order, a stable sort
    on the distance in units of 1e-9 m, greedy acceptance."""
    cands = []
    for i, (xa, ya) in enumerate(pos_a.tolist()):
        for j, (xb, yb) in enumerate(pos_b.tolist()):
            dx, dy = xa - xb, ya - yb
            d = math.sqrt(dx * dx + dy * dy)
            if d <= gate + PAIRING_EPS:
                cands.append((float(np.rint(d / PAIRING_EPS)), i, j, d))
    used_a, used_b, out = set(), set(), []
    for _, i, j, d in sorted(cands, key=lambda c: c[0]):
        if i not in used_a and j not in used_b:
            used_a.add(i)
            used_b.add(j)
            out.append((i, j, d))
    return out


@st.composite
def pairing_case(draw):
    """Objects on a coarse grid (ties), scattered widely, or at the gate's edge to within a
    few roundings; gates from the edges of the prefilter's range."""
    gate = draw(
        st.sampled_from(
            [3.0, 0.5, 0.0, -1e-9, -1.0, 1e-120, 1e-60, 1e99, 1e101, math.inf, 1.0 / 3.0]
        )
    )
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    na, nb = int(rng.integers(0, 12)), int(rng.integers(0, 12))
    kind = draw(st.sampled_from(["grid", "wide", "edge"]))
    if kind == "grid":
        pos_a = rng.integers(0, 4, (na, 2)) * 1.5
        pos_b = rng.integers(0, 4, (nb, 2)) * 1.5
    elif kind == "wide":
        pos_a = rng.uniform(-1, 1, (na, 2)) * 10.0 ** rng.integers(-3, 4, (na, 1))
        pos_b = rng.uniform(-1, 1, (nb, 2)) * 10.0 ** rng.integers(-3, 4, (nb, 1))
    else:  # B's objects at about the gate from A's, along random directions
        reach = gate + PAIRING_EPS if math.isfinite(gate) and gate > 0 else 1.0
        pos_a = rng.uniform(-50, 50, (na, 2))
        angle = rng.uniform(0, 2 * math.pi, nb)
        near = pos_a[rng.integers(0, na, nb)] if na else np.zeros((nb, 2))
        r = reach * (1.0 + rng.choice([-1e-15, 0.0, 1e-16, 2e-16, 1e-13, 1e-12, 1e-11], nb))
        pos_b = near + np.column_stack([r * np.cos(angle), r * np.sin(angle)])
    return (
        np.ascontiguousarray(pos_a, dtype=float).reshape(-1, 2),
        np.ascontiguousarray(pos_b, dtype=float).reshape(-1, 2),
        gate,
    )


@settings(max_examples=400, deadline=None)
@given(pairing_case())
def test_pairing_prefilter_changes_no_pair(case):
    """The pairing kernel with its squared-distance prefilter accepts the same pairs, in the
    same order, at the same distances as before it."""
    pos_a, pos_b, gate = case
    ia, ib, dist = pair_objects(pos_a, pos_b, gate)
    got = list(zip(ia.tolist(), ib.tolist(), dist.tolist(), strict=True))
    assert got == reference_pairing(pos_a, pos_b, gate)
