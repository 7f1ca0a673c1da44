"""Cross-channel similarity metrics, hand-computed on tiny frames."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.similarity import (
    angdiff,
    crpps_distance,
    crpps_inputs,
    ego_similarities,
    ets,
    frechet,
    object_similarities,
    pair_objects,
)
from tests.monitor.builders import channel, ego, frame, obj
from tests.monitor.test_history import along, path_length

GATE = 3.0
K = 0.95


def weighted_pointwise(
    p: np.ndarray, q: np.ndarray, lengths: np.ndarray | None, decay: float
) -> np.ndarray:
    """Reference (numpy): S = sum_n w_n inv(|P_n - Q_n|) / sum_n w_n, w_n = k^(n-1), each row
    of (M, L, 2) limited to its first `lengths[m]` points (None = all)."""
    d = np.hypot(p[..., 0] - q[..., 0], p[..., 1] - q[..., 1])
    w = decay ** np.arange(p.shape[1], dtype=float)
    if lengths is not None:
        w = np.where(np.arange(p.shape[1])[None, :] < lengths[:, None], w, 0.0)
    return (w / (1.0 + d)).sum(axis=-1) / w.sum(axis=-1)


def two_channel_frame():
    a = channel(
        ego(0, 0, 0),
        plan=[[0, 0, 0], [0.1, 1, 0], [0.2, 2, 0]],
        objects=[
            obj("o1", 10, 0, 0, 4, 2, prediction=[[0, 10, 0], [0.1, 11, 0]]),
            obj("o2", 20, 0, 0, 4, 2),
        ],
    )
    b = channel(
        ego(3, 4, math.pi / 2),
        plan=[[0, 3, 4], [0.1, 4, 4]],
        objects=[
            obj(
                "p1", 10, 1, math.pi / 4, 4, 1, prediction=[[0, 10, 1], [0.1, 11, 1], [0.2, 12, 1]]
            ),
            obj("p2", 50, 0),
            obj("p3", 20, 2, math.pi, 4, 2),
        ],
    )
    return frame(0.0, {"a": a, "b": b})


def test_ego_similarities_hand_computed():
    f = two_channel_frame()
    out = ego_similarities(f.channels["a"], f.channels["b"])
    # els: |(0,0)-(3,4)| = 5 -> 1 / (1 + 5) = 1/6
    assert out["els"] == pytest.approx(1 / 6)
    # eos: angdiff(0, pi/2) = pi/2 -> 1 - (pi/2)/pi = 0.5
    assert out["eos"] == pytest.approx(0.5)


def test_object_similarities_hand_computed():
    f = two_channel_frame()
    out = object_similarities(f.channels["a"].objects, f.channels["b"].objects, GATE, K)
    # ocs: |2 - 3| = 1 -> 1/2
    assert out["ocs"] == pytest.approx(0.5)
    # pairs within 3 m: o1-p1 at 1 m, o2-p3 at 2 m; p2 (30 m away) is unpaired and, with no
    # benefit of the doubt left (keep = 0), scores 0: every metric is (pair sum + 0) / 3
    # ols: (1/(1+1) + 1/(1+2)) / 3 = (0.5 + 0.3333) / 3 = 5/18
    assert out["ols"] == pytest.approx(5 / 18)
    # oos: o1-p1 angdiff pi/4 -> 0.75; o2-p3 angdiff pi -> 0.0; (0.75 + 0) / 3
    assert out["oos"] == pytest.approx(0.25)
    # oas: 4x2 = 8 vs 4x1 = 4 -> 0.5; 8 vs 8 -> 1.0; 1.5 / 3
    assert out["oas"] == pytest.approx(0.5)
    # ots compares predicted motion (each prediction relative to its object's position), pair
    #   o1-p1 over the common horizon, o1's 2 points against p1's first 2 (a shorter horizon is
    #   not a disagreement): (0,0),(1,0) vs (0,0),(1,0): S = 1 (the 1 m between the two
    #   positions is ols's); pair o2-p3: no predictions, both stay: 1; p2: 0. (1 + 1 + 0) / 3
    assert out["ots"] == pytest.approx(2 / 3)


def test_unpaired_object_keeps_its_benefit_of_the_doubt():
    f = two_channel_frame()
    a, b = f.channels["a"].objects, f.channels["b"].objects
    # keep = 1 (first seen unpaired): p2 scores what the pairs score on average: neutral
    fresh = object_similarities(a, b, GATE, K, keep=1.0)
    assert fresh["ols"] == pytest.approx(5 / 12)
    assert fresh["oos"] == pytest.approx(0.375)
    # keep = 0.5: (pair sum + 0.5 * pair mean) / 3; ols (5/6 + 0.5 * 5/12) / 3 = 25/72
    half = object_similarities(a, b, GATE, K, keep=0.5)
    assert half["ols"] == pytest.approx(25 / 72)
    assert half["oas"] == pytest.approx((1.5 + 0.5 * 0.75) / 3)
    # ocs counts objects, not their age
    assert fresh["ocs"] == half["ocs"] == 0.5


def test_plan_similarities_hand_computed():
    f = two_channel_frame()
    pa, pb = f.channels["a"].plan, f.channels["b"].plan
    # ets: truncated to 2 points, (0,0)-(3,4) and (1,0)-(4,4): both 5 m -> 1/6 each
    assert ets(pa, pb, K) == pytest.approx(1 / 6)
    # crpps: common horizon = the shorter plan's last dt, so A keeps (0,0),(1,0) and B,
    # translated by (-3,-4), is (0,0),(1,0): Frechet distance 0
    assert crpps_distance(pa, pb) == pytest.approx(0.0)
    assert crpps_distance(pb, pa) == pytest.approx(0.0)


def test_crpps_compares_the_common_horizon_only():
    # A: 3 s plan straight along x at 10 m/s; B: 2 s plan, same start, drifting 1 m left
    # per second. Common horizon 2 s: A (0,0),(10,0),(20,0); B (0,0),(10,1),(20,2).
    # As paths over the length both cover (20 m; B's is 20.1 m), B's points 10 and 20 m along
    # its direction (10, 1) / sqrt(101); discrete Frechet = the end points' distance
    # |(20,0) - 20 (10,1) / sqrt(101)| = 1.992548; A's (30,0) is ignored (whole plans would
    # give at least |(30,0) - (20,2)| = 10.2).
    a = np.array([[0, 0, 0], [1, 10, 0], [2, 20, 0], [3, 30, 0]], dtype=float)
    b = np.array([[0, 5, 5], [1, 15, 6], [2, 25, 7]], dtype=float)
    d = float(np.hypot(20 - 200 / np.sqrt(101), 20 / np.sqrt(101)))
    assert crpps_distance(a, b) == pytest.approx(d)
    assert crpps_distance(b, a) == pytest.approx(d)
    assert d == pytest.approx(1.992548, abs=1e-6)


def test_crpps_reads_the_path_not_the_speed():
    # the same straight path, B planned 20 % faster: 10 m apart at 5 s, time-wise; one path
    a = np.column_stack([np.arange(51) * 0.1, np.arange(51) * 1.0, np.zeros(51)])
    b = a * np.array([1.0, 1.2, 1.0])
    assert crpps_distance(a, b) == pytest.approx(0.0, abs=1e-9)


def test_both_see_nothing_is_one_and_one_side_only_is_zero():
    e = frame(0.0, {"a": channel(ego()), "b": channel(ego())})
    out = object_similarities(e.channels["a"].objects, e.channels["b"].objects, GATE, K)
    assert out == {"ocs": 1.0, "ols": 1.0, "oos": 1.0, "oas": 1.0, "ots": 1.0}
    f = frame(0.0, {"a": channel(ego(), objects=[obj(1, 5, 0), obj(2, 9, 0)]), "b": channel(ego())})
    out = object_similarities(f.channels["a"].objects, f.channels["b"].objects, GATE, K)
    # ocs = 1 / (1 + 2); the rest: objects exist, no pair -> 0.0 (spi-reference Decision)
    assert out == pytest.approx({"ocs": 1 / 3, "ols": 0.0, "oos": 0.0, "oas": 0.0, "ots": 0.0})


def test_no_pair_within_gate_is_zero():
    f = frame(
        0.0,
        {
            "a": channel(ego(), objects=[obj(1, 0, 0)]),
            "b": channel(ego(), objects=[obj(1, 3.5, 0)]),
        },
    )
    out = object_similarities(f.channels["a"].objects, f.channels["b"].objects, GATE, K)
    assert out == {"ocs": 1.0, "ols": 0.0, "oos": 0.0, "oas": 0.0, "ots": 0.0}


def test_pairing_is_greedy_global_with_ties_by_index():
    a = np.array([[0.0, 0.0], [2.0, 0.0]])
    b = np.array([[1.5, 0.0], [-1.0, 0.0]])
    # sorted: A1-B0 0.5, A0-B1 1.0, A0-B0 1.5 (A0 taken), A1-B1 3.0 -> (1,0), (0,1)
    ia, ib, d = pair_objects(a, b, GATE)
    assert ia.tolist() == [1, 0] and ib.tolist() == [0, 1]
    assert d.tolist() == pytest.approx([0.5, 1.0])
    # tie: B0 and B1 both 1 m from A0 -> the lower B index wins
    ia, ib, _ = pair_objects(np.array([[0.0, 0.0]]), np.array([[1.0, 0.0], [-1.0, 0.0]]), GATE)
    assert (ia.tolist(), ib.tolist()) == ([0], [0])
    # gate is inclusive: exactly 3 m pairs
    ia, _, _ = pair_objects(np.array([[0.0, 0.0]]), np.array([[3.0, 0.0]]), GATE)
    assert ia.tolist() == [0]


def test_weighted_pointwise_weights_decay():
    p = np.array([[[0.0, 0.0], [0.0, 0.0]]])
    q = np.array([[[0.0, 1.0], [0.0, 0.0]]])
    # (1 * 1/2 + 0.95 * 1) / 1.95 = 1.45 / 1.95
    assert weighted_pointwise(p, q, None, K)[0] == pytest.approx(1.45 / 1.95)
    # limited to the first point: 1/2
    assert weighted_pointwise(p, q, np.array([1]), K)[0] == pytest.approx(0.5)


def test_angdiff_wraps():
    assert angdiff(0.1, 2 * math.pi - 0.1) == pytest.approx(0.2)
    assert angdiff(-math.pi, math.pi) == pytest.approx(0.0, abs=1e-12)
    assert angdiff(0.0, 3 * math.pi) == pytest.approx(math.pi)


def test_frechet_single_point_and_empty_plan():
    # one point vs a polyline: the farthest point, |(0,0)-(3,4)| = 5
    assert frechet(np.array([[0.0, 0.0]]), np.array([[1.0, 0.0], [3.0, 4.0]])) == 5.0
    assert ets(np.zeros((0, 3)), np.array([[0.0, 1.0, 1.0]]), K) is None
    assert crpps_distance(np.zeros((0, 3)), np.array([[0.0, 1.0, 1.0]])) is None


# -- compiled kernels against independent references -------------------------------------------


def reference_pairs(pos_a: np.ndarray, pos_b: np.ndarray, gate: float) -> list[tuple[int, int]]:
    """Greedy global matching, written plainly: all gated (A, B) candidates sorted by
    (distance in 1e-9 m steps, index in A, index in B), accepted while both are free."""
    cands = []
    for i, (xa, ya) in enumerate(pos_a.tolist()):
        for j, (xb, yb) in enumerate(pos_b.tolist()):
            d = math.sqrt((xa - xb) ** 2 + (ya - yb) ** 2)
            if d <= gate + 1e-9:
                cands.append((round(d / 1e-9), i, j))
    used_a: set[int] = set()
    used_b: set[int] = set()
    out = []
    for _, i, j in sorted(cands):
        if i not in used_a and j not in used_b:
            used_a.add(i)
            used_b.add(j)
            out.append((i, j))
    return out


def reference_objects(a, b, gate: float, decay: float, keep: float = 0.0) -> dict[str, float]:
    """spi-reference object similarities from the parsed objects, one pair at a time; every
    unpaired object scores `keep` times the pairs' mean (1.0 without pairs)."""
    out = {"ocs": 1.0 / (1.0 + abs(len(a) - len(b)))}
    if len(a) == 0 and len(b) == 0:
        return {**out, "ols": 1.0, "oos": 1.0, "oas": 1.0, "ots": 1.0}
    pairs = reference_pairs(a.pos, b.pos, gate)
    lone = len(a) + len(b) - 2 * len(pairs)
    if not pairs:
        return {**out, "ols": keep, "oos": keep, "oas": keep, "ots": keep}
    xa, la = a.prediction_xy()
    xb, lb = b.prediction_xy()
    ols, oos, oas, ots = [], [], [], []
    for i, j in pairs:
        ols.append(1.0 / (1.0 + math.dist(a.pos[i], b.pos[j])))
        oos.append(1.0 - angdiff(a.yaw[i], b.yaw[j]) / math.pi)
        hi, lo = max(a.areas[i], b.areas[j]), min(a.areas[i], b.areas[j])
        oas.append(lo / hi if hi > 0 else 1.0)
        # the common horizon when both predict; an object without prediction (pred_len 0,
        # its current position as a one-point prediction) stays put over the other's
        both = (
            a.pred_len[i] > 0 and b.pred_len[j] > 0
            if a.pred.shape[1] and b.pred.shape[1]
            else False
        )
        n = min(la[i], lb[j]) if both else max(la[i], lb[j])
        # predicted motion: each prediction relative to its own object's position
        pa = xa[i][np.minimum(np.arange(n), la[i] - 1)] - a.pos[i]
        pb = xb[j][np.minimum(np.arange(n), lb[j] - 1)] - b.pos[j]
        ots.append(weighted_pointwise(pa[None], pb[None], None, decay)[0])

    def with_lone(values: list[float]) -> float:
        return (sum(values) + lone * keep * np.mean(values)) / (len(values) + lone)

    return {
        **out,
        "ols": with_lone(ols),
        "oos": with_lone(oos),
        "oas": with_lone(oas),
        "ots": with_lone(ots),
    }


