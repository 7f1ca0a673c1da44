"""Unpaired objects: their ages across ticks, lone_age and the object means in the engine,
and plan_lat, hand-computed (spi-reference "Unpaired objects", "plan_lat")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.lone import LoneAges, benefit_of_doubt
from casewatch.monitor.similarity import plan_lateral
from casewatch.safety_case.model import MetricParams
from tests.monitor.builders import channel, ego, frame, obj

AB = ["a", "b"]


def _lone(ages: LoneAges, t: float, pos: list, vel: list, lone: list | None = None):
    flags = [True] * len(pos) if lone is None else lone
    return ages.update(
        t,
        np.array(pos, float).reshape(-1, 2),
        np.array(vel, float).reshape(-1, 2),
        np.array(flags, bool),
    ).tolist()


def test_ages_follow_objects_by_position_and_velocity():
    ages = LoneAges(gate=3.0, max_gap=0.5)
    # t = 0: one unpaired object at (10, 0) driving +x at 10 m/s: age 0
    assert _lone(ages, 0.0, [[10, 0]], [[10, 0]]) == [0.0]
    # t = 0.1: it is now at (11.2, 0.1) (predicted 11.0); a second one appears far away
    assert _lone(ages, 0.1, [[50, 5], [11.2, 0.1]], [[0, 0], [10, 0]]) == pytest.approx([0, 0.1])
    # t = 0.3 (a 0.2 s gap, within max_gap): both continue
    assert _lone(ages, 0.3, [[13.1, 0], [50, 5]], [[10, 0], [0, 0]]) == pytest.approx([0.3, 0.2])
    # t = 0.9: 0.6 s later, beyond max_gap: every age starts afresh
    assert _lone(ages, 0.9, [[19, 0]], [[10, 0]]) == [0.0]


def test_a_missed_detection_is_bridged_a_pairing_is_not():
    ages = LoneAges(gate=3.0, max_gap=0.5)
    _lone(ages, 0.0, [[0, 0]], [[0, 0]])
    _lone(ages, 0.1, [[0.5, 0]], [[0, 0]])
    # t = 0.2-0.3: not reported at all (a missed detection); t = 0.4 unpaired again: age 0.4
    _lone(ages, 0.2, [], [])
    _lone(ages, 0.3, [], [])
    assert _lone(ages, 0.4, [[0.5, 0]], [[0, 0]]) == pytest.approx([0.4])
    # t = 0.5: reported and paired: its age ends; unpaired at t = 0.6, it is new
    assert _lone(ages, 0.5, [[0.5, 0]], [[0, 0]], [False]) == []
    assert _lone(ages, 0.6, [[0.5, 0]], [[0, 0]]) == [0.0]
    # missing for longer than max_gap: new as well
    _lone(ages, 0.7, [], [])
    assert _lone(ages, 1.3, [[0.5, 0]], [[0, 0]]) == [0.0]


def test_benefit_of_doubt_falls_linearly_to_zero():
    keep = benefit_of_doubt(np.array([0.0, 0.5, 1.0, 2.0, 3.0]), 2.0)
    assert keep.tolist() == [1.0, 0.75, 0.5, 0.0, 0.0]


def _drop_stream(seconds: float, others: int) -> list[dict[str, float | None]]:
    """Channel b misses car 'x' (10 m ahead, standing) for `seconds` from t = 1 s; `others`
    more cars both channels see."""
    eng = MetricEngine(MetricParams(), AB)
    outs = []
    for k in range(round((1.0 + seconds + 1.0) / 0.1)):
        t = round(0.1 * k, 3)
        shared = [obj(f"c{i}", 20.0 + 10 * i, 4.0) for i in range(others)]
        a = channel(ego(), objects=[obj("x", 10.0, 0.0), *shared])
        missing = 1.0 - 1e-9 <= t < 1.0 + seconds - 1e-9
        b = channel(ego(), objects=shared if missing else [obj("x", 10.0, 0.0), *shared])
        outs.append(eng.step(frame(t, {"a": a, "b": b})))
    return outs


def test_a_dropped_car_ages_and_drags_the_object_means_down():
    outs = _drop_stream(3.0, others=0)
    # before the drop: one pair at 0 m
    assert outs[5]["lone_age"] == 0.0 and outs[5]["ols"] == 1.0
    # t = 1.0: first tick unpaired: age 0, neutral (no pair: 1.0)
    assert outs[10]["lone_age"] == 0.0 and outs[10]["ols"] == pytest.approx(1.0)
    # t = 2.0: age 1.0 s, keep 0.5 -> ols 0.5 (the only object)
    assert outs[20]["lone_age"] == pytest.approx(1.0)
    assert outs[20]["ols"] == pytest.approx(0.5)
    # t = 3.5: age 2.5 s beyond the 2 s horizon: ols 0
    assert outs[35]["lone_age"] == pytest.approx(2.5)
    assert outs[35]["ols"] == 0.0 and outs[35]["ots"] == 0.0
    # back again at t = 4.0: paired, age 0
    assert outs[40]["lone_age"] == 0.0 and outs[40]["ols"] == 1.0


def test_lone_age_sees_the_drop_whatever_else_is_in_view():
    outs = _drop_stream(3.0, others=3)
    # three paired cars at 0 m and the lone one at age 2.5: ols = (3 + 0) / 4
    assert outs[35]["ols"] == pytest.approx(0.75)
    assert outs[35]["lone_age"] == pytest.approx(2.5)


def test_a_short_ghost_stays_young():
    outs = _drop_stream(0.3, others=0)
    assert max(o["lone_age"] for o in outs) == pytest.approx(0.2)
    assert min(o["ols"] for o in outs) == pytest.approx(0.9)


def test_lone_age_has_no_value_while_a_channel_is_absent():
    eng = MetricEngine(MetricParams(), AB)
    a = channel(ego(), objects=[obj("x", 10.0, 0.0)])
    eng.step(frame(0.0, {"a": a, "b": channel(ego())}))
    out = eng.step(frame(0.1, {"a": a}))
    assert out["lone_age"] is None
    # the channel is back: the lone object starts afresh
    out = eng.step(frame(0.2, {"a": a, "b": channel(ego())}))
    assert out["lone_age"] == 0.0


def _straight(offset: float, n: int = 31, speed: float = 10.0) -> np.ndarray:
    dt = 0.1 * np.arange(n)
    return np.column_stack([dt, speed * dt, np.full(n, offset)])


def test_plan_lat_reads_a_sideways_shift_not_a_speed_difference():
    a = _straight(0.0)
    # same path 1.5 m to the left: 1.5 whatever the speed
    assert plan_lateral(
        a, _straight(1.5, speed=12.0), (0.0, 0.0), (0.0, 0.0), 2.0
    ) == pytest.approx(1.5)
    # the same shift when channel b believes the ego is 1.5 m left too: nothing planned apart
    assert plan_lateral(a, _straight(1.5), (0.0, -1.5), (0.0, 0.0), 2.0) == pytest.approx(0.0)
    # the order of the channels does not matter
    assert plan_lateral(_straight(1.5), a, (0.0, 0.0), (0.0, 0.0), 2.0) == pytest.approx(1.5)


def test_plan_lat_compares_the_first_seconds_only():
    a = _straight(0.0, n=51)
    b = a.copy()
    # b diverges linearly from 0 at 2 s to 2 m at 5 s: unseen in the first 2 s
    b[:, 2] = np.clip((b[:, 0] - 2.0) / 3.0, 0.0, None) * 2.0
    assert plan_lateral(a, b, (0.0, 0.0), (0.0, 0.0), 2.0) == pytest.approx(0.0, abs=1e-12)
    # over 3.5 s: 1.5 / 3 * 2 = 1.0 m apart at dt = 3.5, read across the mean direction of
    # the two plans there (a straight one and one climbing 2 m in 30 m): 1.0 cos(atan(1/15) / 2)
    want = math.cos(math.atan(2.0 / 30.0) / 2.0)
    assert plan_lateral(a, b, (0.0, 0.0), (0.0, 0.0), 3.5) == pytest.approx(want)


def test_plan_lat_of_standing_plans_reads_across_the_ego_heading():
    a = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    b = np.array([[0.0, 0.3, 0.4], [1.0, 0.3, 0.4]])
    # both egos head +y: across is x: 0.3
    assert plan_lateral(a, b, (0.0, 0.0), (math.pi / 2, math.pi / 2), 2.0) == pytest.approx(0.3)
    assert plan_lateral(a, np.zeros((0, 3)), (0.0, 0.0), (0.0, 0.0), 2.0) is None


def test_standing_pairs_leave_ots():
    from casewatch.monitor.similarity import object_similarities
    from tests.monitor.test_similarity import GATE, K, two_channel_frame

    f = two_channel_frame()
    a, b = f.channels["a"].objects, f.channels["b"].objects
    # o1-p1 both predict 1 m of motion (ots 1); o2-p3 have no prediction (no motion: ots 1);
    # p2 is unpaired (keep 0). Every object counted: (1 + 1 + 0) / 3
    assert object_similarities(a, b, GATE, K)["ots"] == pytest.approx(2 / 3)
    # standing below 0.5 m: o2-p3 leaves ots (not ols): (1 + 0) / 2
    out = object_similarities(a, b, GATE, K, standing=0.5)
    assert out["ots"] == pytest.approx(0.5)
    assert out["ols"] == pytest.approx(5 / 18)


def test_standing_objects_leave_ompv():
    from casewatch.monitor.prediction import ompv

    prev = frame(
        0.0,
        {
            "a": channel(
                ego(),
                objects=[obj("m", 0.0, 0.0, prediction=[[0.5, 5.0, 0.0]]), obj("s", 20.0, 0.0)],
            )
        },
    )
    # the moving car went the other way (a reversed prediction); the standing one stayed
    cur = frame(0.5, {"a": channel(ego(), objects=[obj("m", -5.0, 0.0), obj("s", 20.0, 0.0)])})
    p, c = prev.channels["a"].objects, cur.channels["a"].objects
    assert ompv(p, 0.5, c, 1.0, 3.0) == pytest.approx(0.5)
    assert ompv(p, 0.5, c, 1.0, 3.0, standing=0.5) == 0.0
    # nothing moves: nothing to judge
    still = frame(0.5, {"a": channel(ego(), objects=[obj("s", 20.0, 0.0)])}).channels["a"].objects
    assert ompv(still, 0.5, still, 1.0, 3.0, standing=0.5) == 1.0


def test_standing_ompv_when_everything_is_gone():
    from casewatch.monitor.prediction import ompv

    prev = frame(
        0.0,
        {
            "a": channel(
                ego(),
                objects=[obj("m", 0.0, 0.0, prediction=[[0.5, 5.0, 0.0]]), obj("s", 20.0, 0.0)],
            )
        },
    )
    none = frame(0.5, {"a": channel(ego())}).channels["a"].objects
    # the moving car is gone: existence (lone_age's), not prediction; nothing left to check
    assert ompv(prev.channels["a"].objects, 0.5, none, 1.0, 3.0, standing=0.5) == 1.0
    # the study's reading counts it (and the standing car) as misses
    assert ompv(prev.channels["a"].objects, 0.5, none, 1.0, 3.0) == 0.0
    # a moving car new since: not a miss either
    new = (
        frame(
            0.5, {"a": channel(ego(), objects=[obj("n", 9.0, 9.0, prediction=[[0.5, 14.0, 9.0]])])}
        )
        .channels["a"]
        .objects
    )
    assert ompv(prev.channels["a"].objects, 0.5, new, 1.0, 3.0, standing=0.5) == 1.0


def test_ols_tolerance_grows_with_range():
    from casewatch.monitor.similarity import compare_objects

    a = frame(0.0, {"a": channel(ego(), objects=[obj("1", 50.0, 0.0)])}).channels["a"].objects
    b = frame(0.0, {"b": channel(ego(), objects=[obj("2", 51.0, 0.0)])}).channels["b"].objects
    ranges = (np.array([50.0]), np.array([51.0]))
    # 1 m apart at a mean range of 50.5 m: d = 1 / (1 + 50.5 / 50) -> ols = 1 / (1 + d)
    cmp = compare_objects(a, b, 3.0, 0.95, None, None, 0.0, *ranges, 50.0, 0.0)
    want = 1.0 / (1.0 + 1.0 / (1.0 + 50.5 / 50.0))
    assert cmp.scores(np.zeros(0), np.zeros(0))["ols"] == pytest.approx(want)
    # off (0): the study's absolute metres
    cmp = compare_objects(a, b, 3.0, 0.95, None, None, 0.0, *ranges, 0.0, 0.0)
    assert cmp.scores(np.zeros(0), np.zeros(0))["ols"] == pytest.approx(0.5)


def test_ots_tolerance_grows_with_look_ahead():
    from casewatch.monitor.similarity import compare_objects

    pa = [[1.0, 1.0, 0.0], [2.0, 2.0, 0.0]]
    pb = [[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]  # 1 m apart at 1 s, 2 m at 2 s
    a = frame(0.0, {"a": channel(ego(), objects=[obj("1", 0, 0, prediction=pa)])})
    b = frame(0.0, {"b": channel(ego(), objects=[obj("2", 0, 0, prediction=pb)])})
    oa, ob = a.channels["a"].objects, b.channels["b"].objects
    w = 0.95
    # time_scale 1 s: both points read 1 / (1 + 1) and 2 / (1 + 2): inv 1/(1+0.5), 1/(1+2/3)
    cmp = compare_objects(oa, ob, 3.0, w, None, None, 0.0, None, None, 0.0, 1.0)
    want = (1 / 1.5 + w * (1 / (1 + 2 / 3))) / (1 + w)
    assert cmp.scores(np.zeros(0), np.zeros(0))["ots"] == pytest.approx(want)
    cmp = compare_objects(oa, ob, 3.0, w, None, None, 0.0, None, None, 0.0, 0.0)
    assert cmp.scores(np.zeros(0), np.zeros(0))["ots"] == pytest.approx((0.5 + w / 3) / (1 + w))


def test_ets_relative_takes_the_egos_offset_out():
    from casewatch.monitor.similarity import ets

    a = _straight(0.0)
    b = _straight(1.0)  # channel b's ego, and so its plan, 1 m to the left
    assert ets(a, b, 0.95) == pytest.approx(0.5)
    assert ets(a, b, 0.95, shift=(0.0, -1.0)) == pytest.approx(1.0)


def test_a_standing_plan_drives_into_nothing():
    from casewatch.monitor.safety_score import safety_matrix

    # a standing plan whose footprint overlaps a standing car 4 m ahead (both 4.5 m long)
    plan = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]
    car = obj("c", 4.0, 0.0, 0.0, 4.5, 1.8)
    f = frame(0.0, {"a": channel(ego(0, 0, 0, 4.5, 1.8), plan=plan, objects=[car])})
    assert safety_matrix(["a"], f.channels, 2.0)[("a", "a")] == 0.0
    assert safety_matrix(["a"], f.channels, 2.0, standing_is_clear=True)[("a", "a")] == 1.0
