"""Cross-channel similarity metrics (spi-reference: "Cross-channel metrics").

Pure functions on one channel pair; arrays in, numbers out. `None` means "no value".
inv(d) = 1 / (1 + d) throughout.

A pair's object similarities (pairing included), its ets and its crpps inputs are one compiled
kernel call each (`monitor.jit`): with a handful of objects and 30-50-point plans, the numpy
formulation spent its time in the fixed cost of many tiny array calls. The tests keep plain
references to compare the kernels with.

The similarity family does not call them one by one: `PairTracker` runs a pair's whole tick
(coverage, pairing, lone ages, scores, ets, plan_lat, the ELS window) in one call of
`_pair_tick`, which calls the same kernels in the same order, its history kept in arrays
(issue 36: the Python glue around a dozen kernel calls per pair and tick was most of the
family's time). The per-call functions stay: they define the values (the tick is held to them,
bit for bit, in tests/monitor/test_similarity_fast.py) and other modules call them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import cast

import numpy as np

from casewatch.monitor.frames import ChannelState, Objects
from casewatch.monitor.frechet import frechet_distance
from casewatch.monitor.history import crpps_path
from casewatch.monitor.jit import kernel
from casewatch.safety_case.model import MetricParams

#: Pairing distance resolution [m]: closer distances are ties.
PAIRING_EPS = 1e-9

#: Resolution [m] of the coverage edge tests (`monitor.coverage`): a point on an edge is inside
#: whatever the rounding of arctan2 and sin in the numpy build at hand (one build put a point on
#: the edge ray 4e-15 m outside it).
EDGE_EPS = 1e-9


def angdiff(a: float, b: float) -> float:
    """Absolute heading difference wrapped into [0, pi].

    Python's float `%` takes the sign of the divisor, exactly like `np.remainder`.
    """
    d = abs((a - b) % (2 * math.pi))
    return min(d, 2 * math.pi - d)


@kernel
def _stable_order(key: np.ndarray) -> np.ndarray:
    """Indices sorting `key` ascending, equal keys in index order (bottom-up merge sort).

    Written out because numba's `np.argsort(kind="mergesort")` takes seconds to compile.
    """
    n = key.shape[0]
    order = np.arange(n)
    buf = np.empty(n, dtype=np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i, j = lo, mid
            for k in range(lo, hi):
                # take from the right run only when strictly smaller: stability
                if j < hi and (i >= mid or key[order[j]] < key[order[i]]):
                    buf[k] = order[j]
                    j += 1
                else:
                    buf[k] = order[i]
                    i += 1
        order, buf = buf, order
        width *= 2
    return order


@kernel
def _pair_kernel(
    pos_a: np.ndarray, pos_b: np.ndarray, gate: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Greedy global nearest matching in machine code (see `pair_objects`)."""
    na, nb = pos_a.shape[0], pos_b.shape[0]
    reach = gate + PAIRING_EPS
    # Squared distances above this are beyond the gate whatever sqrt's rounding (a margin of
    # 1e-12, thousands of roundings): the row's squared distances in one vectorised pass, and
    # sqrt and the exact test below only for the few within it (issue 36: the reference load's
    # 40 x 40 objects). Far from the normal range (a gate whose square under- or overflows) no
    # pair is left out before the exact test.
    prefilter = reach * reach * (1.0 + 1e-12) if 1e-100 < reach < 1e100 else np.inf
    dist = np.empty(na * nb)
    cand_a = np.empty(na * nb, dtype=np.int64)
    cand_b = np.empty(na * nb, dtype=np.int64)
    key = np.empty(na * nb)
    row = np.empty(nb)
    nc = 0
    for i in range(na):
        xa = pos_a[i, 0]
        ya = pos_a[i, 1]
        for j in range(nb):
            dx = xa - pos_b[j, 0]
            dy = ya - pos_b[j, 1]
            row[j] = dx * dx + dy * dy
        for j in range(nb):
            if row[j] > prefilter:
                continue  # (a NaN goes on, and fails the exact test as it always did)
            d = math.sqrt(row[j])
            # Decision: distances equal to within 1e-9 m are ties (broken by index), so that
            # float noise from a change of world frame cannot reorder the matching.
            if d <= reach:
                cand_a[nc] = i
                cand_b[nc] = j
                dist[nc] = d
                key[nc] = np.rint(d / PAIRING_EPS)
                nc += 1
    # candidates are generated in (index in A, index in B) order; a stable sort on the rounded
    # distance gives the (distance, index in A, index in B) order
    order = _stable_order(key[:nc])
    used_a = np.zeros(na, dtype=np.bool_)
    used_b = np.zeros(nb, dtype=np.bool_)
    m = min(na, nb)
    acc_a = np.empty(m, dtype=np.int64)
    acc_b = np.empty(m, dtype=np.int64)
    acc_d = np.empty(m)
    k = 0
    for c in order:
        i, j = cand_a[c], cand_b[c]
        if not used_a[i] and not used_b[j]:
            used_a[i] = True
            used_b[j] = True
            acc_a[k] = i
            acc_b[k] = j
            acc_d[k] = dist[c]
            k += 1
    return acc_a[:k], acc_b[:k], acc_d[:k]