@st.composite
def object_list(draw):
    """0-4 objects on a coarse grid (distance ties are common), random headings, boxes or
    polygons, predictions of 0-5 points, absent, or empty."""
    objs = []
    for k in range(draw(st.integers(0, 4))):
        x, y = draw(st.integers(0, 4)) * 1.5, draw(st.integers(0, 2)) * 2.0
        extra = {}
        kind = draw(st.sampled_from(["none", "empty", "points"]))
        if kind == "empty":
            extra["prediction"] = []
        elif kind == "points":
            n = draw(st.integers(1, 5))
            steps = draw(st.lists(st.floats(-2, 2), min_size=2 * n, max_size=2 * n))
            extra["prediction"] = [
                [0.1 * m, x + sum(steps[0 : 2 * m + 1 : 2]), y + sum(steps[1 : 2 * m + 2 : 2])]
                for m in range(n)
            ]
        o = obj(
            k,
            x,
            y,
            draw(st.floats(-7, 7)),
            draw(st.floats(0.1, 6)),
            draw(st.floats(0.1, 3)),
            **extra,
        )
        if draw(st.booleans()):
            # a polygon footprint instead of the box (its area: the shoelace formula)
            del o["length"], o["width"]
            n_vert = draw(st.integers(3, 5))
            o["polygon"] = draw(
                st.lists(
                    st.tuples(st.floats(-3, 3), st.floats(-2, 2)), min_size=n_vert, max_size=n_vert
                )
            )
        objs.append(o)
    return objs


