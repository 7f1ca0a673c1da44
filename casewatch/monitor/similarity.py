"""Cross-channel similarity metrics (spi-reference: "Cross-channel metrics").

Pure functions on one channel pair; arrays in, numbers out. `None` means "no value".
inv(d) = 1 / (1 + d) throughout.

A pair's object similarities (pairing included), its ets and its crpps inputs are one compiled
kernel call each (`monitor.jit`): with a handful of objects and 30-50-point plans, the numpy
formulation spent its time in the fixed cost of many tiny array calls. The tests keep plain
references to compare the kernels with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from casewatch.monitor.frames import ChannelState, Objects
from casewatch.monitor.frechet import frechet_distance
from casewatch.monitor.history import crpps_path
from casewatch.monitor.jit import kernel

#: Pairing distance resolution [m]: closer distances are ties.
PAIRING_EPS = 1e-9


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
    dist = np.empty((na, nb))
    cand_a = np.empty(na * nb, dtype=np.int64)
    cand_b = np.empty(na * nb, dtype=np.int64)
    key = np.empty(na * nb)
    nc = 0
    for i in range(na):
        for j in range(nb):
            dx = pos_a[i, 0] - pos_b[j, 0]
            dy = pos_a[i, 1] - pos_b[j, 1]
            d = math.sqrt(dx * dx + dy * dy)
            dist[i, j] = d
            # Decision: distances equal to within 1e-9 m are ties (broken by index), so that
            # float noise from a change of world frame cannot reorder the matching.
            if d <= gate + PAIRING_EPS:
                cand_a[nc] = i
                cand_b[nc] = j
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
            acc_d[k] = dist[i, j]
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
            if p == length - 1 and (math.hypot(xa, ya) > standing or math.hypot(xb, yb) > standing):
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
