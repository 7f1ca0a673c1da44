"""MetricEngine: signal set, missing data, warm-up, gap resets, arbitration, properties."""

from __future__ import annotations

import copy
import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.parse import parse_frame
from casewatch.safety_case.model import MetricParams
from casewatch.safety_case.signals import (
    PAIR_METRICS,
    SITUATION_METRICS,
    builtin_signals,
    pair_name,
)
from tests.monitor.builders import channel, ego, frame, obj, straight_plan

AB = ["a", "b"]


def simple(t: float, x_b: float = 1.0, plan: bool = True) -> dict[str, Any]:
    p = straight_plan(0, 0, 10, 0, 10) if plan else []
    return {
        "a": channel(ego(10 * t, 0), plan=p, objects=[obj(1, 30, 0)]),
        "b": channel(ego(10 * t + x_b, 0), plan=p, objects=[obj(1, 30.5, 0)]),
    }


def test_every_builtin_signal_and_passthrough():
    eng = MetricEngine(MetricParams(), AB)
    out = eng.step(frame(0.0, simple(0.0), signals={"speed_limit": 13.9, "gap": None}))
    assert set(builtin_signals(AB)) <= set(out)
    assert out["speed_limit"] == 13.9 and out["gap"] is None
    assert out["els"] == pytest.approx(0.5)  # 1 m apart -> 1 / (1 + 1)
    assert out["els__a__b"] == out["els"]
    assert eng.arbitration() == eng.last_arbitration == "a"  # tie on the first tick -> first
    assert all(v is None or isinstance(v, float) for v in out.values())


def test_warm_up_then_values():
    eng = MetricEngine(MetricParams(), AB)
    outs = [eng.step(frame(round(0.1 * k, 1), simple(0.1 * k))) for k in range(32)]
    # els_var: no value until 5 ELS values; constant ELS -> 0
    assert [o["els_var"] is None for o in outs[:5]] == [True] * 4 + [False]
    assert outs[4]["els_var"] == pytest.approx(0.0)
    # ompv and chpps need one earlier tick; hcs positions reaching back comfort_span (3 s)
    assert outs[0]["ompv"] is None and outs[1]["ompv"] is not None
    assert outs[0]["chpps"] is None and outs[1]["chpps"] is not None
    assert all(o["hcs"] is None for o in outs[:30]) and outs[30]["hcs"] == pytest.approx(1.0)
    # the objects stand still with no prediction: predicted = actual -> 1.0
    assert outs[1]["ompv"] == 1.0


def test_dropout_gives_no_value_never_a_pass():
    eng = MetricEngine(MetricParams(), AB)
    for k in range(5):
        eng.step(frame(round(0.1 * k, 1), simple(0.1 * k)))
    only_a = {"a": simple(0.5)["a"]}
    out = eng.step(frame(0.5, only_a))
    for m in PAIR_METRICS:
        assert out[m] is None and out[pair_name(m, "a", "b")] is None
    assert out["crpps_mean"] is None
    assert out["ppcs__a"] is not None and out["ppcs__b"] is None and out["ppcs"] is None
    assert out["ss__a__a"] == 1.0 and out["ss__a__b"] is None and out["ss"] is None
    assert eng.arbitration() == "a"
    # a one-tick dropout (0.2 s < max_gap) does not restart the ELS window ...
    out = eng.step(frame(0.6, simple(0.6)))
    assert out["els_var"] is not None
    # ... but an absence longer than max_gap does
    for k in range(7, 14):
        eng.step(frame(round(0.1 * k, 1), only_a | {}))
    out = eng.step(frame(1.4, simple(1.4)))
    assert out["els_var"] is None and out["ompv__b"] is None and out["chpps__b"] is None


