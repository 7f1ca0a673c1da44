"""The compiled box-footprint path of the safety score against its oracles: the numpy path
(`score_grid_numpy`, kept for polygon footprints) on random box scenes, and brute-force shapely
on single plans."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.safety_kernel import score_boxes
from casewatch.monitor.safety_score import (
    safety_matrix,
    safety_score,
    score_grid,
    score_grid_numpy,
)
from tests.monitor.builders import channel, ego, frame, obj, straight_plan
from tests.monitor.test_safety_score import brute_force, scene

PET_REF = 2.0


@st.composite
def path(draw, n: int, times: list[float], stationary: bool) -> list[list[float]]:
    """n points [dt, x, y] on `times`: a turning constant-speed path, or standing still."""
    x, y = draw(st.floats(-4, 4)), draw(st.floats(-4, 4))
    if stationary:
        return [[times[i], x, y] for i in range(n)]
    speed = draw(st.floats(0, 25))
    heading = draw(st.floats(-3.2, 3.2))
    turn = draw(st.floats(-1.0, 1.0))
    pts = []
    for i in range(n):
        pts.append([times[i], x, y])
        if i + 1 < n:
            step = times[i + 1] - times[i]
            heading += turn * step
            x += speed * step * math.cos(heading)
            y += speed * step * math.sin(heading)
    return pts


@st.composite
def box_world(draw, times: list[float], plan: list[list[float]]) -> list[dict]:
    """1..3 box objects near the egos' start: standing, or predicted (on a grid that starts at
    0 or later, of any length, sometimes standing still, sometimes with repeated points), or
    crossing the first plan at another time, or driving it some steps earlier or later with a
    lateral offset (PET cases)."""
    objects = []
    for k in range(draw(st.integers(1, 3))):
        if len(plan) > 2 and draw(st.booleans()):  # crossing the plan at another time
            a = draw(st.integers(0, len(plan) - 1))
            late = draw(st.floats(-1.5, 1.5))
            speed = draw(st.floats(3, 20))
            head = draw(st.floats(-3.2, 3.2))
            c, s = speed * math.cos(head), speed * math.sin(head)
            pts = [
                [
                    t,
                    plan[a][1] + c * (t - plan[a][0] - late),
                    plan[a][2] + s * (t - plan[a][0] - late),
                ]
                for t in times
            ]
            objects.append(
                obj(
                    k,
                    *pts[0][1:],
                    head,
                    draw(st.floats(0.5, 5)),
                    draw(st.floats(0.5, 2)),
                    prediction=pts,
                )
            )
            continue
        if len(plan) > 2 and draw(st.booleans()):
            shift = draw(st.integers(1, len(plan) - 1))
            dx, dy = draw(st.floats(-3, 3)), draw(st.floats(-3, 3))
            moved = [[p[1] + dx, p[2] + dy] for p in plan]
            if draw(st.booleans()):  # ahead: where the ego will be `shift` steps later
                pts = [[plan[i][0], *moved[i + shift]] for i in range(len(plan) - shift)]
                start = pts[0][1:]
            else:  # behind: where the ego was, coming from as far behind
                pts = [[plan[i + shift][0], *moved[i]] for i in range(len(plan) - shift)]
                start = [2 * moved[0][0] - moved[shift][0], 2 * moved[0][1] - moved[shift][1]]
            objects.append(
                obj(
                    k,
                    *start,
                    draw(st.floats(-3.2, 3.2)),
                    draw(st.floats(0.5, 5)),
                    draw(st.floats(0.5, 2)),
                    prediction=pts,
                )
            )
            continue
        ox, oy = draw(st.floats(-25, 25)), draw(st.floats(-25, 25))
        o = obj(
            k, ox, oy, draw(st.floats(-3.2, 3.2)), draw(st.floats(0.5, 8)), draw(st.floats(0.5, 3))
        )
        m = draw(st.integers(0, 12))
        if m:
            start = draw(st.sampled_from([0.0, 0.1, 0.25, 0.4]))
            step = draw(st.sampled_from([0.1, 0.2]))
            grid = [round(start + step * i, 2) for i in range(m)]
            pts = draw(path(m, grid, draw(st.booleans()) and draw(st.booleans())))
            # the prediction starts where the object is plus the path's own offset
            o["prediction"] = [[t, ox + px, oy + py] for t, px, py in pts]
            if m > 2 and draw(st.booleans()):  # a zero-length segment inside
                o["prediction"][1][1:] = o["prediction"][0][1:]
        objects.append(o)
    return objects


@st.composite
def box_scene(draw) -> tuple[list[np.ndarray], list, list]:
    """Plans on prefixes of one grid (uniform or not), their box egos, box world models."""
    n_long = draw(st.integers(2, 20))
    steps = draw(
        st.lists(st.sampled_from([0.1, 0.2, 0.05]), min_size=n_long - 1, max_size=n_long - 1)
    )
    times = [0.0]
    for s in steps:
        times.append(round(times[-1] + s, 2))
    n_plans = draw(st.integers(1, 3))
    lengths = [n_long] + [draw(st.integers(2, n_long)) for _ in range(n_plans - 1)]
    n_worlds = draw(st.integers(1, 3))
    chans = {}
    first = None
    for c in range(max(n_plans, n_worlds)):
        plan = (
            draw(path(lengths[c], times, draw(st.booleans()) and draw(st.booleans())))
            if c < n_plans
            else straight_plan(0, 0, 1, 0, 2)
        )
        first = first or plan
        e = ego(0, 0, draw(st.floats(-3.2, 3.2)), draw(st.floats(1, 6)), draw(st.floats(1, 3)))
        objects = draw(box_world(times, first)) if c < n_worlds else []
        chans[f"c{c}"] = channel(e, plan=plan, objects=objects)
    f = frame(0.0, chans)
    states = list(f.channels.values())
    plans = [s.plan for s in states[:n_plans]]
    egos = [s.ego for s in states[:n_plans]]
    worlds = [s.objects for s in states[:n_worlds]]
    return plans, egos, worlds


@settings(max_examples=300, deadline=None)
@given(box_scene(), st.sampled_from([2.0, 0.5]))
def test_kernel_equals_numpy_path(data, pet_ref):
    plans, egos, worlds = data
    got = score_boxes(plans, egos, worlds, pet_ref)
    assert got is not None  # all boxes: the kernel scores it
    want = score_grid_numpy(plans, egos, worlds, pet_ref)
    for name, g, w in zip(("ss", "ttc", "pet"), got, want, strict=True):
        assert np.array_equal(g, w), (name, g, w)
    # the public entry takes the kernel here and returns the same
    for g, w in zip(score_grid(plans, egos, worlds, pet_ref), want, strict=True):
        assert np.array_equal(g, w)


@st.composite
def box_single(draw):
    """One plan (moving or standing) and box objects for the brute-force comparison."""
    n = draw(st.integers(2, 14))
    times = [round(0.1 * i, 1) for i in range(n)]
    plan = draw(path(n, times, draw(st.booleans()) and draw(st.booleans())))
    return plan, draw(box_world(times, plan))


@settings(max_examples=100, deadline=None)
@given(box_single())
def test_kernel_matches_brute_force(data):
    plan, objects = data
    s = scene(objects, plan=plan)
    assert score_boxes([s.plan], [s.ego], [s.objects], PET_REF) is not None  # kernel path
    ss, ttc, _ = safety_score(s.plan, s.ego, s.objects, PET_REF)
    ref_ss, ref_ttc = brute_force(s.plan, s.ego, s.objects, PET_REF)
    assert ttc == ref_ttc
    assert ss == pytest.approx(ref_ss, abs=1e-12)


def test_prediction_starting_later_moves_from_the_current_position():
    # Object 4 x 2 heading north at (20.5, -10.5); its one-point prediction is (20.5, 4.5) at
    # dt = 1.5 s. Before that it moves from where it is: y = -10.5 + 15 t / 1.5 = -10.5 + 10 t,
    # then stays at 4.5. Ego 4 x 2 along y = 0 at 10 m/s.
    # x overlap (ego [10 t - 2, 10 t + 2], object [19.5, 21.5]): t in [1.75, 2.35], grid 1.8..2.3
    # y overlap (ego [-1, 1], object [y - 2, y + 2]): y in [-3, 3], t in [0.75, 1.35], grid
    # 0.8..1.3 (the lead-in; at 4.5 it is clear). No equal times: PET = 1.8 - 1.3 = 0.5,
    # ss = 0.5 / 2 = 0.25. (Without the lead-in the object would never be in the way: ss = 1.)
    s = scene([obj(1, 20.5, -10.5, math.pi / 2, 4, 2, prediction=[[1.5, 20.5, 4.5]])])
    ss, ttc, pet = safety_score(s.plan, s.ego, s.objects, PET_REF)
    assert ttc == math.inf
    assert pet == pytest.approx(0.5)
    assert ss == pytest.approx(0.25)


def test_matrix_with_prefix_grids_takes_the_kernel_and_agrees():
    # Channel a plans 3.0 s, b the first 1.0 s of the same grid (one kernel call for both).
    # a's object (4 x 2) stands at 13.5 m, its rear at 11.5. Both egos' fronts are at
    # 10 t + 2: 11.0 at 0.9 s (clear), 12.0 at 1.0 s (overlap): ttc = 1.0 for both.
    # ss_aa = 1.0 / 3.0 = 1/3; ss_ba = min(1, 1.0 / 1.0) = 1.0 (a hit at b's horizon).
    f = frame(
        0.0,
        {
            "a": channel(ego(), plan=straight_plan(0, 0, 10, 0, 31), objects=[obj(1, 13.5, 0)]),
            "b": channel(ego(), plan=straight_plan(0, 0, 10, 0, 11)),
        },
    )
    m = safety_matrix(["a", "b"], f.channels, PET_REF)
    assert m[("a", "a")] == pytest.approx(1 / 3)
    assert m[("b", "a")] == pytest.approx(1.0)
    assert m[("a", "b")] == 1.0 and m[("b", "b")] == 1.0


def test_polygon_footprints_leave_the_kernel():
    # A polygon object, or a polygon ego, is not a box: the kernel declines (None) and
    # score_grid takes the numpy path (tested by the U-shaped object in test_safety_score).
    poly = {
        "id": 1,
        "x": 13.5,
        "y": 0.0,
        "yaw": 0.0,
        "polygon": [[2, 1], [-2, 1], [-2, -1], [2, -1]],
    }
    s = scene([poly])
    assert score_boxes([s.plan], [s.ego], [s.objects], PET_REF) is None
    e = {"x": 0, "y": 0, "yaw": 0, "polygon": [[2, 1], [-2, 1], [-2, -1], [2, -1]]}
    f = frame(
        0.0, {"a": channel(e, plan=straight_plan(0, 0, 10, 0, 31), objects=[obj(1, 13.5, 0)])}
    )
    a = f.channels["a"]
    assert score_boxes([a.plan], [a.ego], [a.objects], PET_REF) is None
    # the same 4 x 2 rectangle either way: ttc = 1.0 (front 12.0 >= rear 11.5 at 1.0 s), ss = 1/3
    assert safety_score(s.plan, s.ego, s.objects, PET_REF)[1] == pytest.approx(1.0)
    assert safety_score(a.plan, a.ego, a.objects, PET_REF)[1] == pytest.approx(1.0)


@pytest.mark.parametrize(("lateral", "expected"), [(3.5, (1.0, math.inf)), (2.0, (0.0, 0.0))])
def test_parallel_traffic_in_the_next_lane(lateral, expected):
    # Ego 4 x 2 along y = 0 and an object 4 x 2 beside it along y = lateral, both at 10 m/s
    # for 3.0 s (predicted on the plan's grid). Their sides are lateral - 2 apart:
    # 3.5 -> 1.5 m apart at every time pair that overlaps in x: never meet, ss = 1, ttc = inf;
    # 2.0 -> 0 m: the sides touch from t = 0 (touching intersects): ttc = 0, ss = 0.
    pred = straight_plan(0, lateral, 10, 0, 31)
    s = scene([obj(1, 0, lateral, 0, 4, 2, prediction=pred)])
    ss, ttc, pet = safety_score(s.plan, s.ego, s.objects, PET_REF)
    assert (ss, ttc) == expected
    assert pet == math.inf
