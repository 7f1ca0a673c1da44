"""The safety score's compiled path: every footprint (egos and objects) an oriented box.

`_score_group` computes what `monitor.safety_score.score_grid_numpy` computes (spi-reference
"Safety score": TTC on equal grid times, then the grid reading of PET within
`pet_ref * min(1, ttc / H)`, for every plan of a prefix-grid group against every world model).
Only conservative prefilters run before the exact closed-form separating-axis test of two
oriented boxes: bounding boxes of whole sweeps and of CHUNK-point runs, bounding circles, time
gaps, a heading cone per (ego, object) pair (every pair of headings rear-end: no PET), and a
lateral separating axis per ego run (parallel traffic in the next lane). PET visits run pairs in
order of time offset and stops once nothing left can beat the best value found. Touching counts
as intersecting, as everywhere.

Two entries share that core:

- `_tick`, the safety family's whole tick in one call: each present channel is copied once into
  a preallocated scene (`Scene`, `_load`: one row per channel, so the call unboxes three arrays
  whatever the channel count), then `safety_score.safety_matrix`'s grouping (world models by
  prediction horizon, plans cut to it, prefix grids), the worst values and the arbitration;
- `score_boxes`, one group given as plans, egos and world models (`score_grid`'s box path).

Why a kernel: with a handful of objects per channel, the numpy formulation spent its time in
the fixed cost of a few hundred small array calls (about 0.5 ms per frame), and the Python glue
around a kernel per group (dicts, lists, a packed scene per group) three times the kernel's own
time. The tests hold the core equal to the numpy path and to brute-force shapely, and `_tick` to
the Python composition it replaces.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit

from casewatch.monitor.frames import Ego, Objects
from casewatch.monitor.jit import KERNEL_OPTIONS, kernel

#: Grid points per run in the run-level prefilters (both paths use runs of this length).
CHUNK = 5

#: Shortest grid segment [m] that counts as motion for a heading (spi-reference "Safety score"):
#: 2 cm per 0.1 s step is 0.2 m/s. Streams round positions (to a centimetre, say), and the
#: direction of a millimetre jump between two rounded points of a standing car is noise: read
#: as a heading, it turned a car parked beside the ego across it.
MOTION_EPS = 0.02

#: Conflict angle [rad] below which an encounter is of the rear-end type (SSAM's classification
#: of conflicts by the angle between the two headings at the conflict point: rear-end under
#: 30 degrees, lane change up to 85, crossing above). spi-reference "Safety score", conflict
#: types: PET counts only for encounters at this angle or more (following is judged by TTC and
#: by the headway signals), and a rear-end contact from behind the ego is the follower's.
REAR_END_ANGLE = math.radians(30.0)
REAR_END_COS = math.cos(REAR_END_ANGLE)
#: Resolution [m] of "the object's centre is behind the ego's": centres closer to level than
#: this count as level (not behind), whatever the world frame's rounding.
BEHIND_EPS = 1e-9

#: Slack (m) added to every prefilter bound of the kernel, so that rounding in a prefilter can
#: never drop a pair the exact test would find touching (coordinates may be map-sized).
SLACK = 1e-6


@kernel
def _headings(
    x: np.ndarray, y: np.ndarray, n: int, yaw: float, cos: np.ndarray, sin: np.ndarray
) -> None:
    """`_directions` for one track of n >= 2 points (x, y) into (cos, sin)."""
    c = math.cos(yaw)
    s = math.sin(yaw)
    for t in range(n - 1):
        dx = x[t + 1] - x[t]
        dy = y[t + 1] - y[t]
        # standing still: no hypot call (~15 ns) needed
        length = 0.0 if dx == 0.0 and dy == 0.0 else math.hypot(dx, dy)
        if length > MOTION_EPS:
            c = dx / length
            s = dy / length
        cos[t] = c
        sin[t] = s
    cos[n - 1] = cos[n - 2]
    sin[n - 1] = sin[n - 2]


@kernel
def _box_hit(
    dx: float,
    dy: float,
    ca: float,
    sa: float,
    la: float,
    wa: float,
    cb: float,
    sb: float,
    lb: float,
    wb: float,
) -> bool:
    """`boxes_intersect` for one pair, the same arithmetic in the same order."""
    cd = abs(ca * cb + sa * sb)
    sd = abs(sb * ca - cb * sa)
    if abs(dx * ca + dy * sa) > la + lb * cd + wb * sd:
        return False
    if abs(dy * ca - dx * sa) > wa + lb * sd + wb * cd:
        return False
    if abs(dx * cb + dy * sb) > lb + la * cd + wa * sd:
        return False
    return not abs(dy * cb - dx * sb) > wb + la * sd + wa * cd


@kernel
def _rear_end(ca: float, sa: float, cb: float, sb: float) -> bool:
    """The headings (ca, sa) and (cb, sb) differ by less than REAR_END_ANGLE."""
    return ca * cb + sa * sb > REAR_END_COS


@kernel
def _from_behind(dx: float, dy: float, ca: float, sa: float, cb: float, sb: float) -> bool:
    """A rear-end contact whose object (centre at dx, dy from the ego's) is behind the ego
    (ego heading ca, sa; object heading cb, sb): the follower runs into the ego. Read at an
    object's first equal-time contact: such an object counts for neither TTC nor PET."""
    return _rear_end(ca, sa, cb, sb) and dx * ca + dy * sa < -BEHIND_EPS


@kernel
def _nanmin(a: float, b: float) -> float:
    """np.minimum on scalars: NaN propagates (Python's min would drop it)."""
    if a != a or b != b:
        return math.nan
    return a if a <= b else b


@kernel
def _track(
    px: float,
    py: float,
    pred: np.ndarray,
    base: int,
    n_pred: int,
    times: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
) -> None:
    """`interpolate_tracks` for one object at (px, py) (the same arithmetic): its prediction
    is the n_pred points [dt, x, y] at pred[base:]."""
    n_t = times.shape[0]
    if n_pred == 0:
        for t in range(n_t):
            x[t] = px
            y[t] = py
        return
    d0 = pred[base]
    x0 = pred[base + 1]
    y0 = pred[base + 2]
    lo = 0  # searchsorted(dt, tt, side="right"): walked forward while the grid ascends
    prev = -math.inf
    for t in range(n_t):
        tt = times[t]
        if tt < d0:
            lead = tt / d0 if d0 > 0 else 0.0
            x[t] = px + (x0 - px) * lead
            y[t] = py + (y0 - py) * lead
        elif n_pred == 1:
            x[t] = x0
            y[t] = y0
        else:
            if tt < prev:
                lo = 0
            prev = tt
            while lo < n_pred and pred[base + 3 * lo] <= tt:
                lo += 1
            idx = min(max(lo - 1, 0), n_pred - 2)
            a = base + 3 * idx
            t0 = pred[a]
            span = pred[a + 3] - t0
            frac = (tt - t0) / span if span > 0 else 0.0
            frac = min(max(frac, 0.0), 1.0)
            x[t] = pred[a + 1] + (pred[a + 4] - pred[a + 1]) * frac
            y[t] = pred[a + 2] + (pred[a + 5] - pred[a + 2]) * frac


@kernel
def _run_boxes(x: np.ndarray, y: np.ndarray, n: int, r: float, out: np.ndarray) -> None:
    """Axis-aligned bounding box (x lo, x hi, y lo, y hi) of each CHUNK-point run of the
    first n points, grown by the footprint radius r (plus SLACK): out (C, 4)."""
    r = r + SLACK
    for c in range((n + CHUNK - 1) // CHUNK):
        lo = c * CHUNK
        x0 = x[lo]
        x1 = x[lo]
        y0 = y[lo]
        y1 = y[lo]
        for t in range(lo + 1, min(lo + CHUNK, n)):
            x0 = min(x0, x[t])
            x1 = max(x1, x[t])
            y0 = min(y0, y[t])
            y1 = max(y1, y[t])
        out[c, 0] = x0 - r
        out[c, 1] = x1 + r
        out[c, 2] = y0 - r
        out[c, 3] = y1 + r


@kernel
def _last_dt_max(pred: np.ndarray, pred_len: np.ndarray) -> float:
    """`float(pred[arange(K), max(len - 1, 0), 0][len > 0].max())` for (K, P, 3) predictions
    with P >= 1 and some length > 0: numpy's max, a NaN included (NaN)."""
    best = -np.inf
    for k in range(pred.shape[0]):
        n = pred_len[k]
        if n > 0:
            v = pred[k, n - 1, 0]
            if math.isnan(v):
                return v
            if v > best:
                best = v
    return best


@kernel
def _stands_still(plan: np.ndarray) -> bool:
    """`(plan[:, 1:3] == plan[0, 1:3]).all()` (a NaN never equals)."""
    for i in range(plan.shape[0]):  # noqa: SIM110 - a loop, not a generator, inside numba
        if not (plan[i, 1] == plan[0, 1] and plan[i, 2] == plan[0, 2]):
            return False
    return True


@kernel
def _prefix_upto(plan: np.ndarray, limit: float) -> int:
    """n when the rows with dt <= limit are exactly plan[:n] (always, for increasing dt),
    else -1."""
    n = 0
    while n < plan.shape[0] and plan[n, 0] <= limit:
        n += 1
    for i in range(n, plan.shape[0]):
        if plan[i, 0] <= limit:
            return -1
    return n


#: Columns of a scene's `meta` rows (one row per channel, see `_load`).
PRESENT, POINTS, OBJECTS, PRED_POINTS, BOXES = range(5)

#: Margin [rad] of the heading-cone test of the PET search: it drops an (ego, object) pair only
#: when every pair of their headings is provably more than this inside REAR_END_ANGLE, far
#: beyond the rounding of the per-pair test (about 1e-7 rad for the arccos of near-1 cosines).
CONE_SLACK = 1e-5


@kernel
def _load(
    data: np.ndarray,
    meta: np.ndarray,
    egos: np.ndarray,
    c: int,
    plan: np.ndarray,
    yaw: float,
    half_l: float,
    half_w: float,
    pos: np.ndarray,
    obj_yaw: np.ndarray,
    half: np.ndarray,
    pred_len: np.ndarray,
    pred: np.ndarray,
) -> int:
    """Copy one channel (its plan, box ego and objects) into row c of a scene: `data` (C, cap)
    holds the plan rows [dt, x, y] (N, 3), then the objects' pos (K, 2), yaw (K,), half (K, 2),
    pred_len (K,) and pred (K, P, 3), flat; `meta` (C, 5) says present, N, K, P and whether
    every object is a box (no NaN half extent); `egos` (C, 3) the ego's yaw and half extents.

    Why a copy: the tick's kernel then takes three arrays for every channel, not six per
    channel (each array argument costs about 0.1 us to unbox). Returns 0, or the row length
    the channel needs when `data` is too short (nothing is marked present then)."""
    n = plan.shape[0]
    k_n = pos.shape[0]
    p_n = pred.shape[1]
    need = 3 * n + 6 * k_n + 3 * k_n * p_n
    if need > data.shape[1]:
        return need
    # flat copies with 2-D stores: the loops LLVM vectorises (a row view, or indexing the
    # (K, P, 3) predictions point by point, copied at half the speed)
    flat = np.ascontiguousarray(plan).reshape(-1)
    for q in range(3 * n):
        data[c, q] = flat[q]
    at = 3 * n
    flat = np.ascontiguousarray(pos).reshape(-1)
    for q in range(2 * k_n):
        data[c, at + q] = flat[q]
    at += 2 * k_n
    for q in range(k_n):
        data[c, at + q] = obj_yaw[q]
    at += k_n
    flat = np.ascontiguousarray(half).reshape(-1)
    boxes = 1
    for q in range(2 * k_n):
        data[c, at + q] = flat[q]
        if math.isnan(flat[q]):
            boxes = 0
    at += 2 * k_n
    for q in range(k_n):
        data[c, at + q] = pred_len[q]
    at += k_n
    flat = np.ascontiguousarray(pred).reshape(-1)
    for q in range(3 * k_n * p_n):
        data[c, at + q] = flat[q]
    meta[c, PRESENT] = 1
    meta[c, POINTS] = n
    meta[c, OBJECTS] = k_n
    meta[c, PRED_POINTS] = p_n
    meta[c, BOXES] = boxes
    egos[c, 0] = yaw
    egos[c, 1] = half_l
    egos[c, 2] = half_w
    return 0


@kernel
def _plan_headings(row: np.ndarray, n: int, yaw: float, cos: np.ndarray, sin: np.ndarray) -> None:
    """`_headings` of a plan stored as [dt, x, y] rows in `row` (the same arithmetic)."""
    c = math.cos(yaw)
    s = math.sin(yaw)
    for t in range(n - 1):
        dx = row[3 * t + 4] - row[3 * t + 1]
        dy = row[3 * t + 5] - row[3 * t + 2]
        length = 0.0 if dx == 0.0 and dy == 0.0 else math.hypot(dx, dy)
        if length > MOTION_EPS:
            c = dx / length
            s = dy / length
        cos[t] = c
        sin[t] = s
    cos[n - 1] = cos[n - 2]
    sin[n - 1] = sin[n - 2]


@kernel
def _spread(cos: np.ndarray, sin: np.ndarray, n: int) -> float:
    """The largest angle [rad] between heading 0 and headings 1 .. n-1, computed as the arccos
    of the smallest cosine; NaN when a heading is NaN."""
    lo = 1.0
    for t in range(1, n):
        d = cos[t] * cos[0] + sin[t] * sin[0]
        if d != d:
            return math.nan
        if d < lo:
            lo = d
    return math.acos(max(lo, -1.0))


@kernel
def _all_rear_end(ec: np.ndarray, es: np.ndarray, oc: np.ndarray, os_: np.ndarray, n: int) -> bool:
    """Every pair of ego heading t < n and object heading h <= n - 2 is of the rear-end type
    (`_rear_end`), proven by angles: each heading lies within its track's spread of the
    track's first heading, so two headings are at most spread + spread + the first headings'
    angle apart; with CONE_SLACK to spare that is below REAR_END_ANGLE. False when unsure
    (a NaN anywhere compares false)."""
    d = ec[0] * oc[0] + es[0] * os_[0]
    if d != d:
        return False
    between = math.acos(min(max(d, -1.0), 1.0))
    total = _spread(ec, es, n) + between + _spread(oc, os_, n - 1)
    return total < REAR_END_ANGLE - CONE_SLACK


@kernel
def _score_group(
    data: np.ndarray,
    meta: np.ndarray,
    egos: np.ndarray,
    members: np.ndarray,
    cuts: np.ndarray,
    worlds: np.ndarray,
    pet_ref: float,
    hcos: np.ndarray,
    hsin: np.ndarray,
    res: np.ndarray,
) -> None:
    """(ss, ttc, pet) into res (3, M, W) for box footprints: the plans of scene rows `members`,
    each cut to its first `cuts` points (the cut grids are prefixes of the longest one), with
    their egos, against the world models of rows `worlds` (spi-reference "Safety score").
    hcos / hsin hold each member's headings along its whole plan (`_plan_headings`): a cut
    plan's heading at point t is the whole plan's at min(t, cut - 2), the same doubles.

    Only the exact box test (the numpy path's arithmetic) decides; the prefilters are
    conservative: whole-sweep and CHUNK-run bounding boxes, bounding circles per time pair,
    time gaps, for PET the heading cone of an (ego, object) pair (every contact rear-end: no
    PET) and the lateral axis of each ego run (parallel traffic in the next lane passes the
    boxes and circles, not that axis). PET visits run pairs in the order of their time offset
    and lowers its bound to the best value found: pairs at or above it cannot lower the
    minimum.
    """
    n_i = members.shape[0]
    n_j = worlds.shape[0]
    n_k = 0
    for jj in range(n_j):
        n_k += meta[worlds[jj], OBJECTS]
    longest = 0
    for i in range(n_i):
        if cuts[i] > cuts[longest]:
            longest = i
    n_t = cuts[longest]
    n_c = (n_t + CHUNK - 1) // CHUNK
    # Arrays of one shape share one allocation (views of it): some twenty allocations cost
    # about as much as the egos' setup.
    ints = np.empty(n_j + 1 + n_i, dtype=np.int64)
    grid = np.empty(n_t + 3 * n_c + 1)
    etrack = np.empty((4, n_i, n_t))
    otrack = np.empty((4, n_k, n_t))
    runs_all = np.empty((2 * n_i + n_k, n_c, 4))
    ego_small = np.empty((3, n_i, 4))
    obj_small = np.empty((2, n_k))
    flags = np.zeros((2 * n_i + 1, n_k), dtype=np.bool_)
    # objects: world jj's are first[jj] .. first[jj + 1] - 1
    first = ints[: n_j + 1]
    n_k = 0
    for jj in range(n_j):
        first[jj] = n_k
        n_k += meta[worlds[jj], OBJECTS]
    first[n_j] = n_k
    # the grid: the longest plan's times
    lrow = data[members[longest]]
    times = grid[:n_t]
    for t in range(n_t):
        times[t] = lrow[3 * t]
    ttc = res[1]
    pet = res[2]
    for i in range(n_i):
        for jj in range(n_j):
            ttc[i, jj] = math.inf
            pet[i, jj] = math.inf
    # egos on their own grids: poses, run boxes, whole-sweep boxes, run lateral axes
    plen = ints[n_j + 1 :]
    ex = etrack[0]
    ey = etrack[1]
    ec = etrack[2]
    es = etrack[3]
    ehalf = ego_small[0]  # half length, half width (columns 0, 1)
    erad = ego_small[1, :, 0]
    erun = runs_all[:n_i]
    eaxis = runs_all[n_i : 2 * n_i]  # axis x, axis y, interval lo, hi
    esweep = ego_small[2]
    for i in range(n_i):
        m_row = members[i]
        prow = data[m_row]
        n = cuts[i]
        plen[i] = n
        for t in range(n):
            ex[i, t] = prow[3 * t + 1]
            ey[i, t] = prow[3 * t + 2]
            h = min(t, n - 2)
            ec[i, t] = hcos[m_row, h]
            es[i, t] = hsin[m_row, h]
        hl = egos[m_row, 1]
        hw = egos[m_row, 2]
        ehalf[i, 0] = hl
        ehalf[i, 1] = hw
        erad[i] = math.hypot(hl, hw)
        _run_boxes(ex[i], ey[i], n, erad[i], erun[i])
        for q in range(4):
            esweep[i, q] = erun[i, 0, q]
        for c in range((n + CHUNK - 1) // CHUNK):
            esweep[i, 0] = min(esweep[i, 0], erun[i, c, 0])
            esweep[i, 1] = max(esweep[i, 1], erun[i, c, 1])
            esweep[i, 2] = min(esweep[i, 2], erun[i, c, 2])
            esweep[i, 3] = max(esweep[i, 3], erun[i, c, 3])
            ax = -es[i, c * CHUNK]
            ay = ec[i, c * CHUNK]
            lo = math.inf
            hi = -math.inf
            for t in range(c * CHUNK, min(c * CHUNK + CHUNK, n)):
                centre = ex[i, t] * ax + ey[i, t] * ay
                c_t = ec[i, t]
                s_t = es[i, t]
                rad = hl * abs(c_t * ax + s_t * ay) + hw * abs(c_t * ay - s_t * ax)
                lo = min(lo, centre - rad)
                hi = max(hi, centre + rad)
            eaxis[i, c, 0] = ax
            eaxis[i, c, 1] = ay
            eaxis[i, c, 2] = lo - SLACK
            eaxis[i, c, 3] = hi + SLACK
    # time gaps between runs of the grid: the smallest over run pairs at each run offset d,
    # then the smallest over offsets |d| >= e (so that the PET search may stop at e)
    t_lo = grid[n_t : n_t + n_c]
    t_hi = grid[n_t + n_c : n_t + 2 * n_c]
    for c in range(n_c):
        t_lo[c] = times[c * CHUNK]
        t_hi[c] = times[c * CHUNK]
        for t in range(c * CHUNK + 1, min(c * CHUNK + CHUNK, n_t)):
            t_lo[c] = min(t_lo[c], times[t])
            t_hi[c] = max(t_hi[c], times[t])
    floor = grid[n_t + 2 * n_c :]
    for e in range(n_c + 1):
        floor[e] = math.inf
    for a in range(n_c):
        for b in range(n_c):
            e = abs(b - a)
            floor[e] = min(floor[e], max(t_lo[a] - t_hi[b], t_lo[b] - t_hi[a]))
    for e in range(n_c - 2, -1, -1):
        floor[e] = min(floor[e], floor[e + 1])
    # objects: tracks on the grid (headings when first needed), run boxes
    ox = otrack[0]
    oy = otrack[1]
    oc = otrack[2]
    os_ = otrack[3]
    oyaw = obj_small[0]
    orad = obj_small[1]
    orun = runs_all[2 * n_i :]
    live = flags[:n_i]
    meets = flags[n_i : 2 * n_i]
    headed = flags[2 * n_i]
    for jj in range(n_j):
        w_row = worlds[jj]
        wrow = data[w_row]
        k_n = meta[w_row, OBJECTS]
        p = meta[w_row, PRED_POINTS]
        at = 3 * meta[w_row, POINTS]  # the objects follow the world's plan
        lo_k = first[jj]
        hi_k = first[jj + 1]
        # TTC: equal times only
        for k in range(lo_k, hi_k):
            q = k - lo_k
            px = wrow[at + 2 * q]
            py = wrow[at + 2 * q + 1]
            oyaw[k] = wrow[at + 2 * k_n + q]
            hl = wrow[at + 3 * k_n + 2 * q]
            hw = wrow[at + 3 * k_n + 2 * q + 1]
            r = math.hypot(hl, hw)
            orad[k] = r
            n_pred = int(wrow[at + 5 * k_n + q]) if p > 0 else 0
            base = at + 6 * k_n + 3 * p * q
            # the box of every position the object can take (interpolation stays inside)
            x0 = px
            x1 = x0
            y0 = py
            y1 = y0
            for s in range(n_pred):
                x0 = min(x0, wrow[base + 3 * s + 1])
                x1 = max(x1, wrow[base + 3 * s + 1])
                y0 = min(y0, wrow[base + 3 * s + 2])
                y1 = max(y1, wrow[base + 3 * s + 2])
            reach = r + SLACK
            near = False
            for i in range(n_i):
                if (
                    x0 - reach <= esweep[i, 1]
                    and x1 + reach >= esweep[i, 0]
                    and y0 - reach <= esweep[i, 3]
                    and y1 + reach >= esweep[i, 2]
                ):
                    live[i, k] = True
                    near = True
            if not near:
                continue
            _track(px, py, wrow, base, n_pred, times, ox[k], oy[k])
            _run_boxes(ox[k], oy[k], n_t, r, orun[k])
            for i in range(n_i):
                if not live[i, k]:
                    continue
                n = plen[i]
                reach = erad[i] + r
                for t in range(n):
                    dx = ox[k, t] - ex[i, t]
                    dy = oy[k, t] - ey[i, t]
                    if dx * dx + dy * dy > reach * reach:
                        continue
                    if not headed[k]:
                        _headings(ox[k], oy[k], n_t, oyaw[k], oc[k], os_[k])
                        headed[k] = True
                    h = min(t, n - 2)  # the last point of a shorter grid: its last segment
                    if _box_hit(
                        dx,
                        dy,
                        ec[i, t],
                        es[i, t],
                        ehalf[i, 0],
                        ehalf[i, 1],
                        oc[k, h],
                        os_[k, h],
                        hl,
                        hw,
                    ):
                        meets[i, k] = True
                        if _from_behind(dx, dy, ec[i, t], es[i, t], oc[k, h], os_[k, h]):
                            break  # the follower's contact, not the plan's (conflict types)
                        if times[t] < ttc[i, jj]:
                            ttc[i, jj] = times[t]
                        break
        # PET: objects that never meet the ego at equal times, |t_n - t_m| < limit
        for i in range(n_i):
            n = plen[i]
            limit = pet_ref * _nanmin(1.0, ttc[i, jj] / times[n - 1])
            if not limit > 0:
                continue
            runs = (n + CHUNK - 1) // CHUNK
            la = ehalf[i, 0]
            wa = ehalf[i, 1]
            best = pet[i, jj]
            for k in range(lo_k, hi_k):
                if not live[i, k] or meets[i, k]:
                    continue
                q = k - lo_k
                hl = wrow[at + 3 * k_n + 2 * q]
                hw = wrow[at + 3 * k_n + 2 * q + 1]
                best = _pet_object(
                    ex[i],
                    ey[i],
                    ec[i],
                    es[i],
                    la,
                    wa,
                    erad[i],
                    erun[i],
                    eaxis[i],
                    ox[k],
                    oy[k],
                    oc[k],
                    os_[k],
                    hl,
                    hw,
                    orad[k],
                    orun[k],
                    oyaw[k],
                    headed,
                    k,
                    n,
                    n_t,
                    runs,
                    times,
                    t_lo,
                    t_hi,
                    floor,
                    limit,
                    best,
                )
            pet[i, jj] = best
    for i in range(n_i):
        horizon = times[plen[i] - 1]
        for jj in range(n_j):
            res[0, i, jj] = _nanmin(1.0, _nanmin(ttc[i, jj] / horizon, pet[i, jj] / pet_ref))


@njit(inline="always", **KERNEL_OPTIONS)
def _pet_object(
    ex: np.ndarray,
    ey: np.ndarray,
    ec: np.ndarray,
    es: np.ndarray,
    la: float,
    wa: float,
    erad: float,
    erun: np.ndarray,
    eaxis: np.ndarray,
    ox: np.ndarray,
    oy: np.ndarray,
    oc: np.ndarray,
    os_: np.ndarray,
    hl: float,
    hw: float,
    orad: float,
    orun: np.ndarray,
    oyaw: float,
    headed: np.ndarray,
    k: int,
    n: int,
    n_t: int,
    runs: int,
    times: np.ndarray,
    t_lo: np.ndarray,
    t_hi: np.ndarray,
    floor: np.ndarray,
    limit: float,
    best: float,
) -> float:
    """`best` lowered to the smallest |t_n - t_m| < limit at which the ego (plan of n points)
    meets object k (which never meets it at equal times) in a contact that is not rear-end.
    The object's headings are computed on first need (`headed[k]`). An object whose every
    heading pairs with every ego heading as rear-end (`_all_rear_end`: following, or being
    followed) is done before any run pair is visited: on the bundled drives that is nearly
    every object that reaches this search.

    Inlined into its caller (numba's IR inlining): it takes some thirty arguments, which a
    call would pass on every (ego, object) pair."""
    if not headed[k]:
        _headings(ox, oy, n_t, oyaw, oc, os_)
        headed[k] = True
    if _all_rear_end(ec, es, oc, os_, n):
        return best  # following: TTC's and the headways' job, never PET
    reach = erad + orad
    for e in range(runs):
        bound = limit if limit < best else best
        if floor[e] >= bound:
            break
        for sign in range(2 if e else 1):
            d = e if sign == 0 else -e
            for a in range(max(0, -d), min(runs, runs - d)):
                b = a + d
                bound = limit if limit < best else best
                if max(t_lo[a] - t_hi[b], t_lo[b] - t_hi[a]) >= bound:
                    continue
                if (
                    erun[a, 0] > orun[b, 1]
                    or erun[a, 1] < orun[b, 0]
                    or erun[a, 2] > orun[b, 3]
                    or erun[a, 3] < orun[b, 2]
                ):
                    continue
                # the ego run's lateral axis: the object run's interval on it
                ax = eaxis[a, 0]
                ay = eaxis[a, 1]
                lo = math.inf
                hi = -math.inf
                for m in range(b * CHUNK, min(b * CHUNK + CHUNK, n)):
                    h = min(m, n - 2)
                    centre = ox[m] * ax + oy[m] * ay
                    rad = hl * abs(oc[h] * ax + os_[h] * ay) + hw * abs(oc[h] * ay - os_[h] * ax)
                    lo = min(lo, centre - rad)
                    hi = max(hi, centre + rad)
                if lo > eaxis[a, 3] or hi < eaxis[a, 2]:
                    continue
                for t in range(a * CHUNK, min(a * CHUNK + CHUNK, n)):
                    for m in range(b * CHUNK, min(b * CHUNK + CHUNK, n)):
                        dt = abs(times[t] - times[m])
                        if not (dt < limit and dt < best):
                            continue
                        dx = ox[m] - ex[t]
                        dy = oy[m] - ey[t]
                        if dx * dx + dy * dy > reach * reach:
                            continue
                        h = min(m, n - 2)
                        if _rear_end(ec[t], es[t], oc[h], os_[h]):
                            continue  # following: TTC's and the headways' job
                        if _box_hit(dx, dy, ec[t], es[t], la, wa, oc[h], os_[h], hl, hw):
                            best = dt
    return best


#: `_tick`'s answer when the tick needs the Python path (`safety_score.safety_matrix`): a
#: footprint that is not a box, a plan whose cut is not a prefix, or a NaN best score.
PYTHON_PATH = -1


@kernel
def _python_min(vals: np.ndarray, lo: int, hi: int, step: int) -> float:
    """Python's `min` over vals[lo:hi:step]: the first value, replaced by each later one that
    is smaller (so a NaN first stays, a NaN later is passed over)."""
    best = vals[lo]
    for q in range(lo + step, hi, step):
        if vals[q] < best:
            best = vals[q]
    return best


@kernel
def _upto_row(row: np.ndarray, n: int, limit: float) -> int:
    """`_prefix_upto` of a plan stored as [dt, x, y] rows."""
    m = 0
    while m < n and row[3 * m] <= limit:
        m += 1
    for t in range(m, n):
        if row[3 * t] <= limit:
            return -1
    return m


@kernel
def _still_row(row: np.ndarray, n: int) -> bool:
    """`_stands_still` of a plan stored as [dt, x, y] rows."""
    for t in range(n):  # noqa: SIM110 - a loop, not a generator, inside numba
        if not (row[3 * t + 1] == row[1] and row[3 * t + 2] == row[2]):
            return False
    return True


@kernel
def _horizon_row(row: np.ndarray, n: int, k_n: int, p: int) -> float:
    """`safety_score.prediction_horizon` of the objects stored in a scene row after a plan of
    n points: `_last_dt_max` of their predictions, inf when none predicts."""
    if k_n == 0 or p == 0:
        return math.inf
    at = 3 * n
    best = -np.inf
    for q in range(k_n):
        m = int(row[at + 5 * k_n + q])
        if m > 0:
            v = row[at + 6 * k_n + 3 * (q * p + m - 1)]
            if math.isnan(v):
                return v
            if v > best:
                best = v
    return math.inf if best == -math.inf else best


@kernel
def _same_grid(head: np.ndarray, row: np.ndarray, n: int) -> bool:
    """The first n times of two plans stored as [dt, x, y] rows (viewed as int64 bits) are
    the same bytes (`bytes.startswith` on their dt columns): -0.0 and 0.0 differ, a NaN equals
    its own bit pattern."""
    for t in range(n):  # noqa: SIM110 - a loop, not a generator, inside numba
        if head[3 * t] != row[3 * t]:
            return False
    return True


@kernel
def _tick(
    data: np.ndarray,
    meta: np.ndarray,
    egos: np.ndarray,
    pet_ref: float,
    standing_is_clear: bool,
    previous: int,
    vals: np.ndarray,
    nones: np.ndarray,
) -> int:
    """One tick of the safety score for the C channels loaded into the scene (`_load`; rows
    not marked present are absent channels): `safety_score.safety_matrix`, the family's worst
    values and `safety_score.arbitrate` in one call.

    vals (C * C + C + 1) receives ss_ij (row-major), ss_i, then ss, with nones[q] = 1 where
    the value is None. Returns 2 * (arbitration + 1) + (any None), the arbitration a channel
    index or -1 for None (`previous`: the last one's index, -1 for None); or PYTHON_PATH.
    Every present flag is cleared on return, ready for the next tick's loads.

    The grouping is `safety_matrix`'s: world models by equal prediction horizon, the plans
    cut to it, then by prefix grids (`_prefix_groups`), one `_score_group` each."""
    n_ch = meta.shape[0]
    ok = True
    for c in range(n_ch):
        if meta[c, PRESENT] and not meta[c, BOXES]:
            ok = False
    if ok:
        code = _tick_scores(data, meta, egos, pet_ref, standing_is_clear, previous, vals, nones)
    else:
        code = PYTHON_PATH
    for c in range(n_ch):
        meta[c, PRESENT] = 0
    return code


@kernel
def _tick_scores(
    data: np.ndarray,
    meta: np.ndarray,
    egos: np.ndarray,
    pet_ref: float,
    standing_is_clear: bool,
    previous: int,
    vals: np.ndarray,
    nones: np.ndarray,
) -> int:
    """`_tick` once every footprint is known to be a box."""
    n_ch = meta.shape[0]
    nn = n_ch * n_ch
    for q in range(nn + n_ch + 1):
        nones[q] = 1
        vals[q] = math.nan
    n_worlds = 0
    for j in range(n_ch):
        if meta[j, PRESENT] and meta[j, OBJECTS] > 0:
            n_worlds += 1
    # small arrays of one type share one allocation (views of it)
    flags = np.zeros((3, n_ch), dtype=np.bool_)
    scored = flags[0]
    small = np.empty((2, n_ch))
    any_scored = False
    for i in range(n_ch):
        n = meta[i, POINTS]
        if not meta[i, PRESENT] or n == 0:
            continue
        for j in range(n_ch):
            if meta[j, PRESENT]:
                vals[i * n_ch + j] = 1.0
                nones[i * n_ch + j] = 0
        standing = standing_is_clear and _still_row(data[i], n)
        if n >= 2 and n_worlds > 0 and not standing:
            scored[i] = True
            any_scored = True
    if any_scored:
        # world models by prediction horizon (a dict keyed by floats: NaN never matches)
        horizon = small[0]
        ints = np.empty((7, n_ch), dtype=np.int64)
        head = ints[0]
        head[:] = -1
        for j in range(n_ch):
            if not (meta[j, PRESENT] and meta[j, OBJECTS] > 0):
                continue
            horizon[j] = _horizon_row(
                data[j], meta[j, POINTS], meta[j, OBJECTS], meta[j, PRED_POINTS]
            )
            head[j] = j
            for g in range(j):
                if head[g] == g and horizon[g] == horizon[j]:
                    head[j] = g
                    break
        n_max = 2
        for i in range(n_ch):
            if scored[i] and meta[i, POINTS] > n_max:
                n_max = meta[i, POINTS]
        heading = np.empty((2, n_ch, n_max))
        hcos = heading[0]
        hsin = heading[1]
        headed = flags[1]
        cut = ints[1]
        order = ints[2]
        group = ints[3]
        worlds = ints[4]
        members = ints[5]
        cuts = ints[6]
        res = np.empty((3, n_ch, n_ch))
        for g in range(n_ch):
            if head[g] != g:
                continue
            n_w = 0
            for j in range(g, n_ch):
                if head[j] == g:
                    worlds[n_w] = j
                    n_w += 1
            limit = horizon[g] + 1e-9
            # the plans cut to the horizon, longest first (a stable sort: ties by channel)
            n_cut = 0
            for i in range(n_ch):
                if not scored[i]:
                    continue
                m = _upto_row(data[i], meta[i, POINTS], limit)
                if m < 0:
                    return PYTHON_PATH
                if m < 2:
                    continue
                cut[i] = m
                at = n_cut
                while at > 0 and cut[order[at - 1]] < m:
                    order[at] = order[at - 1]
                    at -= 1
                order[at] = i
                n_cut += 1
            # prefix grids: group[a] is the index (into order) of the group's first plan
            bits = data.view(np.int64)
            for a in range(n_cut):
                i = order[a]
                group[a] = a
                for b in range(a):
                    if group[b] == b and _same_grid(bits[order[b]], bits[i], cut[i]):
                        group[a] = b
                        break
            for b in range(n_cut):
                if group[b] != b:
                    continue
                n_m = 0
                for a in range(b, n_cut):
                    if group[a] == b:
                        i = order[a]
                        members[n_m] = i
                        cuts[n_m] = cut[i]
                        n_m += 1
                        if not headed[i]:
                            _plan_headings(data[i], meta[i, POINTS], egos[i, 0], hcos[i], hsin[i])
                            headed[i] = True
                _score_group(
                    data,
                    meta,
                    egos,
                    members[:n_m],
                    cuts[:n_m],
                    worlds[:n_w],
                    pet_ref,
                    hcos,
                    hsin,
                    res,
                )
                for a in range(n_m):
                    for w in range(n_w):
                        q = members[a] * n_ch + worlds[w]
                        vals[q] = res[0, a, w]
    # ss_i and ss: Python's min over the row / the matrix, None when any value is None
    any_none = False
    for i in range(n_ch):
        row_none = False
        for j in range(n_ch):
            if nones[i * n_ch + j]:
                row_none = True
        if row_none:
            any_none = True
        else:
            vals[nn + i] = _python_min(vals, i * n_ch, (i + 1) * n_ch, 1)
            nones[nn + i] = 0
    if not any_none:
        vals[nn + n_ch] = _python_min(vals, 0, nn, 1)
        nones[nn + n_ch] = 0
    # arbitration: argmax_i of the min over the world models present, ties keep `previous`
    score = small[1]
    has = flags[2]
    best = math.nan
    first = -1
    for i in range(n_ch):
        for j in range(n_ch):
            q = i * n_ch + j
            if nones[q]:
                continue
            if not has[i]:
                score[i] = vals[q]
                has[i] = True
            elif vals[q] < score[i]:
                score[i] = vals[q]
        if has[i]:
            if first < 0:
                first = i
                best = score[i]
            elif score[i] > best:
                best = score[i]
    if first < 0:
        choice = -1
    elif best != best:
        return PYTHON_PATH  # no channel ties with a NaN best: the Python path's own error
    else:
        choice = -1
        for i in range(n_ch):
            if has[i] and score[i] == best:
                if i == previous:
                    choice = i
                    break
                if choice < 0:
                    choice = i
    return 2 * (choice + 1) + (1 if any_none else 0)


class Scene:
    """The preallocated arrays `_load` fills and `_tick` reads, for C channels: data (C, cap)
    grown on demand, meta (C, 5), egos (C, 3), and the outputs vals / nones (C * C + C + 1)."""

    __slots__ = ("data", "egos", "meta", "nones", "vals")

    def __init__(self, n_channels: int, capacity: int = 2048):
        self.data = np.empty((n_channels, capacity))
        self.meta = np.zeros((n_channels, 5), dtype=np.int64)
        self.egos = np.zeros((n_channels, 3))
        self.vals = np.empty(n_channels * n_channels + n_channels + 1)
        self.nones = np.ones(len(self.vals), dtype=np.uint8)

    def load(
        self,
        c: int,
        plan: np.ndarray,
        yaw: float,
        half: tuple[float, float],
        objects: Objects,
    ) -> None:
        """Row c holds this channel (`_load`), the scene grown first when it is too short."""
        need = _load(
            self.data,
            self.meta,
            self.egos,
            c,
            plan,
            yaw,
            half[0],
            half[1],
            objects.pos,
            objects.yaw,
            objects.half,
            objects.pred_len,
            objects.pred,
        )
        if need:
            self.grow(need)
            self.load(c, plan, yaw, half, objects)

    def grow(self, need: int) -> None:
        """Rows of at least `need` floats (doubling), the rows loaded so far kept."""
        old = self.data
        self.data = np.empty((len(old), max(need, 2 * old.shape[1])))
        self.data[:, : old.shape[1]] = old


@kernel
def _score_boxes(
    data: np.ndarray, meta: np.ndarray, egos: np.ndarray, pet_ref: float, n_plans: int
) -> np.ndarray:
    """`score_boxes` on a scene whose first n_plans rows hold the plans (and egos) and the
    others the world models: (3, I, J)."""
    n_j = meta.shape[0] - n_plans
    n_max = 2
    for i in range(n_plans):
        n_max = max(n_max, meta[i, POINTS])
    hcos = np.empty((n_plans, n_max))
    hsin = np.empty((n_plans, n_max))
    members = np.arange(n_plans)
    cuts = np.empty(n_plans, dtype=np.int64)
    for i in range(n_plans):
        cuts[i] = meta[i, POINTS]
        _plan_headings(data[i], cuts[i], egos[i, 0], hcos[i], hsin[i])
    res = np.empty((3, n_plans, n_j))
    worlds = np.arange(n_plans, n_plans + n_j)
    _score_group(data, meta, egos, members, cuts, worlds, pet_ref, hcos, hsin, res)
    return res


def score_boxes(
    plans: Sequence[np.ndarray], egos: Sequence[Ego], worlds: Sequence[Objects], pet_ref: float
) -> np.ndarray | None:
    """`monitor.safety_score.score_grid` by the kernel: (3, I, J) = ss, ttc, pet, or None when
    a footprint is not a box (the numpy path's case). The plans' grids must be prefixes of the
    longest one."""
    if not all(e.half is not None for e in egos):
        return None
    scene = Scene(len(plans) + len(worlds))
    none = Objects.empty()
    for i, (plan, ego) in enumerate(zip(plans, egos, strict=True)):
        scene.load(i, plan, ego.yaw, ego.half, none)  # type: ignore[arg-type]
    no_plan = np.zeros((0, 3))
    for j, objects in enumerate(worlds):
        scene.load(len(plans) + j, no_plan, 0.0, (math.nan, math.nan), objects)
    if not scene.meta[len(plans) :, BOXES].all():
        return None
    return _score_boxes(scene.data, scene.meta, scene.egos, float(pet_ref), len(plans))  # type: ignore[no-any-return]
