"""The safety family's one-call tick (`safety_kernel._tick`) against the Python composition it
replaces (`safety_matrix`, `worst`, `arbitrate`), value for value over sequences of ticks, with
the matrix computed by the numpy path (`score_grid_numpy`, independent of the kernel); and the
heading-cone prefilter of the PET search against the per-pair test it stands for."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor import safety_score
from casewatch.monitor.families.safety import SafetyFamily
from casewatch.monitor.frames import ChannelState
from casewatch.monitor.safety_kernel import (
    CONE_SLACK,
    PYTHON_PATH,
    REAR_END_ANGLE,
    REAR_END_COS,
    Scene,
    _all_rear_end,
    _tick,
)
from casewatch.safety_case.model import MetricParams
from tests.monitor.builders import channel, ego, frame, obj, straight_plan
from tests.monitor.test_safety_kernel import box_world, path

PET_REF = 2.0


class _Engine:
    """What a family sees of the engine."""

    def __init__(self, channels: list[str], standstill: float):
        self.params = MetricParams(pet_ref=PET_REF, plan_standstill=standstill)
        self.channels = channels
        self.pairs: list[tuple[str, str]] = []
        self.coverage: dict = {}
        self.last_arbitration: str | None = None


def _reference(channels: list[str], standstill: float) -> tuple[_Engine, SafetyFamily]:
    engine = _Engine(channels, standstill)
    return engine, SafetyFamily(engine)  # type: ignore[arg-type]


def _numpy_step(family: SafetyFamily, states: dict[str, ChannelState], out: dict) -> None:
    """The old composition, its matrix by the numpy path (the kernel declines every scene)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(safety_score, "score_boxes", lambda *args: None)
        family._step_python(states, out)


def _same(a: float | None, b: float | None) -> bool:
    if a is None or b is None:
        return a is b
    return type(a) is type(b) and (a == b or (math.isnan(a) and math.isnan(b)))


@st.composite
def tick(draw, names: list[str]) -> dict[str, ChannelState]:
    """The channels present at one tick: each absent now and then; plans empty, of one point,
    standing, or moving on 0.1 s or 0.2 s grids of different lengths (prefix grids, others);
    box egos (a polygon one now and then); box objects predicted over different horizons, a
    polygon object now and then."""
    chans = {}
    first_plan: list[list[float]] | None = None
    for name in names:
        if draw(st.integers(0, 9)) == 0:
            continue
        kind = draw(st.sampled_from(["moving"] * 6 + ["empty", "one", "standing"]))
        n = draw(st.integers(2, 16))
        step = draw(st.sampled_from([0.1, 0.1, 0.2]))
        times = [round(step * q, 2) for q in range(n)]
        plan: list[list[float]]
        if kind == "empty":
            plan = []
        elif kind == "one":
            plan = [[0.0, 1.0, 0.5]]
        else:
            plan = draw(path(n, times, kind == "standing"))
        first_plan = first_plan or (plan if len(plan) > 2 else None)
        e = ego(0, 0, draw(st.floats(-3.2, 3.2)), draw(st.floats(1, 6)), draw(st.floats(1, 3)))
        if draw(st.integers(0, 19)) == 0:
            e = {"x": 0, "y": 0, "yaw": 0, "polygon": [[2, 1], [-2, 1], [-2, -1], [2, -1]]}
        objects = []
        if draw(st.integers(0, 4)):
            pred_times = [round(0.1 * q, 2) for q in range(20)]
            objects = draw(box_world(pred_times, first_plan or straight_plan(0, 0, 8, 0, 12)))
            if draw(st.integers(0, 19)) == 0:
                objects.append(
                    {"id": 99, "x": 5, "y": 0, "polygon": [[1, 1], [-1, 1], [-1, -1], [1, -1]]}
                )
        chans[name] = channel(e, plan=plan, objects=objects)
    return dict(frame(0.0, chans).channels)


@st.composite
def ticks(draw) -> tuple[list[str], float, list[dict[str, ChannelState]]]:
    names = ["a", "b", "c"][: draw(st.integers(1, 3))]
    standstill = draw(st.sampled_from([0.0, 1.0]))
    return names, standstill, [draw(tick(names)) for _ in range(draw(st.integers(1, 4)))]


@settings(max_examples=300, deadline=None)
@given(ticks())
def test_tick_equals_the_python_composition(data):
    names, standstill, sequence = data
    engine, family = _reference(names, standstill)
    ref_engine, ref_family = _reference(names, standstill)
    for states in sequence:
        got: dict = {}
        want: dict = {}
        family.step(0.0, states, got)
        _numpy_step(ref_family, states, want)
        assert got.keys() == want.keys()
        for key, value in want.items():
            assert _same(got[key], value), (key, got[key], value)
        assert engine.last_arbitration == ref_engine.last_arbitration