def test_time_gap_restarts_history():
    eng = MetricEngine(MetricParams(), AB)
    for k in range(6):
        out = eng.step(frame(round(0.1 * k, 1), simple(0.1 * k)))
    assert out["els_var"] is not None
    out = eng.step(frame(1.2, simple(1.2)))  # 0.7 s > max_gap 0.5 s
    assert out["els_var"] is None and out["ompv"] is None and out["chpps"] is None


def test_hcs_window_slides_and_restarts_after_a_gap():
    eng = MetricEngine(MetricParams(), AB)
    outs = [eng.step(frame(round(0.1 * k, 1), simple(0.1 * k))) for k in range(34)]
    # positions reaching back 3 s from tick 30 on, sliding (constant speed: no acceleration)
    assert [o["hcs__a"] is None for o in outs] == [True] * 30 + [False] * 4
    assert outs[33]["hcs__a"] == pytest.approx(1.0)
    # 0.6 s without channel b (> max_gap): b's window restarts, a's keeps sliding
    for k in range(34, 40):
        out = eng.step(frame(round(0.1 * k, 1), {"a": simple(0.1 * k)["a"]}))
    assert out["hcs__a"] == pytest.approx(1.0) and out["hcs__b"] is None
    outs = [eng.step(frame(round(0.1 * k, 1), simple(0.1 * k))) for k in range(40, 71)]
    assert [o["hcs__b"] is None for o in outs] == [True] * 30 + [False]
    # b stops dead from 10 m/s at t = 3.0 s: while the stop passes through b's window the
    # score drops (lowest, 0.57, with the stop a third of the way in), a's stays 1
    eng = MetricEngine(MetricParams(), AB)
    worst = {"hcs__a": 1.0, "hcs__b": 1.0}
    for k in range(51):
        f = simple(0.1 * k)
        f["b"] = channel(
            ego(10 * 0.1 * min(k, 30), 0), plan=straight_plan(0, 0, 10, 0, 10), objects=[]
        )
        out = eng.step(frame(round(0.1 * k, 1), f))
        if out["hcs__b"] is not None:
            assert out["hcs"] == out["hcs__b"]
            worst = {n: min(worst[n], out[n]) for n in worst}
    assert worst["hcs__b"] < 0.6 and worst["hcs__a"] == pytest.approx(1.0)


def test_empty_plan_gives_no_plan_metrics():
    eng = MetricEngine(MetricParams(), AB)
    out = eng.step(frame(0.0, simple(0.0, plan=False)))
    for name in ("ets", "crpps", "crpps_mean", "ppcs", "ss", "chpps"):
        assert out[name] is None
    assert out["els"] is not None


def test_non_increasing_time_is_refused():
    eng = MetricEngine(MetricParams(), AB)
    eng.step(frame(1.0, simple(0.0)))
    with pytest.raises(ValueError, match="does not increase"):
        eng.step(frame(1.0, simple(0.0)))


# -- properties --------------------------------------------------------------------------

coord = st.floats(-20, 20, allow_nan=False)
heading = st.floats(-math.pi, math.pi, allow_nan=False)
size = st.floats(0.5, 5)


@st.composite
def trajectory(draw: Any, max_len: int) -> list[list[float]]:
    # Smooth paths (velocity plus centimetre noise): random jumps would saturate the comfort
    # normalisation at 1 and make the comfort properties vacuous.
    n = draw(st.integers(0, max_len))
    x, y = draw(coord), draw(coord)
    vx, vy = draw(st.floats(-15, 15)), draw(st.floats(-15, 15))
    pts = []
    for i in range(n):
        pts.append([round(0.1 * i, 1), x, y])
        x += 0.1 * vx + draw(st.floats(-0.02, 0.02))
        y += 0.1 * vy + draw(st.floats(-0.02, 0.02))
    return pts