@kernel
def _follow_lone(  # pragma: no cover - compiled
    t, pos, vel, lone, mem_pos, mem_vel, mem_age, mem_seen, gate, max_gap
):
    """`monitor.lone.LoneAges.update`'s general case in one call (here, beside the pairing
    kernel it calls: a kernel calls only kernels of its own module). Returns the new memory
    (pos, vel, age, seen: the unpaired objects now, then the remembered ones kept) and the
    ages of the unpaired objects now, in index order; the same arithmetic as the numpy
    formulation it replaced."""
    n = pos.shape[0]
    m = mem_pos.shape[0]
    age = np.zeros(n)
    keep = np.zeros(m, dtype=np.bool_)
    if m > 0:
        recent = np.empty(m, dtype=np.bool_)
        n_recent = 0
        for i in range(m):
            recent[i] = t - mem_seen[i] <= max_gap + 1e-9
            if recent[i]:
                n_recent += 1
        found = np.zeros(m, dtype=np.bool_)
        if n > 0 and n_recent > 0:
            idx = np.empty(n_recent, dtype=np.int64)
            moved = np.empty((n_recent, 2))
            r = 0
            for i in range(m):
                if recent[i]:
                    idx[r] = i
                    r += 1
            for r in range(n_recent):
                i = idx[r]
                elapsed = t - mem_seen[i]
                moved[r, 0] = mem_pos[i, 0] + mem_vel[i, 0] * elapsed
                moved[r, 1] = mem_pos[i, 1] + mem_vel[i, 1] * elapsed
            prev, cur, _ = _pair_kernel(moved, pos, gate)
            for r in range(prev.shape[0]):
                i = idx[prev[r]]
                found[i] = True
                c = cur[r]
                if lone[c]:
                    age[c] = mem_age[i] + (t - mem_seen[i])
        # not reported now: remembered until max_gap has passed since last seen
        for i in range(m):
            keep[i] = recent[i] and not found[i] and t - mem_seen[i] < max_gap - 1e-9
    n_lone = 0
    for i in range(n):
        if lone[i]:
            n_lone += 1
    n_keep = 0
    for i in range(m):
        if keep[i]:
            n_keep += 1
    new_pos = np.empty((n_lone + n_keep, 2))
    new_vel = np.empty((n_lone + n_keep, 2))
    new_age = np.empty(n_lone + n_keep)
    new_seen = np.empty(n_lone + n_keep)
    ages = np.empty(n_lone)
    j = 0
    for i in range(n):
        if lone[i]:
            new_pos[j, 0] = pos[i, 0]
            new_pos[j, 1] = pos[i, 1]
            new_vel[j, 0] = vel[i, 0]
            new_vel[j, 1] = vel[i, 1]
            new_age[j] = age[i]
            new_seen[j] = t
            ages[j] = age[i]
            j += 1
    for i in range(m):
        if keep[i]:
            new_pos[j, 0] = mem_pos[i, 0]
            new_pos[j, 1] = mem_pos[i, 1]
            new_vel[j, 0] = mem_vel[i, 0]
            new_vel[j, 1] = mem_vel[i, 1]
            new_age[j] = mem_age[i]
            new_seen[j] = mem_seen[i]
            j += 1
    return new_pos, new_vel, new_age, new_seen, ages