def _two_channels(plan_b: list[list[float]]) -> dict[str, ChannelState]:
    plan = straight_plan(0, 0, 10, 0, 31)
    return dict(
        frame(
            0.0,
            {
                "a": channel(ego(), plan=plan, objects=[obj(1, 13.5, 0)]),
                "b": channel(ego(), plan=plan_b, objects=[]),
            },
        ).channels
    )


def test_ties_keep_the_previous_channel_and_dropouts_leave_none():
    # a's object (4 x 2 at 13.5 m) stands in both plans (the same plan, 10 m/s for 3 s):
    # ttc = 1.0 s (front 12.0 >= its rear 11.5 at 1.0 s), ss_aa = ss_ba = 1/3; b sees nothing.
    engine, family = _reference(["a", "b"], 0.0)
    out: dict = {}
    family.step(0.0, _two_channels(straight_plan(0, 0, 10, 0, 31)), out)
    assert out["ss__a__a"] == pytest.approx(1 / 3) and out["ss__b__a"] == pytest.approx(1 / 3)
    assert out["ss__a__b"] == 1.0 and out["ss__b__b"] == 1.0
    assert out["ss__a"] == out["ss__b"] == out["ss"] == out["ss__a__a"]
    assert engine.last_arbitration == "a"  # a tie: the first declared channel
    engine.last_arbitration = "b"
    family.step(0.1, _two_channels(straight_plan(0, 0, 10, 0, 31)), out)
    assert engine.last_arbitration == "b"  # a tie keeps the previous recommendation
    # b drops out: its row and column have no value, nor the worst values that read them
    only_a = {"a": _two_channels([])["a"]}
    family.step(0.2, only_a, out)
    assert out["ss__a__a"] == pytest.approx(1 / 3)
    assert out["ss__a__b"] is None and out["ss__b__a"] is None and out["ss__b__b"] is None
    assert out["ss__a"] is None and out["ss__b"] is None and out["ss"] is None
    assert engine.last_arbitration == "a"  # b has no value: not a candidate
    family.step(0.3, {}, out)
    assert all(v is None for v in out.values()) and engine.last_arbitration is None


def test_a_shorter_plan_that_does_not_meet_wins():
    # b plans 0.5 s (the first 6 points of the same grid): it ends before the object at 1.0 s,
    # so ss_ba = 1.0; ss_aa = 1/3. b's plan is the better one: arbitration b.
    engine, family = _reference(["a", "b"], 0.0)
    out: dict = {}
    family.step(0.0, _two_channels(straight_plan(0, 0, 10, 0, 6)), out)
    assert out["ss__a__a"] == pytest.approx(1 / 3) and out["ss__b__a"] == 1.0
    assert out["ss__a"] == pytest.approx(1 / 3) and out["ss__b"] == 1.0
    assert engine.last_arbitration == "b"


def test_ticks_the_kernel_leaves_take_the_python_path():
    # a plan whose rows up to the horizon are not a prefix (dt not increasing: the reader
    # refuses such plans, a caller building states may not), and a NaN best score.
    states = _two_channels(straight_plan(0, 0, 10, 0, 31))
    scene = Scene(2)
    for c, name in enumerate(["a", "b"]):
        s = states[name]
        scene.load(c, s.plan, s.ego.yaw, s.ego.half, s.objects)  # type: ignore[arg-type]
    assert _tick(scene.data, scene.meta, scene.egos, PET_REF, False, -1, scene.vals, scene.nones)
    assert not scene.meta[:, 0].any()  # present flags cleared for the next tick
    shuffled = states["a"].plan.copy()
    shuffled[[3, 40 % len(shuffled)]] = shuffled[[40 % len(shuffled), 3]]
    shuffled[5, 0] = 99.0  # beyond the object's horizon (none: inf), so the cut is every row
    bad = replace(states["a"], objects=replace(states["a"].objects))
    bad.plan = shuffled
    bad.objects.pred = np.array([[[0.0, 13.5, 0.0], [2.0, 13.5, 0.0]]])
    bad.objects.pred_len = np.array([2])
    for c, s in enumerate([bad, states["b"]]):
        scene.load(c, s.plan, s.ego.yaw, s.ego.half, s.objects)  # type: ignore[arg-type]
    code = _tick(scene.data, scene.meta, scene.egos, PET_REF, False, -1, scene.vals, scene.nones)
    assert code == PYTHON_PATH
    engine, family = _reference(["a", "b"], 0.0)
    ref_engine, ref_family = _reference(["a", "b"], 0.0)
    got: dict = {}
    want: dict = {}
    family.step(0.0, {"a": bad, "b": states["b"]}, got)
    ref_family._step_python({"a": bad, "b": states["b"]}, want)
    assert got == want and engine.last_arbitration == ref_engine.last_arbitration