@st.composite
def channel_state(draw: Any, k: int, motion: tuple[float, ...]) -> dict[str, Any]:
    """A channel at tick k; the ego follows `motion` (x0, y0, vx, vy) with centimetre noise."""
    objs = []
    for i in range(draw(st.integers(0, 4))):
        o = obj(i, draw(coord), draw(coord), draw(heading), draw(size), draw(size))
        pred = draw(trajectory(5))
        if pred:
            o["prediction"] = pred
        objs.append(o)
    x0, y0, vx, vy, yaw = motion
    t = 0.1 * k
    e = ego(
        x0 + vx * t + draw(st.floats(-0.01, 0.01)),
        y0 + vy * t + draw(st.floats(-0.01, 0.01)),
        yaw + draw(st.floats(-0.05, 0.05)),
        draw(size),
        draw(size),
    )
    e["vx"], e["vy"] = draw(coord), draw(coord)
    return channel(e, plan=draw(trajectory(8)), objects=objs)


@st.composite
def stream(draw: Any, identical: bool = False) -> list[dict[str, Any]]:
    frames = []
    speed = st.floats(-15, 15)
    motion_a = (draw(coord), draw(coord), draw(speed), draw(speed), draw(heading))
    motion_b = (draw(coord), draw(coord), draw(speed), draw(speed), draw(heading))
    for k in range(draw(st.sampled_from([3, 6, 11]))):  # before, at and after warm-ups
        a = draw(channel_state(k, motion_a))
        b = copy.deepcopy(a) if identical else draw(channel_state(k, motion_b))
        frames.append({"t": round(0.1 * k, 1), "channels": {"a": a, "b": b}})
    return frames


def run(frames: list[dict[str, Any]], channels: list[str] = AB) -> list[dict[str, Any]]:
    eng = MetricEngine(MetricParams(), channels)
    outs = []
    for f in frames:
        out = eng.step(parse_frame(f))
        out["arbitration"] = eng.arbitration()
        outs.append(out)
    return outs


def rigid(frames: list[dict[str, Any]], theta: float, dx: float, dy: float) -> list[dict]:
    c, s = math.cos(theta), math.sin(theta)

    def pt(x: float, y: float) -> tuple[float, float]:
        return c * x - s * y + dx, s * x + c * y + dy

    out = copy.deepcopy(frames)
    for f in out:
        for ch in f["channels"].values():
            for thing in [ch["ego"], *ch["objects"]]:
                thing["x"], thing["y"] = pt(thing["x"], thing["y"])
                thing["yaw"] += theta
                vx, vy = thing.get("vx", 0.0), thing.get("vy", 0.0)
                thing["vx"], thing["vy"] = c * vx - s * vy, s * vx + c * vy
                for p in thing.get("prediction", []):
                    p[1], p[2] = pt(p[1], p[2])
            for p in ch["plan"]:
                p[1], p[2] = pt(p[1], p[2])
    return out


SIMILARITIES = ["els", "eos", "ocs", "ols", "oos", "oas", "ots", "ets", "crpps", "crpps_mean"]


@settings(max_examples=25, deadline=None)
@given(stream(identical=True))
def test_identical_channels_are_fully_similar(frames):
    for k, out in enumerate(run(frames)):
        for m in SIMILARITIES:
            if m in ("ets", "crpps", "crpps_mean") and not frames[k]["channels"]["a"]["plan"]:
                assert out[m] is None
            else:
                assert out[m] == pytest.approx(1.0, abs=1e-12), m
        if k >= 4:
            assert out["els_var"] == 0.0
        else:
            assert out["els_var"] is None


@settings(max_examples=25, deadline=None)
@given(stream())
def test_every_score_lies_in_unit_interval(frames):
    # scores, not the situation signals (metres, seconds, m/s) or ego_dist / ego_yaw_diff
    info = builtin_signals(["a", "b"])
    measures = {*SITUATION_METRICS, "ego_dist", "ego_yaw_diff", "lone_age", "plan_lat"}
    for out in run(frames):
        for name, v in out.items():
            if name in info and info[name].metric not in measures and v is not None:
                assert 0.0 <= v <= 1.0, name


