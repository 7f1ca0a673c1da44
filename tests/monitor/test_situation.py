"""Situation signals, hand-computed (spi-reference "Situation signals")."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.frames import Coverage
from casewatch.monitor.situation import (
    GAP_CAP,
    TIME_CAP,
    _nearest,
    headway,
    neighbour,
    project,
    time_to_collision,
)
from casewatch.safety_case.model import MetricParams
from tests.monitor.builders import channel, ego, frame, obj, straight_plan

HALF_WIDTH = 1.75


def test_projection_onto_a_polyline():
    # L-shaped path (0,0) -> (10,0) -> (10,10): (10.5, 6) projects onto the second leg at
    # s = 10 + 6 = 16, 0.5 m off it, tangent +y; (4, -1) onto the first at s = 4, 1 m off
    path = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    s, d, tangent = project(path, np.array([[10.5, 6.0], [4.0, -1.0]]))
    np.testing.assert_allclose(s, [16.0, 4.0])
    np.testing.assert_allclose(d, [0.5, 1.0])
    np.testing.assert_allclose(tangent, [[0.0, 1.0], [1.0, 0.0]], atol=1e-12)


def run_one(objects, plan=None, speed=20.0, history=()):
    """One channel 'a' (and an identical 'b'), ego 4 x 2 at the origin heading +x at `speed`;
    `history` are earlier ego x positions (one frame each, 0.1 s apart) for the driven path."""
    eng = MetricEngine(MetricParams(), ["a", "b"])
    out = {}
    times = [round(-0.1 * (len(history) - k), 1) for k in range(len(history))] + [0.0]
    for t, x in zip(times, [*history, 0.0], strict=True):
        ch = channel(ego(x, 0, 0, 4, 2, vx=speed), plan=plan, objects=objects if t == 0 else [])
        out = eng.step(frame(t, {"a": ch, "b": ch}))
    return out


def test_leader_in_the_corridor_hand_computed():
    # leader 4 m long centred 30 m ahead, 0.5 m off the path, 15 m/s:
    # gap = 30 - 2 - 2 = 26 m; THW = 26 / 20 = 1.3 s; TTC = 26 / (20 - 15) = 5.2 s
    plan = straight_plan(0, 0, 20, 0, 31)
    out = run_one([obj(1, 30.0, 0.5, 0.0, 4, 2, vx=15.0)], plan=plan)
    assert out["lead_gap__a"] == pytest.approx(26.0)
    assert out["lead_thw__a"] == pytest.approx(1.3)
    assert out["lead_ttc__a"] == pytest.approx(5.2)
    assert out["lead_speed__a"] == pytest.approx(15.0) == out["lead_speed"]
    assert out["lead_thw"] == pytest.approx(1.3) and out["ego_speed"] == pytest.approx(20.0)


def test_no_leader_is_the_cap_not_missing_data():
    # 2.5 m beside the path is outside the 1.75 m corridor; behind the ego is not ahead
    plan = straight_plan(0, 0, 20, 0, 31)
    out = run_one([obj(1, 30.0, 2.5, 0.0, 4, 2, vx=15.0), obj(2, -10.0, 0.0)], plan=plan)
    assert (out["lead_gap"], out["lead_thw"], out["lead_ttc"]) == (GAP_CAP, TIME_CAP, TIME_CAP)
    assert out["lead_speed"] == 0.0


def test_leader_beyond_a_bend_of_the_plan():
    # plan (0,0) -> (10,0) -> (10,10) (an L, 20 m/s is irrelevant to the geometry); a car
    # heading +y at (10.5, 6): s = 16, its half length 2 along the tangent: gap 16 - 2 - 2 = 12
    plan = [[0.0, 0.0, 0.0], [0.5, 10.0, 0.0], [1.0, 10.0, 10.0]]
    out = run_one([obj(1, 10.5, 6.0, math.pi / 2, 4, 2)], plan=plan, speed=10.0)
    assert out["lead_gap__a"] == pytest.approx(12.0, abs=0.2)  # resampled corner: within 0.2


def test_follower_along_the_driven_path():
    # the ego came along +x (x = -2.0 .. -0.1 over the last 2 s); a 4 m car centred 12 m
    # behind drives at 25 m/s towards it: gap = 12 - 2 - 2 = 8 m; follow_speed 25;
    # THW = 8 / 25 = 0.32 s; TTC = 8 / (25 - 20) = 1.6 s
    history = [-0.1 * k for k in range(20, 0, -1)]
    plan = straight_plan(0, 0, 20, 0, 31)
    out = run_one([obj(1, -12.0, 0.3, 0.0, 4, 2, vx=25.0)], plan=plan, history=history)
    assert out["follow_gap__a"] == pytest.approx(8.0)
    assert out["follow_speed__a"] == pytest.approx(25.0)
    assert out["follow_thw__a"] == pytest.approx(0.32)
    assert out["follow_ttc__a"] == pytest.approx(1.6)
    # and nothing ahead
    assert out["lead_thw__a"] == TIME_CAP


def test_a_forward_camera_never_makes_the_follower_a_data_gap():
    history = [-0.1 * k for k in range(20, 0, -1)]
    eng = MetricEngine(MetricParams(), ["lidar", "cam"], {"cam": Coverage(120.0, 70.0)})
    follower = obj(1, -12.0, 0.0, 0.0, 4, 2, vx=25.0)
    out = {}
    for k, x in enumerate([*history, 0.0]):
        t = round(-0.1 * (len(history) - k), 1)
        lidar = channel(ego(x, 0, 0, 4, 2, vx=20.0), objects=[follower] if x == 0.0 else [])
        cam = channel(ego(x, 0, 0, 4, 2, vx=20.0))
        out = eng.step(frame(t, {"lidar": lidar, "cam": cam}))
    assert out["follow_thw__cam"] is None  # the camera cannot see behind
    assert out["follow_thw"] == pytest.approx(0.32)  # the lidar's, not a gap
    assert out["lead_thw"] == TIME_CAP  # ahead: both see, nothing there
    # without the lidar nobody sees behind: no value, never a pass
    out = eng.step(frame(0.1, {"cam": channel(ego(2.0, 0, 0, 4, 2, vx=20.0))}))
    assert out["follow_thw"] is None


def test_headway_and_ttc_caps():
    assert headway(10.0, 0.0) == TIME_CAP  # a standing ego has all the time in the world
    assert headway(10.0, 5.0) == pytest.approx(2.0)
    assert headway(1000.0, 1.0) == TIME_CAP
    assert time_to_collision(10.0, -1.0) == TIME_CAP  # opening: no collision course
    assert time_to_collision(10.0, 4.0) == pytest.approx(2.5)


def test_ego_accel_is_the_slope_of_the_reported_speed():
    # speed 10 + 2 t: a slope of 2 m/s^2 once half a second of speeds is there
    eng = MetricEngine(MetricParams(), ["a", "b"])
    outs = []
    for k in range(12):
        t = round(0.1 * k, 1)
        ch = channel(ego(0, 0, 0, vx=10.0 + 2.0 * t))
        outs.append(eng.step(frame(t, {"a": ch, "b": ch})))
    assert [o["ego_accel"] is None for o in outs[:6]] == [True] * 5 + [False]
    assert outs[11]["ego_accel"] == pytest.approx(2.0)


def test_neighbour_without_objects():
    f = frame(0.0, {"a": channel(ego())})
    s = f.channels["a"]
    path = np.array([[0.0, 0.0], [50.0, 0.0]])
    assert neighbour(s.ego, s.objects, path, HALF_WIDTH, 2.0).present is False


def segment_distances(path, pos):
    """(K, 2): each point's distance to its nearest and second-nearest path segment."""
    a, b = path[:-1], path[1:]
    ab = b - a
    t = np.clip(
        np.einsum("ksi,si->ks", pos[:, None] - a, ab) / np.einsum("si,si->s", ab, ab), 0.0, 1.0
    )
    foot = a + t[..., None] * ab
    dist = np.sort(np.hypot(*(pos[:, None] - foot).transpose(2, 0, 1)), axis=1)
    if dist.shape[1] == 1:  # one segment: nothing to tie with
        return np.column_stack([dist[:, 0], np.full(len(pos), np.inf)])
    return dist[:, :2]