headings = st.lists(st.floats(-math.pi, math.pi), min_size=1, max_size=12)


@settings(max_examples=2000, deadline=None)
@given(headings, headings, st.floats(-0.6, 0.6), st.floats(-0.6, 0.6))
def test_heading_cone_drops_only_rear_end_pairs(ego_yaws, obj_yaws, spread, offset):
    # Headings near a common direction (so that both answers occur): whenever the cone test
    # says every pair is rear-end, the per-pair test says so for each pair.
    ec = np.cos(np.array(ego_yaws) * spread)
    es = np.sin(np.array(ego_yaws) * spread)
    oc = np.cos(np.array(obj_yaws) * spread + offset)
    os_ = np.sin(np.array(obj_yaws) * spread + offset)
    n = min(len(ec), len(oc) + 1)
    if n < 2:
        return
    if _all_rear_end(ec, es, oc, os_, n):
        for t in range(n):
            for h in range(n - 1):
                assert ec[t] * oc[h] + es[t] * os_[h] > REAR_END_COS


def test_heading_cone_on_hand_computed_angles():
    # Straight ahead both: 0 apart, all rear-end. Ego turning to 10 deg, object at -15 deg:
    # at most 25 deg apart (< 30): dropped. Object at -21 deg: 31 deg apart: kept. A NaN: kept.
    def unit(deg: list[float]) -> tuple[np.ndarray, np.ndarray]:
        r = np.radians(deg)
        return np.cos(r), np.sin(r)

    ec, es = unit([0, 5, 10])
    assert _all_rear_end(ec, es, *unit([0, 0]), 3)
    assert _all_rear_end(ec, es, *unit([0, -15]), 3)
    assert not _all_rear_end(ec, es, *unit([0, -21]), 3)
    oc, os_ = unit([0, -15])
    oc[1] = math.nan
    assert not _all_rear_end(ec, es, oc, os_, 3)
    assert math.degrees(REAR_END_ANGLE - CONE_SLACK) < 30.0


def test_a_scene_too_short_grows_and_keeps_the_rows_loaded():
    # Rows of 4 floats hold no plan: loading a (31 plan points x 3, one object without a
    # prediction: 6 floats) grows them to max(99, 2 x 4); b (93 floats) then fits. The tick
    # scores as a fresh family does.
    _, family = _reference(["a", "b"], 0.0)
    family._scene = Scene(2, capacity=4)
    out: dict = {}
    family.step(0.0, _two_channels(straight_plan(0, 0, 10, 0, 31)), out)
    assert family._scene.data.shape[1] == 3 * 31 + 6
    want: dict = {}
    _reference(["a", "b"], 0.0)[1].step(0.0, _two_channels(straight_plan(0, 0, 10, 0, 31)), want)
    assert out == want and out["ss__a__a"] == pytest.approx(1 / 3)


def test_object_arrays_of_any_layout_score_as_the_reader_s():
    # A frame built in memory may hold Fortran-ordered, strided, int32 or read-only arrays:
    # _load copies them whatever their kind, and the tick gives what the reader's arrays give.
    plan = straight_plan(0, 0, 10, 0, 31)
    pred = straight_plan(13.5, -6, 0, 6, 21)  # crossing the plan from the right at 6 m/s
    f = frame(
        0.0,
        {
            "a": channel(
                ego(), plan=plan, objects=[obj(1, 13.5, -6, math.pi / 2, prediction=pred)]
            ),
            "b": channel(ego(), plan=plan, objects=[obj(2, 30, 0), obj(3, 8, 3.1)]),
        },
    )
    states = dict(f.channels)
    _, family = _reference(["a", "b"], 0.0)
    want: dict = {}
    family.step(0.0, states, want)
    odd = {}
    for name, s in states.items():
        o = replace(s.objects)
        o.pred = np.asfortranarray(o.pred)
        o.pred_len = o.pred_len.astype(np.int32)
        o.pos = np.ascontiguousarray(np.repeat(o.pos, 2, axis=0)[::2])  # same values
        o.pos = np.hstack([o.pos, o.pos])[:, :2]  # strided view
        o.half = o.half.copy()
        o.half.flags.writeable = False
        odd[name] = replace(s, plan=np.asfortranarray(s.plan), objects=o)
    _, fresh = _reference(["a", "b"], 0.0)
    got: dict = {}
    fresh.step(0.0, odd, got)
    assert got == want
    assert want["ss__a__a"] < 1.0  # the crossing object counts