@settings(max_examples=150, deadline=None)
@given(
    object_list(),
    object_list(),
    st.sampled_from([0.0, 1.5, 3.0]),
    st.sampled_from([0.5, 0.95]),
    st.sampled_from([0.0, 0.4, 1.0]),
)
def test_object_kernel_equals_reference(objs_a, objs_b, gate, decay, keep):
    f = frame(0.0, {"a": channel(ego(), objects=objs_a), "b": channel(ego(), objects=objs_b)})
    a, b = f.channels["a"].objects, f.channels["b"].objects
    ia, ib, dist = pair_objects(a.pos, b.pos, gate)
    assert list(zip(ia.tolist(), ib.tolist(), strict=True)) == reference_pairs(a.pos, b.pos, gate)
    assert dist.tolist() == pytest.approx(
        [math.dist(a.pos[i], b.pos[j]) for i, j in zip(ia, ib, strict=True)]
    )
    want = reference_objects(a, b, gate, decay, keep)
    assert object_similarities(a, b, gate, decay, keep=keep) == pytest.approx(want, abs=1e-12)


@st.composite
def plan(draw):
    """A plan [dt, x, y] of 0-8 points on the canonical 0.1 s grid (what the engine hands the
    plan metrics after resampling), starting at dt = 0, 0.1 or 0.2."""
    n = draw(st.integers(0, 8))
    dt = 0.1 * (draw(st.integers(0, 2)) + np.arange(n))
    xy = draw(st.lists(st.floats(-50, 50), min_size=2 * n, max_size=2 * n))
    return np.column_stack([dt, np.reshape(xy, (n, 2))]) if n else np.zeros((0, 3))