@settings(max_examples=80, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(-50, 50), st.floats(-50, 50)), min_size=2, max_size=6, unique=True
    ),
    st.lists(
        st.tuples(st.floats(-60, 60), st.floats(-60, 60), st.floats(-3.2, 3.2)),
        min_size=1,
        max_size=8,
    ),
)
def test_compiled_nearest_equals_the_numpy_projection(points, objects):
    """The kernel against `project` (numpy) and the gap formula written out."""
    path = np.array(points)
    seg = np.hypot(*np.diff(path, axis=0).T)
    if (seg < 1e-3).any():
        return
    pos = np.array([(x, y) for x, y, _ in objects])
    yaw = np.array([a for _, _, a in objects])
    hl, hw = np.full(len(pos), 2.2), np.full(len(pos), 0.9)
    k, gap, _, _ = _nearest(
        path, pos, yaw, hl, hw, np.zeros((len(pos), 2)), HALF_WIDTH, 2.3, 1.0, 0.0, 0.0, 0.0, False
    )
    s, d, tangent = project(path, pos)
    cos = np.abs(np.cos(yaw) * tangent[:, 0] + np.sin(yaw) * tangent[:, 1])
    want = np.maximum(s - 2.3 - (hl * cos + hw * np.sqrt(np.maximum(0, 1 - cos**2))), 0.0)
    inside = (d <= HALF_WIDTH) & (s > 0)
    # away from the boundaries the kernel decides (boundary cases are the EPS rule's): the
    # corridor's edge, beside the ego, and points as near to two segments (a vertex, a
    # bisector), whose tangent the EPS rule picks and argmin may not
    near_edge = (np.abs(d - HALF_WIDTH) < 1e-6) | (np.abs(s) < 1e-6)
    if near_edge.any() or (segment_distances(path, pos)[:, 1] - d < 1e-6).any():
        return
    if not inside.any():
        assert k == -1
        return
    assert gap == pytest.approx(np.min(want[inside]), abs=1e-6)