@settings(max_examples=25, deadline=None)
@given(stream())
def test_pairwise_scores_symmetric_in_channel_order(frames):
    for ab, ba in zip(run(frames, ["a", "b"]), run(frames, ["b", "a"]), strict=True):
        for m in PAIR_METRICS:
            assert ab[pair_name(m, "a", "b")] == pytest.approx(ba[pair_name(m, "b", "a")])
            assert ab[m] == pytest.approx(ba[m])
        for name in ab:
            if name.startswith(("ss", "chpps", "ompv", "hcs", "ppcs", "crpps_mean")):
                assert ab[name] == pytest.approx(ba[name]), name


@settings(max_examples=25, deadline=None)
@given(stream(), heading, st.floats(-100, 100), st.floats(-100, 100))
def test_rigid_motion_of_the_world_changes_nothing(frames, theta, dx, dy):
    for before, after in zip(run(frames), run(rigid(frames, theta, dx, dy)), strict=True):
        assert before["arbitration"] == after["arbitration"]
        for name, v in before.items():
            if name == "arbitration":
                continue
            if v is None:
                assert after[name] is None, name
            else:
                assert after[name] == pytest.approx(v, abs=1e-9), name


def test_three_channels_worst_pair_and_crpps_mean():
    a = channel(ego(0, 0), plan=[[0, 0, 0], [0.1, 1, 0], [0.2, 2, 0]])
    b = channel(ego(3, 4), plan=[[0, 5, 5], [0.1, 6, 5], [0.2, 7, 5]])
    c = channel(ego(0, 1), plan=[[0, 0, 0], [0.1, 1, 1], [0.2, 2, 2]])
    out = MetricEngine(MetricParams(), ["a", "b", "c"]).step(frame(0.0, {"a": a, "b": b, "c": c}))
    # Frechet after translating onto the first plan's start, as paths over the length both
    # cover (2 m; the diagonal is 2.83 m): a-b 0; a-c: (1,0),(2,0) against the diagonal's
    # points 1 and 2 m along, (.707,.707),(1.414,1.414): the end points' distance
    # d = sqrt((2 - sqrt 2)^2 + 2) = 1.530734 -> crpps 1, 1/(1+d), 1/(1+d); worst 1/(1+d)
    d = ((2 - 2**0.5) ** 2 + 2) ** 0.5
    assert out["crpps__a__b"] == pytest.approx(1.0)
    assert out["crpps__a__c"] == pytest.approx(1 / (1 + d))
    assert out["crpps__b__c"] == pytest.approx(1 / (1 + d))
    assert out["crpps"] == pytest.approx(0.395142, abs=1e-6)
    # crpps_mean = inv(mean(0, d, d))
    assert out["crpps_mean"] == pytest.approx(1 / (1 + 2 * d / 3))
    # els: a-b 5 m -> 1/6, a-c 1 m -> 1/2, b-c sqrt(18) m -> 0.190744; worst = 1/6
    assert out["els__b__c"] == pytest.approx(1 / (1 + 18**0.5))
    assert out["els"] == pytest.approx(1 / 6)


def test_ompv_bridges_a_short_dropout():
    moving = [[0, 0, 0], [0.3, 3, 0]]
    other = channel(ego(), objects=[obj(9, 50, 50)])
    eng = MetricEngine(MetricParams(), AB)
    eng.step(
        frame(0.0, {"a": channel(ego(), objects=[obj(1, 0, 0, prediction=moving)]), "b": other})
    )
    out = eng.step(frame(0.1, {"b": other}))
    assert out["ompv__a"] is None and out["ompv__b"] == 1.0
    # 0.2 s after the last observation (< max_gap): predicted (2, 0), actual (2.5, 0): followed
    out = eng.step(frame(0.2, {"a": channel(ego(), objects=[obj(1, 2.5, 0)]), "b": other}))
    assert out["ompv__a"] == 1.0
