"""Safety score geometry: TTC, PET, the matrix and arbitration."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.frames import box_footprint, place
from casewatch.monitor.safety_score import (
    arbitrate,
    boxes_intersect,
    convex_intersects,
    prediction_horizon,
    safety_matrix,
    safety_score,
)
from tests.monitor.builders import channel, ego, frame, obj, straight_plan

PET_REF = 2.0
GRID = 0.1


def scene(objects, plan=None):
    plan = plan if plan is not None else straight_plan(0, 0, 10, 0, 31)  # 10 m/s for 3.0 s
    f = frame(0.0, {"a": channel(ego(0, 0, 0, 4, 2), plan=plan, objects=objects)})
    return f.channels["a"]


def test_driving_into_a_stopped_object_at_one_second_of_three():
    # Ego 4x2 box, front bumper at x + 2; stopped 4x2 object centred at 13.5 m, rear at 11.5.
    # At 0.9 s the front is at 11.0 (no contact), at 1.0 s at 12.0: first hit at 1.0 s.
    # ttc = 1.0, H = 3.0 -> ss = 1/3 (within the grid resolution 0.1 / 3)
    s = scene([obj(1, 13.5, 0, 0, 4, 2)])
    ss, ttc, pet = safety_score(s.plan, s.ego, s.objects, PET_REF)
    assert ttc == pytest.approx(1.0)
    assert ss == pytest.approx(1 / 3, abs=GRID / 3)
    assert pet == math.inf  # the colliding object is not a PET candidate


def test_rounding_jitter_of_a_standing_car_is_not_a_heading():
    # a 4.6 x 1.8 car standing 3.2 m to the left of a standing 4 x 2 ego (lateral gap 1.3 m),
    # its predicted points rounded to the centimetre: 4 mm from its reported centre, straight
    # towards the ego. Read as a heading, that jump turns the car across the ego (its half
    # length 2.3 m reaching to 0.9 m from the ego's centre line, inside its half width 1.0: a
    # collision now, ss = 0). Segments under 2 cm are standing still: the car keeps its yaw
    still = [[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]]
    car = obj(1, 0.0, 3.204, 0.0, 4.6, 1.8, prediction=[[0.5 * k, 0.0, 3.2] for k in range(1, 9)])
    s = scene([car], plan=still)
    assert safety_matrix(["a"], {"a": s}, PET_REF)[("a", "a")] == 1.0
    ss, ttc, _ = safety_score(s.plan, s.ego, s.objects, PET_REF)
    assert ss == 1.0 and ttc == math.inf


def test_passing_five_metres_beside_is_one():
    s = scene([obj(1, 13.5, 5.0, 0, 4, 2)])
    assert safety_score(s.plan, s.ego, s.objects, PET_REF) == (1.0, math.inf, math.inf)


def test_crossing_object_gives_post_encroachment_time():
    # Object 4x2 crosses northwards along x = 20.5 at 10 m/s, from y = -10.5.
    # Footprints meet when ego x in [17.5, 23.5] -> t_n in [1.75, 2.35] (grid 1.8 .. 2.3)
    # and object y in [-3, 3] -> t_m in [0.75, 1.35] (grid 0.8 .. 1.3): never at equal times.
    # PET on the grid = 1.8 - 1.3 = 0.5 -> ss = min(1, inf, 0.5 / 2) = 0.25
    pred = straight_plan(20.5, -10.5, 0, 10, 31)
    s = scene([obj(1, 20.5, -10.5, math.pi / 2, 4, 2, prediction=pred)])
    ss, ttc, pet = safety_score(s.plan, s.ego, s.objects, PET_REF)
    assert ttc == math.inf
    assert pet == pytest.approx(0.5)
    assert ss == pytest.approx(0.25)


def test_following_is_no_post_encroachment():
    # A 4x2 lead 14 m ahead (gap 10 m) at the ego's 10 m/s: the ego reaches every spot the
    # lead held 1.0 s later, a PET of 1.0 s (ss 0.5) if read as a crossing. Rear-end
    # encounters (headings under 30 degrees apart) are not PET's (conflict types): ss = 1.
    lead = obj(1, 14.0, 0, 0, 4, 2, prediction=straight_plan(14.0, 0, 10, 0, 31)[1:])
    assert safety_score(scene([lead]).plan, scene([lead]).ego, scene([lead]).objects, PET_REF) == (
        1.0,
        math.inf,
        math.inf,
    )
    # the same lead standing still: the ego drives into it, TTC as before (gap 10 m at 10 m/s)
    stopped = scene([obj(1, 14.0, 0, 0, 4, 2)])
    ss, ttc, _ = safety_score(stopped.plan, stopped.ego, stopped.objects, PET_REF)
    assert ttc == pytest.approx(1.0) and ss == pytest.approx(1 / 3)


def test_a_follower_running_into_the_ego_is_the_followers_contact():
    # The ego stands (its plan does not move); a 4x2 car 10 m behind (centre) drives at 10 m/s:
    # its front reaches the ego's rear at 0.6 s. A contact from behind, same heading: not the
    # plan's (ss 1), where it read ttc 0.6 / 3 = 0.2 before.
    standing = [[0.1 * n, 0.0, 0.0] for n in range(31)]
    car = obj(1, -10.0, 0, 0, 4, 2, prediction=straight_plan(-10.0, 0, 10, 0, 31)[1:])
    s = scene([car], plan=standing)
    assert safety_score(s.plan, s.ego, s.objects, PET_REF) == (1.0, math.inf, math.inf)
    # the same car coming from the side (heading +y, 10 m to the right) does count: at
    # 0.7 s its front (y = -10 + 7 + 2) reaches the ego's right side (y = -1)
    side = obj(1, 0.0, -10.0, math.pi / 2, 4, 2, prediction=straight_plan(0, -10.0, 0, 10, 31)[1:])
    s = scene([side], plan=standing)
    ss, ttc, _ = safety_score(s.plan, s.ego, s.objects, PET_REF)
    assert ttc == pytest.approx(0.7) and ss == pytest.approx(0.7 / 3)


def test_first_step_collision_is_zero_and_short_plans():
    s = scene([obj(1, 3.0, 0, 0, 4, 2)])  # already overlapping at dt = 0
    assert safety_score(s.plan, s.ego, s.objects, PET_REF)[0] == 0.0
    one = scene([obj(1, 3.0, 0)], plan=[[0.0, 0.0, 0.0]])
    assert safety_score(one.plan, one.ego, one.objects, PET_REF)[0] == 1.0  # < 2 points
    empty = scene([obj(1, 3.0, 0)], plan=[])
    assert safety_score(empty.plan, empty.ego, empty.objects, PET_REF)[0] is None
    nobody = scene([])
    assert safety_score(nobody.plan, nobody.ego, nobody.objects, PET_REF)[0] == 1.0


def test_non_convex_polygon_footprint_uses_shapely():
    # A U-shaped object open towards the ego, 3 m wide inside: the 2 m-wide ego drives into
    # the gap. Its arms span x in [12, 16] at |y| in [1.5, 2.5]; back wall x in [16, 17].
    # Ego (x in [x_e - 2, x_e + 2], |y| <= 1) first touches the back wall when x_e + 2 >= 16,
    # x_e = 14 at t = 1.4 s -> ss = 1.4 / 3; the convex hull would give an earlier hit (1.0 s).
    u = [[-2, 2.5], [-2, 1.5], [2, 1.5], [2, -1.5], [-2, -1.5], [-2, -2.5], [3, -2.5], [3, 2.5]]
    s = scene([{"id": 1, "x": 14.0, "y": 0.0, "yaw": 0.0, "polygon": u}])
    assert not s.objects.convex[0]
    ss, ttc, _ = safety_score(s.plan, s.ego, s.objects, PET_REF)
    assert ttc == pytest.approx(1.4)
    assert ss == pytest.approx(1.4 / 3)


def test_matrix_dropout_and_arbitration_ties():
    plan = straight_plan(0, 0, 10, 0, 31)
    f = frame(
        0.0,
        {
            "a": channel(ego(), plan=plan, objects=[obj(1, 13.5, 0)]),
            "b": channel(ego(), plan=plan, objects=[]),
        },
    )
    m = safety_matrix(["a", "b"], f.channels, PET_REF)
    # a's objects block both plans (same plan): ss_aa = ss_ba = 1/3; b sees nothing: 1.0
    assert m[("a", "a")] == pytest.approx(1 / 3) and m[("b", "a")] == pytest.approx(1 / 3)
    assert m[("a", "b")] == 1.0 and m[("b", "b")] == 1.0
    # both plans score 1/3 in the worst world: tie -> first declared, or keep the previous
    assert arbitrate(["a", "b"], m, None) == "a"
    assert arbitrate(["a", "b"], m, "b") == "b"
    g = frame(0.0, {"a": channel(ego(), plan=plan, objects=[obj(1, 13.5, 0)])})
    m = safety_matrix(["a", "b"], g.channels, PET_REF)
    assert m[("a", "b")] is None and m[("b", "b")] is None and m[("b", "a")] is None
    assert arbitrate(["a", "b"], m, "b") == "a"  # b has no value: not a candidate
    assert arbitrate(["a", "b"], dict.fromkeys(m), "a") is None


finite = st.floats(-6, 6, allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(
    finite,
    finite,
    st.floats(-4, 4),
    st.floats(0.5, 5),
    st.floats(0.5, 3),
    st.floats(-4, 4),
    st.floats(0.5, 5),
    st.floats(0.5, 3),
)
def test_box_sat_agrees_with_shapely(x, y, ha, la, wa, hb, lb, wb):
    a = place(box_footprint(la, wa)[None], np.zeros((1, 2)), np.array([ha]))
    b = place(box_footprint(lb, wb)[None], np.array([[x, y]]), np.array([hb]))
    truth = bool(shapely.intersects(shapely.polygons(a[0]), shapely.polygons(b[0])))
    dist = float(shapely.distance(shapely.polygons(a[0]), shapely.polygons(b[0])))
    if dist > 1e-9 or truth:  # skip knife-edge touching configurations only
        box = boxes_intersect(
            np.array([x]),
            np.array([y]),
            np.cos([ha]),
            np.sin([ha]),
            la / 2,
            wa / 2,
            np.cos([hb]),
            np.sin([hb]),
            np.array([lb / 2]),
            np.array([wb / 2]),
        )[0]
        assert bool(box) == truth
        assert bool(convex_intersects(a, b)[0]) == truth


# -- the prefilters never change the result: compare with a brute-force shapely reference ----


def brute_force(plan, ego_state, objects, pet_ref):
    """Every (n, m) footprint pair tested with shapely, poses from the same rules."""
    from casewatch.monitor.prediction import interpolate_tracks
    from casewatch.monitor.safety_score import _directions

    times = plan[:, 0]
    horizon = times[-1]
    centres = plan[None, :, 1:3]
    ec, es = _directions(centres, np.array([ego_state.yaw]))
    ego_polys = [
        shapely.polygons(place(ego_state.footprint, centres[0, n], np.arctan2(es[0, n], ec[0, n])))
        for n in range(len(times))
    ]
    oc = interpolate_tracks(objects.pos, objects.pred, objects.pred_len, times)
    cos, sin = _directions(oc, objects.yaw)
    ttc, pet = math.inf, math.inf
    for k in range(len(objects)):
        polys = [
            shapely.polygons(
                place(objects.footprints[k], oc[k, m], np.arctan2(sin[k, m], cos[k, m]))
            )
            for m in range(len(times))
        ]

        def rear_end(n, m, k=k):  # conflict types: headings under 30 degrees apart
            return ec[0, n] * cos[k, m] + es[0, n] * sin[k, m] > math.cos(math.radians(30))

        hits = [
            (n, m)
            for n in range(len(times))
            for m in range(len(times))
            if shapely.intersects(ego_polys[n], polys[m])
        ]
        same = [n for n, m in hits if n == m]
        if same:
            first = min(same)
            ahead = np.dot(oc[k, first] - centres[0, first], [ec[0, first], es[0, first]])
            if not (rear_end(first, first) and ahead < -1e-9):  # else the follower's contact
                ttc = min(ttc, times[first])
        else:
            crossing = [abs(times[n] - times[m]) for n, m in hits if not rear_end(n, m)]
            pet = min([pet, *crossing])
    return min(1.0, ttc / horizon, pet / pet_ref), ttc


@st.composite
def random_scene(draw):
    n = draw(st.integers(2, 14))
    vx, vy = draw(st.floats(-12, 12)), draw(st.floats(-12, 12))
    turn = draw(st.floats(-0.5, 0.5))
    pts, x, y = [], 0.0, 0.0
    for i in range(n):
        pts.append([round(0.1 * i, 1), x, y])
        c, s = math.cos(turn * 0.1), math.sin(turn * 0.1)
        vx, vy = c * vx - s * vy, s * vx + c * vy
        x, y = x + 0.1 * vx, y + 0.1 * vy
    objects = []
    for k in range(draw(st.integers(1, 5))):
        ox, oy = draw(st.floats(-15, 15)), draw(st.floats(-15, 15))
        o = {"id": k, "x": ox, "y": oy, "yaw": draw(st.floats(-3.2, 3.2))}
        shape = draw(st.sampled_from(["box", "convex", "u"]))
        if shape == "box":
            o["length"], o["width"] = draw(st.floats(0.5, 8)), draw(st.floats(0.5, 3))
        elif shape == "convex":
            o["polygon"] = [[1.5, 0.0], [0.0, 1.0], [-1.5, 0.0], [0.0, -1.0]]
        else:
            o["polygon"] = [
                [-2, 2.5],
                [-2, 1.5],
                [2, 1.5],
                [2, -1.5],
                [-2, -1.5],
                [-2, -2.5],
                [3, -2.5],
                [3, 2.5],
            ]
        m = draw(st.integers(0, 12))
        if m:
            pvx, pvy = draw(st.floats(-12, 12)), draw(st.floats(-12, 12))
            start = draw(st.sampled_from([0.0, 0.1, 0.3]))
            o["prediction"] = [
                [
                    round(start + 0.1 * i, 1),
                    ox + pvx * (start + 0.1 * i),
                    oy + pvy * (start + 0.1 * i),
                ]
                for i in range(m)
            ]
        objects.append(o)
    return pts, objects


@settings(max_examples=60, deadline=None)
@given(random_scene())
def test_fast_search_matches_brute_force(scene_data):
    plan, objects = scene_data
    s = scene(objects, plan=plan)
    ss, ttc, _ = safety_score(s.plan, s.ego, s.objects, PET_REF)
    ref_ss, ref_ttc = brute_force(s.plan, s.ego, s.objects, PET_REF)
    assert ttc == ref_ttc
    assert ss == pytest.approx(ref_ss, abs=1e-12)


@settings(max_examples=40, deadline=None)
@given(random_scene(), random_scene(), st.integers(2, 14))
def test_prefix_grids_in_one_pass_match_separate_plans(first, second, cut):
    """safety_matrix scores plans whose grids are prefixes of the longest one (stacks planning
    over different horizons) in one pass on the long grid; every ss_ij must equal the
    single-plan score, whose search is checked against brute force above. The short plan's
    last point is where the object headings of the two grids differ."""
    plan_a, objects_a = first
    plan_b = [list(p) for p in second[0][: max(2, min(cut, len(second[0])))]]
    # b plans on a's grid (a prefix of it), from its own path
    n_b = min(len(plan_b), len(plan_a))
    plan_b = [[plan_a[n][0], plan_b[n][1], plan_b[n][2]] for n in range(n_b)]
    f = frame(
        0.0,
        {
            "a": channel(ego(0, 0, 0, 4, 2), plan=plan_a, objects=objects_a),
            "b": channel(ego(0, 0, 0.3, 5, 2), plan=plan_b, objects=second[1]),
        },
    )
    matrix = safety_matrix(["a", "b"], f.channels, PET_REF)
    for i in ("a", "b"):
        for j in ("a", "b"):
            si, sj = f.channels[i], f.channels[j]
            # over the horizon both cover: plan i cut to j's longest prediction
            plan = si.plan[si.plan[:, 0] <= prediction_horizon(sj.objects) + 1e-9]
            single = safety_score(plan, si.ego, sj.objects, PET_REF)[0] if len(plan) >= 2 else 1.0
            assert matrix[(i, j)] == pytest.approx(single, abs=1e-12), (i, j)


def _with_long_plan(plan_a, objects_a):
    """Channel a with its plan and objects; channel b plans far away over 1.0 s on the same
    0.1 s grid (a's grid is a prefix of b's) and sees nothing, so (a, a) shares the long-grid
    pass with b."""
    far = straight_plan(0, 100, 10, 0, 11)
    return frame(
        0.0,
        {
            "a": channel(ego(0, 0, 0, 2, 2), plan=plan_a, objects=objects_a),
            "b": channel(ego(0, 100, 0, 4, 2), plan=far),
        },
    ).channels


def test_short_plan_ignores_the_long_grid_beyond_its_horizon():
    # Plan a: 0.2 s at 20 m/s, ego 2 x 2 at (0, 0), (2, 0), (4, 0). The object (4 x 1, moving
    # down x = 0 at 20 m/s, y = 4, 2, 0 at t = 0, 0.1, 0.2) never meets the ego at equal times
    # (t = 0.1: object x in [-0.5, 0.5], ego x in [1, 3]); its t = 0.1 pose (y in [0, 4])
    # overlaps the ego's t = 0 pose (y in [-1, 1]): pet = 0.1, ss_aa = 0.1 / 2 = 0.05.
    # Afterwards it drives to (4, 0), the end of plan a, and stops there (t = 0.4): on the
    # long grid of the shared pass that is an equal-time hit with a padded ego pose (t = 0.4,
    # which would give ttc = 0.4 >= H and ss = 1) and an overlap at dt = 0 (ss = 0); both lie
    # beyond plan a's horizon and must not count.
    plan = straight_plan(0, 0, 20, 0, 3)
    path = [[0.0, 0.0, 4.0], [0.1, 0.0, 2.0], [0.2, 0.0, 0.0], [0.3, 2.0, 0.0], [0.4, 4.0, 0.0]]
    o = obj(1, 0, 4, -math.pi / 2, 4, 1, prediction=path)
    channels = _with_long_plan(plan, [o])
    matrix = safety_matrix(["a", "b"], channels, PET_REF)
    assert matrix[("a", "a")] == pytest.approx(0.05, abs=1e-12)
    assert matrix[("b", "b")] == 1.0 and matrix[("a", "b")] == 1.0
    assert matrix[("b", "a")] == 1.0  # b drives at y = 100


def test_object_heading_at_the_end_of_a_short_grid():
    # Plan a (H = 0.2 s): ego 2 x 2 at (3, -3), (3, -1.5), (3, 0). The object, a thin 8 x 0.5
    # box, moves along +x to (0, 0) at t = 0.2 s (heading 0), then turns up +y.
    # On a's grid its last pose keeps the last segment's heading 0: it spans x in [-4, 4] at
    # t = 0.2 and meets the ego (x in [2, 4]) at equal times, so ttc = 0.2 = H and ss_aa = 1.
    # With the long grid's heading there (pi/2, towards the next point) it would miss at
    # t = 0.2 and meet the ego's t = 0.2 pose with its t = 0.1 pose (x up to -1.5 + 4 = 2.5):
    # pet = 0.1, ss = 0.1 / 2 = 0.05.
    plan = [[0.0, 3.0, -3.0], [0.1, 3.0, -1.5], [0.2, 3.0, 0.0]]
    path = [[0.0, -3.0, 0.0], [0.1, -1.5, 0.0], [0.2, 0.0, 0.0]]
    path += [[round(0.1 * n, 1), 0.0, 1.5 * (n - 2)] for n in range(3, 11)]
    o = obj(1, -3, 0, 0.0, 8, 0.5, prediction=path)
    assert safety_score(*_single(plan, o), PET_REF)[0] == 1.0
    matrix = safety_matrix(["a", "b"], _with_long_plan(plan, [o]), PET_REF)
    assert matrix[("a", "a")] == 1.0


def _single(plan, o):
    s = frame(0.0, {"a": channel(ego(3, -3, math.pi / 2, 2, 2), plan=plan, objects=[o])})
    st_ = s.channels["a"]
    return st_.plan, st_.ego, st_.objects