def test_a_car_crossing_the_corridor_is_not_a_leader():
    # 20 m ahead, 1.5 m to the right of the path, 20 m/s along it. Drifting left at 2.5 m/s it
    # is 1.0 m to the left a second later: still in the 1.75 m corridor, a leader (gap 16 m).
    # At 4 m/s it is 2.5 m to the left a second later: it crosses the lane (LANE_HOLD), no
    # leader; drifting right out of the lane at 1 m/s (2.5 m right in a second) neither.
    plan = straight_plan(0, 0, 20, 0, 31)
    for vy, leader in ((2.5, True), (4.0, False), (-1.0, False)):
        out = run_one([obj(1, 20.0, -1.5, 0.0, 4, 2, vx=20.0, vy=vy)], plan=plan)
        assert (out["lead_gap__a"] == pytest.approx(16.0)) is leader, vy
        assert (out["lead_thw__a"] == TIME_CAP) is not leader, vy


def run_path(objects, path_xy, speed=20.0):
    """Channel 'a' (and 'b') driving through the points `path_xy` (oldest first, one frame
    each, 0.1 s apart), heading +x at the last one (the origin), `objects` seen there."""
    eng = MetricEngine(MetricParams(), ["a", "b"])
    out = {}
    n = len(path_xy)
    for k, (x, y) in enumerate(path_xy):
        t = round(-0.1 * (n - 1 - k), 1)
        ch = channel(ego(x, y, 0, 4, 2, vx=speed), objects=objects if k == n - 1 else [])
        out = eng.step(frame(t, {"a": ch, "b": ch}))
    return out


def test_follower_in_its_own_lane_during_a_lane_change():
    # The ego changed lanes: it came from 3.2 m to the left over the last 2 s (its driven
    # path leans back into the old lane: 0.96 m left at x = -12). A 4 m car 12 m behind,
    # 1.2 m to the right, heading +x at 25 m/s is 2.15 m from that path (outside the
    # corridor), but the ego drives in the car's own lane (1.2 m off its heading line): the
    # follower, gap 12 - 2 - 2 = 8 m, THW 8 / 25 = 0.32 s, as a lane-based reading has it.
    path = [(-0.1 * 20 * (20 - k), 3.2 * (20 - k) / 20) for k in range(21)]
    out = run_path([obj(1, -12.0, -1.2, 0.0, 4, 2, vx=25.0)], path)
    assert out["follow_gap__a"] == pytest.approx(8.0)
    assert out["follow_thw__a"] == pytest.approx(0.32)