@settings(max_examples=150, deadline=None)
@given(plan(), plan(), st.sampled_from([0.5, 0.95]))
def test_plan_kernels_equal_reference(pa, pb, decay):
    got = ets(pa, pb, decay)
    if len(pa) == 0 or len(pb) == 0:
        assert got is None and crpps_inputs(pa, pb) is None
        return
    # both metrics read the time range both plans cover (spi-reference "ets", "crpps")
    lo = max(pa[0, 0], pb[0, 0]) - 1e-9
    hi = min(pa[-1, 0], pb[-1, 0]) + 1e-9
    ka = pa[(pa[:, 0] >= lo) & (pa[:, 0] <= hi), 1:3]
    kb = pb[(pb[:, 0] >= lo) & (pb[:, 0] <= hi), 1:3]
    assert len(ka) == len(kb)
    if len(ka) == 0:
        assert got is None and crpps_inputs(pa, pb) is None
        return
    assert got == pytest.approx(weighted_pointwise(ka[None], kb[None], None, decay)[0], abs=1e-12)
    # crpps: B moved onto A's start, both as paths over the length both cover (shapely's)
    xa, xb = crpps_inputs(pa, pb)
    qb = kb - kb[0] + ka[0]
    length = min(path_length(ka), path_length(qb))
    np.testing.assert_allclose(xa, along(ka, length, len(ka)), atol=1e-9)
    np.testing.assert_allclose(xb, along(qb, length, len(ka)), atol=1e-9)


def test_plans_without_common_time_have_no_plan_similarity():
    # B starts after A ends: the plans cover no common time, so there is nothing to compare
    a = np.array([[0.0, 0.0, 0.0]])
    b = np.array([[0.5, 1.0, 1.0], [1.0, 2.0, 2.0]])
    assert crpps_inputs(a, b) is None and ets(a, b, K) is None


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 4), max_size=40))
def test_pairing_order_is_numpys_stable_argsort(keys):
    """The kernel's merge sort orders the pairing candidates like a stable argsort (equal keys
    keep their (A, B) order: the tie break by index)."""
    from casewatch.monitor.similarity import _stable_order

    k = np.array(keys, dtype=float)
    assert _stable_order(k).tolist() == np.argsort(k, kind="mergesort").tolist()