def follow_lone(
    t: float,
    pos: np.ndarray,
    vel: np.ndarray,
    lone: np.ndarray,
    memory: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    gate: float,
    max_gap: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """`_follow_lone` on float (K, 2) positions and velocities, bool flags `lone` and the
    memory (pos, vel, age, seen) of `monitor.lone.LoneAges`."""
    return _follow_lone(
        float(t),
        pos,
        vel,
        lone,
        *memory,
        float(gate),
        float(max_gap),
    )


def pair_objects(
    pos_a: np.ndarray, pos_b: np.ndarray, gate: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Greedy global nearest matching (spi-reference "Object pairing").

    Returns (index in A, index in B, centre distance) of the accepted pairs, in acceptance
    order. Ties break by (distance, index in A, index in B), distances within 1e-9 m being
    ties.
    """
    return _pair_kernel(pos_a, pos_b, float(gate))


@kernel
def _area(half: np.ndarray, footprints: np.ndarray, i: int) -> float:
    """Footprint area of object i: 4 * half length * half width for a box (as
    `Objects.areas`), else the absolute shoelace area of its polygon (padding vertices, repeats
    of the last one, add nothing)."""
    if not math.isnan(half[i, 0]):
        return 4.0 * half[i, 0] * half[i, 1]
    v = footprints.shape[1]
    s = 0.0
    for k in range(v):
        nxt = k + 1 if k + 1 < v else 0
        s += (
            footprints[i, k, 0] * footprints[i, nxt, 1]
            - footprints[i, nxt, 0] * footprints[i, k, 1]
        )
    return 0.5 * abs(s)


@kernel
def _object_kernel(
    pos_a: np.ndarray,
    yaw_a: np.ndarray,
    half_a: np.ndarray,
    foot_a: np.ndarray,
    pred_a: np.ndarray,
    len_a: np.ndarray,
    pos_b: np.ndarray,
    yaw_b: np.ndarray,
    half_b: np.ndarray,
    foot_b: np.ndarray,
    pred_b: np.ndarray,
    len_b: np.ndarray,
    gate: float,
    w: np.ndarray,
    core_a: np.ndarray,
    core_b: np.ndarray,
    standing: float,
    range_a: np.ndarray,
    range_b: np.ndarray,
    range_scale: float,
    time_scale: float,
) -> tuple[float, float, float, float, int, int, np.ndarray, np.ndarray]:
    """(ols, oos, oas, ots) summed over the counted pairs of two object sets, the number of
    counted pairs, the number of them ots counts, and the flags of the unpaired core objects
    of A and of B. With `standing` > 0 a pair whose two predicted motions both end within
    `standing` metres of their objects is left out of ots (spi-reference "Standing objects").
    With `range_scale` > 0 a pair's centre distance is divided by 1 + r / range_scale (r the
    mean of the two objects' ranges `range_a`, `range_b` from their egos), with `time_scale`
    > 0 each ots point's distance by 1 + dt / time_scale (spi-reference "Tolerances that grow
    with range and look-ahead").

    A pair counts when either of its objects is core, an unpaired object when it is core
    (`monitor.coverage.common_view`; without coverage every object is core).

    Each object's prediction is its first `len` points of `pred[:, :, 1:3]`, on the canonical
    time grid (`monitor.resample`); no prediction (length 0, or no prediction columns at all)
    is the object staying at its current position. A pair compares its predictions over the
    horizon both cover (spi-reference "ots": a shorter horizon is not a disagreement); an
    object without prediction stays put over the other's whole horizon. `w` holds the weights
    k^(n-1), at least as many as the longest prediction.
    """
    ia, ib, dist = _pair_kernel(pos_a, pos_b, gate)
    paired_a = np.zeros(pos_a.shape[0], dtype=np.bool_)
    paired_b = np.zeros(pos_b.shape[0], dtype=np.bool_)
    n = 0
    n_ots = 0
    ols = 0.0
    oos = 0.0
    oas = 0.0
    ots = 0.0
    two_pi = 2 * math.pi
    cols_a, cols_b = pred_a.shape[1], pred_b.shape[1]
    for k in range(ia.shape[0]):
        i, j = ia[k], ib[k]
        paired_a[i] = True
        paired_b[j] = True
        if not (core_a[i] or core_b[j]):
            continue
        n += 1
        d_pair = dist[k]
        if range_scale > 0.0:
            d_pair = d_pair / (1.0 + 0.5 * (range_a[i] + range_b[j]) / range_scale)
        ols += 1.0 / (1.0 + d_pair)
        d = abs((yaw_a[i] - yaw_b[j]) % two_pi)
        oos += 1.0 - min(d, two_pi - d) / math.pi
        # the areas are computed here, not by `Objects.areas`: only this metric reads them
        area_a = _area(half_a, foot_a, i)
        area_b = _area(half_b, foot_b, j)
        hi = max(area_a, area_b)
        lo = min(area_a, area_b)
        # spi-reference: a pair of zero-area footprints scores 1.0.
        oas += lo / hi if hi > 0 else 1.0
        la = len_a[i] if cols_a > 0 else 0
        lb = len_b[j] if cols_b > 0 else 0
        # common horizon when both predict; a staying object is compared over the other's
        length = min(la, lb) if la > 0 and lb > 0 else max(la, lb, 1)
        num = 0.0
        den = 0.0
        moving = standing <= 0.0
        for p in range(length):
            # spi-reference "ots" Decision: predicted motion, each prediction relative to its
            # own object's position (where the objects are is ols's question)
            xa = ya = xb = yb = 0.0
            t_p = 0.0  # the point's time: A's when it predicts, else B's
            if lb > 0:
                q = min(p, lb - 1)
                xb, yb = pred_b[j, q, 1] - pos_b[j, 0], pred_b[j, q, 2] - pos_b[j, 1]
                t_p = pred_b[j, q, 0]
            if la > 0:
                q = min(p, la - 1)
                xa, ya = pred_a[i, q, 1] - pos_a[i, 0], pred_a[i, q, 2] - pos_a[i, 1]
                t_p = pred_a[i, q, 0]
            gap = math.hypot(xa - xb, ya - yb)
            if time_scale > 0.0:
                gap = gap / (1.0 + t_p / time_scale)
            num += w[p] * (1.0 / (1.0 + gap))
            den += w[p]
            # (the two motions' lengths only matter while the pair still counts as standing)
            if (
                p == length - 1
                and not moving
                and (math.hypot(xa, ya) > standing or math.hypot(xb, yb) > standing)
            ):
                moving = True
        if moving:
            ots += num / den
            n_ots += 1
    lone_a = core_a[: pos_a.shape[0]] & ~paired_a
    lone_b = core_b[: pos_b.shape[0]] & ~paired_b
    return ols, oos, oas, ots, n, n_ots, lone_a, lone_b


@lru_cache(maxsize=64)
def _weights(decay: float, n: int) -> np.ndarray:
    """w_n = k^(n-1), n = 1 .. N (read-only: cached and shared)."""
    w = decay ** np.arange(n, dtype=float)
    w.flags.writeable = False
    return w


#: Shared all-True flags (never written: writable only so the kernel sees one array type).
_ALL_CORE = np.ones(256, dtype=np.bool_)


def _all_core(n: int) -> np.ndarray:
    """n True flags (a view of a shared array: no allocation per frame)."""
    return _ALL_CORE[:n] if n <= len(_ALL_CORE) else np.ones(n, dtype=np.bool_)


@dataclass(frozen=True)
class ObjectComparison:
    """One channel pair's objects compared at one tick (`compare_objects`): the similarity sums
    over the counted pairs, their number, and which core objects of each side found no
    partner (`lone_a`, `lone_b`: flags over the compared objects of A and of B)."""

    sums: tuple[float, float, float, float]  # ols, oos, oas, ots
    pairs: int
    lone_a: np.ndarray
    lone_b: np.ndarray
    ots_pairs: int  # the pairs ots counts (`pairs` less the standing ones)

    def scores(self, keep_a: np.ndarray, keep_b: np.ndarray) -> dict[str, float]:
        """ocs, ols, oos, oas, ots, with every unpaired core object counted (spi-reference
        "Unpaired objects"). `keep_a` / `keep_b` hold, per unpaired object of each side in
        index order, the share in [0, 1] of the benefit of the doubt it still has: 1 when it
        was first seen unpaired (it scores what the pairs score on average, 1.0 without pairs:
        neutral), 0 once unpaired for `lone_horizon` (it scores 0: a full disagreement about
        whether anything is there). The metric is the mean over pairs and unpaired objects."""
        n_lone_a = int(np.count_nonzero(self.lone_a)) if len(self.lone_a) else 0
        n_lone_b = int(np.count_nonzero(self.lone_b)) if len(self.lone_b) else 0
        # np.sum of an empty array is 0.0: skip the call on the common tick
        keep = (float(np.sum(keep_a)) if len(keep_a) else 0.0) + (
            float(np.sum(keep_b)) if len(keep_b) else 0.0
        )
        lone = n_lone_a + n_lone_b
        out = {"ocs": 1.0 / (1.0 + abs(n_lone_a - n_lone_b))}
        counts = (self.pairs, self.pairs, self.pairs, self.ots_pairs)
        for name, total, pairs in zip(("ols", "oos", "oas", "ots"), self.sums, counts, strict=True):
            mean = total / pairs if pairs else 1.0
            # spi-reference: 1.0 when nothing both channels can compare is there
            out[name] = (total + keep * mean) / (pairs + lone) if pairs + lone else 1.0
        return out


def compare_objects(
    a: Objects,
    b: Objects,
    gate: float,
    decay: float,
    core_a: np.ndarray | None = None,
    core_b: np.ndarray | None = None,
    standing: float = 0.0,
    range_a: np.ndarray | None = None,
    range_b: np.ndarray | None = None,
    range_scale: float = 0.0,
    time_scale: float = 0.0,
) -> ObjectComparison:
    """Pair two channels' objects and sum their similarities (one kernel call).

    `core_a` / `core_b` flag the objects well inside both channels' coverage
    (`monitor.coverage.common_view`); None: every object is core. `range_a` / `range_b`: each
    object's distance from its own channel's ego (needed with `range_scale` > 0).
    """
    all_a = _all_core(len(a)) if core_a is None else core_a
    all_b = _all_core(len(b)) if core_b is None else core_b
    if len(a) == 0 and len(b) == 0:
        return ObjectComparison((0.0, 0.0, 0.0, 0.0), 0, np.zeros(0, bool), np.zeros(0, bool), 0)
    w = _weights(decay, max(a.pred.shape[1], b.pred.shape[1], 1))
    ols, oos, oas, ots, n, n_ots, lone_a, lone_b = _object_kernel(
        a.pos,
        a.yaw,
        a.half,
        a.footprints,
        a.pred,
        a.pred_len,
        b.pos,
        b.yaw,
        b.half,
        b.footprints,
        b.pred,
        b.pred_len,
        float(gate),
        w,
        all_a,
        all_b,
        float(standing),
        np.zeros(len(a)) if range_a is None else range_a,
        np.zeros(len(b)) if range_b is None else range_b,
        float(range_scale),
        float(time_scale),
    )
    return ObjectComparison((ols, oos, oas, ots), int(n), lone_a, lone_b, int(n_ots))


def object_similarities(
    a: Objects,
    b: Objects,
    gate: float,
    decay: float,
    core_a: np.ndarray | None = None,
    core_b: np.ndarray | None = None,
    keep: float = 0.0,
    standing: float = 0.0,
) -> dict[str, float]:
    """ocs, ols, oos, oas, ots of one tick on its own, every unpaired core object keeping
    `keep` of the benefit of the doubt (`ObjectComparison.scores`; the monitor sets it per
    object from how long it has been unpaired, `monitor.lone`). 0.0, the default, is the
    study's reading: a disagreement about whether anything is there is the least similar
    outcome."""
    cmp = compare_objects(a, b, gate, decay, core_a, core_b, standing)
    return cmp.scores(np.full(int(cmp.lone_a.sum()), keep), np.full(int(cmp.lone_b.sum()), keep))


@kernel
def _ranges(pos, x, y):  # pragma: no cover - compiled
    """np.hypot(pos[:, 0] - x, pos[:, 1] - y): each object's distance from its ego."""
    out = np.empty(pos.shape[0])
    for i in range(pos.shape[0]):
        out[i] = np.hypot(pos[i, 0] - x, pos[i, 1] - y)
    return out


def ranges_from(pos: np.ndarray, x: float, y: float) -> np.ndarray:
    """Each object's range (K,) from the ego at (x, y): `np.hypot`'s values in one compiled
    call (the range-scaled tolerances of ols read them every tick)."""
    return _ranges(pos, float(x), float(y))


def ego_pair(a: ChannelState, b: ChannelState) -> tuple[float, float, float, float]:
    """(els, eos, ego_dist, ego_yaw_diff) as a tuple: `ego_similarities` without its dict,
    for the engine's per-tick loop."""
    d = math.hypot(a.ego.x - b.ego.x, a.ego.y - b.ego.y)
    yaw = angdiff(a.ego.yaw, b.ego.yaw)
    return 1.0 / (1.0 + d), 1.0 - yaw / math.pi, d, yaw


def ego_similarities(a: ChannelState, b: ChannelState) -> dict[str, float]:
    """els and eos, and the distance and heading difference they are made from (ego_dist,
    ego_yaw_diff: spi-reference "Situation signals")."""
    els, eos, d, yaw = ego_pair(a, b)
    return {"els": els, "eos": eos, "ego_dist": d, "ego_yaw_diff": yaw}


def common_range(plan_a: np.ndarray, plan_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points of two plans on the same time grid (`monitor.resample`) inside the time
    range both cover: equal-length slices whose rows have equal `dt`."""
    lo = max(plan_a[0, 0], plan_b[0, 0]) - 1e-9
    hi = min(plan_a[-1, 0], plan_b[-1, 0]) + 1e-9
    ta, tb = plan_a[:, 0], plan_b[:, 0]
    a = plan_a[np.searchsorted(ta, lo) : np.searchsorted(ta, hi, side="right")]
    b = plan_b[np.searchsorted(tb, lo) : np.searchsorted(tb, hi, side="right")]
    return a, b


def ets(
    plan_a: np.ndarray,
    plan_b: np.ndarray,
    decay: float,
    shift: tuple[float, float] | None = None,
) -> float | None:
    """Weighted point-wise similarity of two plans on the canonical time grid over the time
    range both cover (spi-reference "ets"); None if a plan is empty or the ranges do not
    overlap."""
    if len(plan_a) == 0 or len(plan_b) == 0:
        return None
    a0, b0, n = _common_start(plan_a, plan_b)
    if n == 0:
        return None
    # spi-reference "ets" Decision (ets_relative): plan B moved by ego A minus ego B
    sx, sy = (0.0, 0.0) if shift is None else shift
    return _ets_at(plan_a, plan_b, a0, b0, _weights(decay, n), sx, sy, shift is not None)


@kernel
def _common_start(plan_a, plan_b):  # pragma: no cover - compiled
    """`common_range` as indices: (first row of A, first row of B, number of rows both
    slices hold, the shorter one's)."""
    lo = max(plan_a[0, 0], plan_b[0, 0]) - 1e-9
    hi = min(plan_a[-1, 0], plan_b[-1, 0]) + 1e-9
    a0 = np.searchsorted(plan_a[:, 0], lo)
    a1 = np.searchsorted(plan_a[:, 0], hi, side="right")
    b0 = np.searchsorted(plan_b[:, 0], lo)
    b1 = np.searchsorted(plan_b[:, 0], hi, side="right")
    return a0, b0, max(min(a1 - a0, b1 - b0), 0)


@kernel
def _ets_at(plan_a, plan_b, a0, b0, w, shift_x, shift_y, shifted):  # pragma: no cover
    """`_ets_kernel` on the rows from a0 of A and b0 of B, B moved by (shift_x, shift_y) when
    `shifted` (the same additions as moving a copy of B first)."""
    num = 0.0
    den = 0.0
    for p in range(w.shape[0]):
        bx = plan_b[b0 + p, 1]
        by = plan_b[b0 + p, 2]
        if shifted:
            bx = bx + shift_x
            by = by + shift_y
        d = math.hypot(plan_a[a0 + p, 1] - bx, plan_a[a0 + p, 2] - by)
        num += w[p] * (1.0 / (1.0 + d))
        den += w[p]
    return num / den


def frechet(p: np.ndarray, q: np.ndarray) -> float:
    """Discrete Fréchet distance of two (n, 2) point sequences (`monitor.frechet`, the source's
    definition; spi-reference "Discrete Fréchet distance").

    A one-point sequence is no polyline; its discrete Fréchet distance to Q is the largest
    distance from that point to a point of Q, computed directly (with `hypot`, as the engine's
    batch does).
    """
    if len(p) == 1 or len(q) == 1:
        one, other = (p, q) if len(p) == 1 else (q, p)
        return float(np.max(np.hypot(*(other - one[0]).T)))
    return frechet_distance(p, q)


def crpps_inputs(plan_a: np.ndarray, plan_b: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The two point sequences whose Fréchet distance is `crpps_distance` (None if a plan is
    empty): the engine batches them with the chpps inputs into one Fréchet call."""
    if len(plan_a) == 0 or len(plan_b) == 0:
        return None
    out, n = crpps_path(plan_a, plan_b)
    if n == 0:
        return None  # the plans cover no common time: nothing to compare, no value
    return out[:n], out[n:]


def crpps_distance(plan_a: np.ndarray, plan_b: np.ndarray) -> float | None:
    """fd(plan_A, plan_B') with plan B translated so its first point is plan A's first point,
    both plans cut to their common horizon and compared as paths (`common_path`: resampled by
    arc length over the length both cover; a channel planning the same path a little faster
    is not a different shape, which `ets` measures).

    Decision: the study's channels plan over different horizons (e.g. 5 s and 3 s). Compared
    whole, the extra seconds of the longer plan alone set the Frechet distance (tens of metres
    at road speed), so crpps would sit near 0 however well the channels agree. Like `ets`,
    which the study truncates to the shorter plan, crpps compares the points with
    `dt <= min(horizon_A, horizon_B)`.
    """
    inputs = crpps_inputs(plan_a, plan_b)
    return None if inputs is None else frechet(*inputs)


def plan_lateral(
    plan_a: np.ndarray,
    plan_b: np.ndarray,
    shift: tuple[float, float],
    yaws: tuple[float, float],
    horizon: float,
) -> float | None:
    """plan_lat (spi-reference): the largest sideways distance between the two plans at equal
    times over their first `horizon` seconds, plan B moved by `shift` (ego A minus ego B, so a
    disagreement about where the ego is, which els judges, is not a planning one). Sideways is
    across the two plans' mean direction at each point (the mean of the egos' headings `yaws`
    where both plans stand still), so the value does not depend on the channel order. None
    when a plan is empty or the plans share no time in the horizon.

    crpps and chpps move one plan onto the other's start before comparing shapes, so a plan
    displaced whole to one side (a planner on the wrong lane, a lateral offset in its output)
    reads as the same shape; this is the signal that sees it."""
    if len(plan_a) == 0 or len(plan_b) == 0:
        return None
    fall_x = math.cos(yaws[0]) + math.cos(yaws[1])
    fall_y = math.sin(yaws[0]) + math.sin(yaws[1])
    norm = max(float(np.hypot(fall_x, fall_y)), 1e-12)
    value = _plan_lateral_kernel(
        plan_a, plan_b, shift[0], shift[1], fall_x / norm, fall_y / norm, horizon
    )
    return None if math.isnan(value) else value


@kernel
def _plan_lateral_kernel(plan_a, plan_b, shift_x, shift_y, fall_x, fall_y, horizon):
    """`plan_lateral` on non-empty plans in one compiled pass (NaN: no common time). The
    tangents are `np.gradient`'s (one-sided at the ends, central inside: (f[i+1] - f[i-1]) /
    2), so each value is the numpy formulation's, bit for bit (the tests hold it to it)."""
    lo = max(plan_a[0, 0], plan_b[0, 0]) - 1e-9
    hi = min(plan_a[-1, 0], plan_b[-1, 0]) + 1e-9
    a0 = np.searchsorted(plan_a[:, 0], lo)
    a1 = np.searchsorted(plan_a[:, 0], hi, side="right")
    b0 = np.searchsorted(plan_b[:, 0], lo)
    b1 = np.searchsorted(plan_b[:, 0], hi, side="right")
    n = 0
    for i in range(a0, a1):
        if plan_a[i, 0] <= horizon + 1e-9:
            n += 1
    n = min(n, b1 - b0)
    if n <= 0:
        return np.nan
    pa = plan_a[a0 : a0 + n, 1:3]
    pb = np.empty((n, 2))
    for i in range(n):
        pb[i, 0] = plan_b[b0 + i, 1] + shift_x
        pb[i, 1] = plan_b[b0 + i, 2] + shift_y
    dx = np.zeros(n)
    dy = np.zeros(n)
    if n > 1:
        for side in range(2):
            p = pa if side == 0 else pb
            for i in range(n):
                if i == 0:
                    tx = p[1, 0] - p[0, 0]
                    ty = p[1, 1] - p[0, 1]
                elif i == n - 1:
                    tx = p[n - 1, 0] - p[n - 2, 0]
                    ty = p[n - 1, 1] - p[n - 2, 1]
                else:
                    tx = (p[i + 1, 0] - p[i - 1, 0]) / 2.0
                    ty = (p[i + 1, 1] - p[i - 1, 1]) / 2.0
                norm = np.hypot(tx, ty)
                scale = norm if norm > 1e-3 else np.inf
                dx[i] += tx / scale
                dy[i] += ty / scale
    worst = -np.inf
    for i in range(n):
        norm = np.hypot(dx[i], dy[i])
        if norm > 1e-3:
            ux = dx[i] / norm
            uy = dy[i] / norm
        else:
            ux = fall_x
            uy = fall_y
        d = abs((pb[i, 1] - pa[i, 1]) * ux - (pb[i, 0] - pa[i, 0]) * uy)
        if d > worst:
            worst = d
    return worst


# --- coverage (monitor.coverage's compiled pass, here beside `_pair_tick`, which calls it) ---


@kernel
def coverage_flags(pos, views):  # pragma: no cover - compiled
    """`monitor.coverage.inside` of every view for the outer (margin -m) and the core (margin
    m) test at once.

    views (V, 7): ego x, y, yaw, then range_m + m + EDGE_EPS, range_m - m + EDGE_EPS, half
    the field of view in radians (inf: all-round in angle), m. The thresholds are computed by
    the caller in `inside`'s own order of operations, so each flag is `inside`'s, bit for bit.
    Returns (outer, core), each (K,) bool, and the number of outer flags set."""
    k = pos.shape[0]
    outer = np.ones(k, dtype=np.bool_)
    core = np.ones(k, dtype=np.bool_)
    for v in range(views.shape[0]):
        ex, ey, yaw = views[v, 0], views[v, 1], views[v, 2]
        reach_out, reach_core, half_fov, m = views[v, 3], views[v, 4], views[v, 5], views[v, 6]
        for i in range(k):
            rx = pos[i, 0] - ex
            ry = pos[i, 1] - ey
            r = np.hypot(rx, ry)
            keep_out = r <= reach_out
            keep_core = r <= reach_core
            if half_fov != np.inf:
                bearing = np.arctan2(ry, rx) - yaw
                bearing = np.abs((bearing + np.pi) % (2.0 * np.pi) - np.pi)
                to_edge = min(max(half_fov - bearing, -np.pi / 2), np.pi / 2)
                side = r * np.sin(to_edge)
                keep_out = keep_out and side >= -m - EDGE_EPS
                keep_core = keep_core and side >= m - EDGE_EPS
            outer[i] = outer[i] and keep_out
            core[i] = core[i] and keep_core
    kept = 0
    for i in range(k):
        if outer[i]:
            kept += 1
    return outer, core, kept


# --- a channel pair's whole tick in one call (the similarity family's per-tick work) ---


@kernel
def _compared(pos, views):  # pragma: no cover - compiled
    """`monitor.coverage.common_view` of one side as rows: the rows of the objects it compares
    (inside every view grown by the margin), in order, and their core flags (inside every view
    shrunk by it). No views (both coverages all-round) or no objects: every row, all core."""
    k = pos.shape[0]
    if views.shape[0] == 0 or k == 0:
        return np.arange(k), np.ones(k, dtype=np.bool_)
    outer, core, kept = coverage_flags(pos, views)
    rows = np.empty(kept, dtype=np.int64)
    flags = np.empty(kept, dtype=np.bool_)
    j = 0
    for i in range(k):
        if outer[i]:
            rows[j] = i
            flags[j] = core[i]
            j += 1
    return rows, flags


@kernel
def _pairwise_block(x, lo, n):  # pragma: no cover - compiled
    """numpy's pairwise summation of a block of at most 128 values x[lo : lo + n]
    (`DOUBLE_pairwise_sum`'s leaves): one running sum from -0.0 below 8 values, else 8
    accumulators added pairwise, then the rest one by one."""
    if n < 8:
        res = -0.0
        for i in range(lo, lo + n):
            res += x[i]
        return res
    r0, r1, r2, r3 = x[lo], x[lo + 1], x[lo + 2], x[lo + 3]
    r4, r5, r6, r7 = x[lo + 4], x[lo + 5], x[lo + 6], x[lo + 7]
    i = 8
    stop = n - n % 8
    while i < stop:
        r0 += x[lo + i]
        r1 += x[lo + i + 1]
        r2 += x[lo + i + 2]
        r3 += x[lo + i + 3]
        r4 += x[lo + i + 4]
        r5 += x[lo + i + 5]
        r6 += x[lo + i + 6]
        r7 += x[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += x[lo + i]
        i += 1
    return res


@kernel
def _pairwise_sum(x):  # pragma: no cover - compiled
    """numpy's pairwise summation of x (`DOUBLE_pairwise_sum`: blocks of at most 128 values,
    a longer range split in two at a multiple of 8 near its middle, the halves' sums added),
    so that `0.0 + _pairwise_sum(x)` is `np.sum(x)` (the identity plus the pairwise sum), bit
    for bit: the tests hold it to np.sum. The recursion is unrolled onto a stack (numba's
    cache of a self-recursive kernel crashed on loading)."""
    n = x.shape[0]
    # frames (start, length, halves done), and the sums of finished halves (every call to the
    # block takes variables, not a literal 0: numba would compile a variant per literal)
    lo = np.empty(64, dtype=np.int64)
    size = np.empty(64, dtype=np.int64)
    done = np.empty(64, dtype=np.int64)
    sums = np.empty(64)
    top = 0
    lo[0], size[0], done[0] = 0, n, 0
    nsum = 0
    while top >= 0:
        m = size[top]
        if m <= 128:
            sums[nsum] = _pairwise_block(x, lo[top], m)
            nsum += 1
            top -= 1
            continue
        half = m // 2
        half -= half % 8
        if done[top] == 0:
            done[top] = 1
            lo[top + 1], size[top + 1], done[top + 1] = lo[top], half, 0
            top += 1
        elif done[top] == 1:
            done[top] = 2
            lo[top + 1], size[top + 1], done[top + 1] = lo[top] + half, m - half, 0
            top += 1
        else:
            sums[nsum - 2] = sums[nsum - 2] + sums[nsum - 1]
            nsum -= 1
            top -= 1
    return sums[0]


@kernel
def _doubt_sum(age, horizon):  # pragma: no cover - compiled
    """float(np.sum(monitor.lone.benefit_of_doubt(age, horizon))) for a non-empty `age`: each
    share np.clip(1 - age / horizon, 0, 1) (numpy's clip: max with 0 then min with 1, a NaN
    kept), summed as np.sum does."""
    n = age.shape[0]
    keep = np.empty(n)
    for i in range(n):
        v = 1.0 - age[i] / horizon
        if not math.isnan(v):
            v = v if v > 0.0 else 0.0
            v = v if v < 1.0 else 1.0
        keep[i] = v
    return 0.0 + _pairwise_sum(keep)


@kernel
def _lone_step(  # pragma: no cover - compiled
    t, pos, vel, lone, side, counts, mem_pos, mem_vel, mem_age, mem_seen, gate, max_gap
):
    """`monitor.lone.LoneAges.update` of one side (0: A, 1: B) on its memory kept in the
    tracker's arrays: rows :counts[2 + side] of mem_*[side] are the remembered objects (the
    caller has checked that the new memory fits). Returns the ages of the unpaired objects."""
    m = counts[2 + side]
    if m == 0:
        n_lone = 0
        for i in range(lone.shape[0]):
            if lone[i]:
                n_lone += 1
        if n_lone == 0:
            # the common tick (LoneAges.update's shortcut): nothing unpaired now and nothing
            # remembered, so nothing to follow and the empty memory stays empty
            return np.zeros(0)
    new_pos, new_vel, new_age, new_seen, ages = _follow_lone(
        t,
        pos,
        vel,
        lone,
        mem_pos[side, :m],
        mem_vel[side, :m],
        mem_age[side, :m],
        mem_seen[side, :m],
        gate,
        max_gap,
    )
    k = new_age.shape[0]
    for i in range(k):
        mem_pos[side, i, 0] = new_pos[i, 0]
        mem_pos[side, i, 1] = new_pos[i, 1]
        mem_vel[side, i, 0] = new_vel[i, 0]
        mem_vel[side, i, 1] = new_vel[i, 1]
        mem_age[side, i] = new_age[i]
        mem_seen[side, i] = new_seen[i]
    counts[2 + side] = k
    return ages


@kernel
def _take1(x, rows):  # pragma: no cover - compiled
    """x[rows] of a 1-d array (`Objects.subset`'s copy) as a plain loop: numba's fancy
    indexing generates its general code at every use, seconds of compiling in `_pair_tick`."""
    out = np.empty(rows.shape[0], dtype=x.dtype)
    for k in range(rows.shape[0]):
        out[k] = x[rows[k]]
    return out


@kernel
def _take2(x, rows):  # pragma: no cover - compiled
    """x[rows] of a 2-d array (see `_take1`)."""
    out = np.empty((rows.shape[0], x.shape[1]), dtype=x.dtype)
    for k in range(rows.shape[0]):
        for j in range(x.shape[1]):
            out[k, j] = x[rows[k], j]
    return out


@kernel
def _take3(x, rows):  # pragma: no cover - compiled
    """x[rows] of a 3-d array (see `_take1`)."""
    out = np.empty((rows.shape[0], x.shape[1], x.shape[2]), dtype=x.dtype)
    for k in range(rows.shape[0]):
        for j in range(x.shape[1]):
            for c in range(x.shape[2]):
                out[k, j, c] = x[rows[k], j, c]
    return out


@kernel
def _view_objects(pos, yaw, vel, half, foot, pred, lens, views):  # pragma: no cover - compiled
    """One side's `monitor.coverage._view_rows` on its arrays: the compared objects' pos,
    yaw, vel, half, footprints, pred, pred_len (`Objects.subset`'s rows, copied only when the
    coverage leaves some out) and their core flags."""
    rows, core = _compared(pos, views)
    whole = rows.shape[0] == pos.shape[0]
    return (
        pos if whole else _take2(pos, rows),
        yaw if whole else _take1(yaw, rows),
        vel if whole else _take2(vel, rows),
        half if whole else _take2(half, rows),
        foot if whole else _take3(foot, rows),
        pred if whole else _take3(pred, rows),
        lens if whole else _take1(lens, rows),
        core,
    )


#: Outputs of `_pair_tick` that can have no value (bit 1 << k of its return value set): ets
#: (an empty plan, no common time), plan_lat (the same), els_var (the window not yet full).
TICK_ETS = 10
TICK_PLAN_LAT = 11
TICK_ELS_VAR = 12
#: The number of `_pair_tick` outputs (`families.similarity.METRICS`, in that order).
TICK_OUTPUTS = 13


@kernel
def _pair_tick(  # pragma: no cover - compiled
    t,
    els,
    eos,
    ego_dist,
    ego_yaw_diff,
    ax,
    ay,
    ayaw,
    bx,
    by,
    byaw,
    pos_a,
    yaw_a,
    vel_a,
    half_a,
    foot_a,
    pred_a,
    len_a,
    plan_a,
    pos_b,
    yaw_b,
    vel_b,
    half_b,
    foot_b,
    pred_b,
    len_b,
    plan_b,
    prm,
    views,
    w,
    counts,
    els_hist,
    mem_pos,
    mem_vel,
    mem_age,
    mem_seen,
    out,
):
    """One channel pair's similarity tick (`PairTracker.step` says what goes in): the coverage
    filter, the object pairing and sums, both sides' lone ages, the object scores, ets,
    plan_lat and the ELS window, by the kernels the per-call functions of this module use, in
    their order of operations. Writes `out` (METRICS order, NaN where no value) and returns the
    bits of the outputs with no value, or -1, having changed nothing, when the memory or the
    weights are too short for this tick's objects and plans."""
    gate = prm[0]
    standing = prm[1]
    range_scale = prm[2]
    time_scale = prm[3]
    ets_relative = prm[4]
    lat_horizon = prm[5]
    lone_horizon = prm[6]
    max_gap = prm[7]
    cap = mem_age.shape[1]
    if pos_a.shape[0] + counts[2] > cap or pos_b.shape[0] + counts[3] > cap:
        return -1
    if w.shape[0] < max(plan_a.shape[0], plan_b.shape[0], pred_a.shape[1], pred_b.shape[1], 1):
        return -1
    # spi-reference "Channel coverage": the views of the coverages that are not all-round, each
    # seen from its own channel's ego (`monitor.coverage._rows`)
    nv = 0
    for s in range(2):
        if views[s, 0] > 0.0:
            nv += 1
    rows = np.empty((nv, 7))
    v = 0
    for s in range(2):
        if views[s, 0] > 0.0:
            rows[v, 0] = ax if s == 0 else bx
            rows[v, 1] = ay if s == 0 else by
            rows[v, 2] = ayaw if s == 0 else byaw
            for c in range(4):
                rows[v, 3 + c] = views[s, 1 + c]
            v += 1
    cpos_a, cyaw_a, cvel_a, chalf_a, cfoot_a, cpred_a, clen_a, core_a = _view_objects(
        pos_a, yaw_a, vel_a, half_a, foot_a, pred_a, len_a, rows
    )
    cpos_b, cyaw_b, cvel_b, chalf_b, cfoot_b, cpred_b, clen_b, core_b = _view_objects(
        pos_b, yaw_b, vel_b, half_b, foot_b, pred_b, len_b, rows
    )
    if range_scale > 0.0:
        range_a = _ranges(cpos_a, ax, ay)
        range_b = _ranges(cpos_b, bx, by)
    else:
        range_a = np.zeros(cpos_a.shape[0])
        range_b = np.zeros(cpos_b.shape[0])
    ols, oos, oas, ots, pairs, ots_pairs, lone_a, lone_b = _object_kernel(
        cpos_a,
        cyaw_a,
        chalf_a,
        cfoot_a,
        cpred_a,
        clen_a,
        cpos_b,
        cyaw_b,
        chalf_b,
        cfoot_b,
        cpred_b,
        clen_b,
        gate,
        w[: max(pred_a.shape[1], pred_b.shape[1], 1)],
        core_a,
        core_b,
        standing,
        range_a,
        range_b,
        range_scale,
        time_scale,
    )
    ages_a = np.zeros(0)
    ages_b = np.zeros(0)
    for side in range(2):  # a loop, not two calls with a literal side: one compiled variant
        ages = _lone_step(
            t,
            cpos_a if side == 0 else cpos_b,
            cvel_a if side == 0 else cvel_b,
            lone_a if side == 0 else lone_b,
            side,
            counts,
            mem_pos,
            mem_vel,
            mem_age,
            mem_seen,
            gate,
            max_gap,
        )
        if side == 0:
            ages_a = ages
        else:
            ages_b = ages
    # ObjectComparison.scores with monitor.lone.benefit_of_doubt's shares
    n_lone_a = ages_a.shape[0]
    n_lone_b = ages_b.shape[0]
    keep = (_doubt_sum(ages_a, lone_horizon) if n_lone_a else 0.0) + (
        _doubt_sum(ages_b, lone_horizon) if n_lone_b else 0.0
    )
    lone = n_lone_a + n_lone_b
    out[0] = els
    out[1] = eos
    out[2] = ego_dist
    out[3] = ego_yaw_diff
    out[4] = 1.0 / (1.0 + abs(n_lone_a - n_lone_b))
    for k in range(4):
        total = ols if k == 0 else oos if k == 1 else oas if k == 2 else ots
        n = pairs if k < 3 else ots_pairs
        mean = total / n if n else 1.0
        out[5 + k] = (total + keep * mean) / (n + lone) if n + lone else 1.0
    # lone_age: the oldest unpaired object of either side (ndarray.max(initial=0.0))
    top_a = 0.0
    for i in range(n_lone_a):
        if ages_a[i] > top_a or math.isnan(ages_a[i]):
            top_a = ages_a[i]
    top_b = 0.0
    for i in range(n_lone_b):
        if ages_b[i] > top_b or math.isnan(ages_b[i]):
            top_b = ages_b[i]
    out[9] = top_b if top_b > top_a else top_a
    none = 0
    # ets (`ets`): plan B moved by ego A minus ego B when ets_relative
    out[10] = np.nan
    none |= 1 << 10
    if plan_a.shape[0] > 0 and plan_b.shape[0] > 0:
        a0, b0, n = _common_start(plan_a, plan_b)
        if n > 0:
            shifted = ets_relative == 1.0
            sx = ax - bx if shifted else 0.0
            sy = ay - by if shifted else 0.0
            out[10] = _ets_at(plan_a, plan_b, a0, b0, w[:n], sx, sy, shifted)
            none &= ~(1 << 10)
    # plan_lat (`plan_lateral`)
    out[11] = np.nan
    none |= 1 << 11
    if plan_a.shape[0] > 0 and plan_b.shape[0] > 0:
        fall_x = math.cos(ayaw) + math.cos(byaw)
        fall_y = math.sin(ayaw) + math.sin(byaw)
        h = np.hypot(fall_x, fall_y)
        norm = 1e-12 if h < 1e-12 else h  # max(h, 1e-12)
        lat = _plan_lateral_kernel(
            plan_a, plan_b, ax - bx, ay - by, fall_x / norm, fall_y / norm, lat_horizon
        )
        if not math.isnan(lat):
            out[11] = lat
            none &= ~(1 << 11)
    # els_var: the ELS window (what a `TimedHistory` of els_window values held, the reference
    # in tests/monitor/reference_windows.py, restarting after a gap), els_hist[0] the time of
    # its newest value, els_hist[1:] a ring from counts[1]
    size = els_hist.shape[0] - 1
    count = counts[0]
    head = counts[1]
    if count > 0 and t - els_hist[0] > max_gap + 1e-9:
        count = 0
        head = 0
    els_hist[1 + head] = els
    head = head + 1 if head + 1 < size else 0
    if count < size:
        count += 1
    els_hist[0] = t
    counts[0] = count
    counts[1] = head
    out[12] = np.nan
    if count < size:
        none |= 1 << 12
    else:  # `history._sample_variance` of the window, oldest first
        total = 0.0
        for k in range(size):
            total += els_hist[1 + (head + k) % size]
        mean = total / size
        ss = 0.0
        for k in range(size):
            d = els_hist[1 + (head + k) % size] - mean
            ss += d * d
        out[12] = ss / (size - 1)
    return none


class PairTracker:
    """One channel pair's similarity history in arrays, and its whole tick in one compiled call
    (`_pair_tick`): the ELS window (`els`: the newest value's time, then a ring of els_window
    values; `counts[0:2]`: how many, where the next goes) and each side's unpaired-object
    memory (`mem_*[side, :counts[2 + side]]`, what `monitor.lone.LoneAges` keeps).

    Why: at a handful of objects per channel, the per-pair functions of this module (coverage,
    pairing, lone ages, scores, ets, plan_lat, the ELS variance) cost a dozen kernel calls, a
    subset of the objects and a dict of scores per pair and tick, most of the family's time in
    Python glue (issue 36). The tick's values are those functions', bit for bit
    (tests/monitor/test_similarity_fast.py holds them to each other).
    """

    def __init__(self, params: MetricParams, capacity: int = 16, width: int = 64):
        self.decay = params.trajectory_decay
        #: the kernel's scalar parameters (`_pair_tick` reads them by position)
        self.prm = np.array(
            [
                params.pairing_gate,
                params.standing_motion,
                params.ols_range_scale,
                params.ots_time_scale,
                float(params.ets_relative),
                params.plan_lat_horizon,
                params.lone_horizon,
                params.max_gap,
            ]
        )
        #: the pair's coverages (`monitor.coverage.pair_views`); default: both all-round
        self.views = np.zeros((2, 5))
        self.counts = np.zeros(4, dtype=np.int64)
        self.els = np.full(params.els_window + 1, np.nan)
        self.out = np.empty(TICK_OUTPUTS)
        self.mem_pos = np.zeros((2, 0, 2))
        self.mem_vel = np.zeros((2, 0, 2))
        self.mem_age = np.zeros((2, 0))
        self.mem_seen = np.zeros((2, 0))
        self.w = _weights(self.decay, 1)
        self._grow(capacity, width)

    def forget_objects(self) -> None:
        """Forget both sides' unpaired objects (a channel of the pair absent: `LoneAges.reset`).
        The ELS window stays; it restarts by itself after a gap."""
        self.counts[2] = 0
        self.counts[3] = 0

    def _grow(self, capacity: int, width: int) -> None:
        """Room for `capacity` remembered plus current objects per side (the memory kept) and
        weights for `width` points (`_weights`: the same values as the per-call functions',
        a longer vector's first n being `_weights(decay, n)`)."""
        old = self.mem_age.shape[1]
        if capacity > old:
            pos, vel = np.zeros((2, capacity, 2)), np.zeros((2, capacity, 2))
            age, seen = np.zeros((2, capacity)), np.zeros((2, capacity))
            pos[:, :old], vel[:, :old] = self.mem_pos, self.mem_vel
            age[:, :old], seen[:, :old] = self.mem_age, self.mem_seen
            self.mem_pos, self.mem_vel, self.mem_age, self.mem_seen = pos, vel, age, seen
        if width > len(self.w):
            self.w = _weights(self.decay, width)

    def step(self, t: float, a: ChannelState, b: ChannelState) -> list[float | None]:
        """The pair's values at `t` in `families.similarity.METRICS` order (None: no value),
        both channels present."""
        els, eos, dist, yaw = ego_pair(a, b)
        t = float(t)  # an int time (a frame built in memory) would compile another variant
        none = self._tick(t, els, eos, dist, yaw, a, b)
        if none < 0:  # more objects or longer plans than ever: grow, then the same call
            oa, ob, counts = a.objects, b.objects, self.counts
            need = max(len(oa) + int(counts[2]), len(ob) + int(counts[3]))
            width = max(len(a.plan), len(b.plan), oa.pred.shape[1], ob.pred.shape[1], 1)
            self._grow(max(2 * need, 16), max(2 * width, 64))
            none = self._tick(t, els, eos, dist, yaw, a, b)
        values = cast("list[float | None]", self.out.tolist())
        if none:
            for k in (TICK_ETS, TICK_PLAN_LAT, TICK_ELS_VAR):
                if none >> k & 1:
                    values[k] = None
        return values

    def _tick(
        self,
        t: float,
        els: float,
        eos: float,
        dist: float,
        yaw: float,
        a: ChannelState,
        b: ChannelState,
    ) -> int:
        ea, eb, oa, ob = a.ego, b.ego, a.objects, b.objects
        return int(
            _pair_tick(
                t,
                els,
                eos,
                dist,
                yaw,
                ea.x,
                ea.y,
                ea.yaw,
                eb.x,
                eb.y,
                eb.yaw,
                oa.pos,
                oa.yaw,
                oa.vel,
                oa.half,
                oa.footprints,
                oa.pred,
                oa.pred_len,
                a.plan,
                ob.pos,
                ob.yaw,
                ob.vel,
                ob.half,
                ob.footprints,
                ob.pred,
                ob.pred_len,
                b.plan,
                self.prm,
                self.views,
                self.w,
                self.counts,
                self.els,
                self.mem_pos,
                self.mem_vel,
                self.mem_age,
                self.mem_seen,
                self.out,
            )
        )