def test_a_car_in_the_next_lane_after_a_turn_is_no_follower():
    # The ego came diagonally (out of a turn) from (-10, -3.3) to the origin; a car heading +x
    # at 15 m/s at (-12, -3.3), in the lane beside the ego's, lies 0.63 m from that driven path
    # extended, but crosses it at 4.7 m/s (LANE_HOLD), and the ego is 3.3 m off its own
    # lane's line: no follower (before, follow_thw read 0.48 s)
    path = [(-10.0 + 0.5 * k, -3.3 + 0.165 * k) for k in range(21)]
    out = run_path([obj(1, -12.0, -3.3, 0.0, 4, 2, vx=15.0)], path, speed=5.0)
    assert out["follow_thw__a"] == TIME_CAP and out["follow_gap__a"] == GAP_CAP


def test_a_car_in_the_planned_path_is_no_leader_before_the_ego_is_in_its_lane():
    # A lane change to the left (a held-out highway drive at 32.7 s): the ego at the origin
    # heading 0.047 rad, its plan bending into the new lane; a car 14 m ahead, 2.31 m to the
    # left, heading 0 at 30 m/s, is 1.66 m from the plan (in the corridor) but 2.31 m across
    # its own lane's line: the chord between them, 1.98 m off the mean heading, says the ego
    # is not in its lane yet (LEAD_LANE). Once the ego has moved 0.9 m across (the car now
    # 1.41 m to its left, chord 1.08 m off) the car is its leader: gap 14 - 2 - 2 = 10 m.
    from casewatch.monitor.situation import neighbours

    plan = [
        [0.0, 0.0, 0.0],
        [0.6, 15.0, 0.7],
        [1.2, 30.0, 1.9],
        [1.8, 45.0, 2.3],
        [4.0, 100.0, 2.3],
    ]
    for ego_y, leader in ((0.0, False), (0.9, True)):
        p = [[t, x, y + ego_y] for t, x, y in plan]
        car = obj(1, 14.0, 2.31, 0.0, 4, 2, vx=30.0)
        s = frame(
            0.0, {"a": channel(ego(0, ego_y, 0.047, 4, 2, vx=22.5), plan=p, objects=[car])}
        ).channels["a"]
        lead, _ = neighbours(s.ego, s.plan, None, s.objects, HALF_WIDTH, 2.0, 250.0)
        assert lead.present is leader, ego_y
        if leader:
            assert lead.gap == pytest.approx(14.0 - 2.0 - 2.0, abs=0.05)


def test_a_leader_around_a_bend_shares_the_lane():
    # A bend of radius 100 m to the left, the ego at its start heading +x; a car 30 m along
    # the arc (0.3 rad further round) heading along it is 4.47 m off the ego's heading line,
    # but the chord between them runs along their mean heading (an arc's chord halves its
    # turn): the leader, gap 30 - 2 - 2 = 26 m along the arc (the plan's polyline)
    from casewatch.monitor.situation import neighbours

    angles = np.linspace(0.0, 0.6, 31)
    plan = [
        [0.1 * k, float(100 * np.sin(a)), float(100 * (1 - np.cos(a)))]
        for k, a in enumerate(angles)
    ]
    car = obj(
        1,
        float(100 * np.sin(0.3)),
        float(100 * (1 - np.cos(0.3))),
        0.3,
        4,
        2,
        vx=float(20 * np.cos(0.3)),
        vy=float(20 * np.sin(0.3)),
    )
    s = frame(
        0.0, {"a": channel(ego(0, 0, 0.0, 4, 2, vx=20.0), plan=plan, objects=[car])}
    ).channels["a"]
    lead, _ = neighbours(s.ego, s.plan, None, s.objects, HALF_WIDTH, 2.0, 250.0)
    assert lead.present and lead.gap == pytest.approx(26.0, abs=0.1)
