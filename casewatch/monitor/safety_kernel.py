"""The safety score's compiled path: every footprint (egos and objects) an oriented box.

`score_boxes` computes what `monitor.safety_score.score_grid_numpy` computes (spi-reference
"Safety score": TTC on equal grid times, then the grid reading of PET within
`pet_ref * min(1, ttc / H)`, for every plan of a prefix-grid group against every world model)
in one kernel call per group. The scene is packed into one flat float array (`_pack`), so the
call passes two arguments. Inside, only conservative prefilters run before the exact closed-form
separating-axis test of two oriented boxes: bounding boxes of whole sweeps and of CHUNK-point
runs, bounding circles, time gaps, and a lateral separating axis per ego run (parallel traffic
in the next lane). PET visits run pairs in order of time offset and stops once nothing left
can beat the best value found. Touching counts as intersecting, as everywhere.

Why a kernel: with a handful of objects per channel, the numpy formulation spent its time in
the fixed cost of a few hundred small array calls (about 0.5 ms per frame); this path takes a
tenth of that. The tests hold it equal to the numpy path and to brute-force shapely.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from casewatch.monitor.frames import Ego, Objects
from casewatch.monitor.jit import kernel

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
def _score_scene(scene: np.ndarray, pet_ref: float) -> np.ndarray:
    """(ss, ttc, pet) as one (3, I, J) array for box footprints.

    `scene` is packed by `_pack` (one flat array, so that a call unboxes two arguments, not a
    dozen); an empty (0, I, J) result when a footprint is not a box. The grid is the longest
    plan's (the first of them); the others' grids are its prefixes.

    Only the exact box test (the numpy path's arithmetic) decides; the prefilters are
    conservative: whole-sweep and CHUNK-run bounding boxes, bounding circles per time pair,
    time gaps, and for PET the lateral axis of each ego run (parallel traffic in the next
    lane passes the boxes and circles, not that axis). PET visits run pairs in the order of
    their time offset and lowers its bound to the best value found: pairs at or above it
    cannot lower the minimum.
    """
    n_i = int(scene[0])
    n_j = int(scene[1])
    at = 2
    egos = np.empty((n_i, 4))
    for i in range(n_i):
        for q in range(4):
            egos[i, q] = scene[at + 4 * i + q]
    at += 4 * n_i
    meta = np.empty((n_j, 3), dtype=np.int64)
    n_k = 0
    for j in range(n_j):
        meta[j, 0] = n_k
        meta[j, 2] = int(scene[at + 2 * j + 1])
        n_k += int(scene[at + 2 * j])
    sizes = np.empty(2 * n_j)
    for q in range(2 * n_j):
        sizes[q] = scene[at + q]
    at += 2 * n_j
    plans = at  # the plans' [dt, x, y] rows, one plan after the other
    for i in range(n_i):
        at += 3 * int(egos[i, 3])
    pos = np.empty((n_k, 2))
    yaw = np.empty(n_k)
    half = np.empty((n_k, 2))
    pred_len = np.empty(n_k, dtype=np.int64)
    boxes = True
    for j in range(n_j):
        first = meta[j, 0]
        k_j = int(sizes[2 * j])
        for q in range(k_j):
            pos[first + q, 0] = scene[at + 2 * q]
            pos[first + q, 1] = scene[at + 2 * q + 1]
            yaw[first + q] = scene[at + 2 * k_j + q]
            half[first + q, 0] = scene[at + 3 * k_j + 2 * q]
            half[first + q, 1] = scene[at + 3 * k_j + 2 * q + 1]
            pred_len[first + q] = int(scene[at + 5 * k_j + q])
            if math.isnan(half[first + q, 0]) or math.isnan(half[first + q, 1]):
                boxes = False
        at += 6 * k_j
        meta[j, 1] = at
        at += 3 * k_j * meta[j, 2]
    if not boxes:
        return np.empty((0, n_i, n_j))
    pred = scene  # the predictions stay in the scene array (meta[:, 1]: their offsets)
    # the grid: the longest plan's times
    starts = np.empty(n_i, dtype=np.int64)
    longest = 0
    off = 0
    for i in range(n_i):
        starts[i] = off
        off += int(egos[i, 3])
        if egos[i, 3] > egos[longest, 3]:
            longest = i
    n_t = int(egos[longest, 3])
    times = np.empty(n_t)
    for t in range(n_t):
        times[t] = scene[plans + 3 * (starts[longest] + t)]
    n_c = (n_t + CHUNK - 1) // CHUNK
    out = np.empty((3, n_i, n_j))
    ttc = out[1]
    pet = out[2]
    for i in range(n_i):
        for j in range(n_j):
            ttc[i, j] = math.inf
            pet[i, j] = math.inf
    # egos on their own grids: poses, run boxes, whole-sweep boxes, run lateral axes
    plen = np.empty(n_i, dtype=np.int64)
    ex = np.empty((n_i, n_t))
    ey = np.empty((n_i, n_t))
    ec = np.empty((n_i, n_t))
    es = np.empty((n_i, n_t))
    erad = np.empty(n_i)
    erun = np.empty((n_i, n_c, 4))
    eaxis = np.empty((n_i, n_c, 4))  # axis x, axis y, interval lo, hi
    esweep = np.empty((n_i, 4))
    for i in range(n_i):
        n = int(egos[i, 3])
        plen[i] = n
        for t in range(n):
            ex[i, t] = scene[plans + 3 * (starts[i] + t) + 1]
            ey[i, t] = scene[plans + 3 * (starts[i] + t) + 2]
        _headings(ex[i], ey[i], n, egos[i, 0], ec[i], es[i])
        hl = egos[i, 1]
        hw = egos[i, 2]
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
    t_lo = np.empty(n_c)
    t_hi = np.empty(n_c)
    for c in range(n_c):
        t_lo[c] = times[c * CHUNK]
        t_hi[c] = times[c * CHUNK]
        for t in range(c * CHUNK + 1, min(c * CHUNK + CHUNK, n_t)):
            t_lo[c] = min(t_lo[c], times[t])
            t_hi[c] = max(t_hi[c], times[t])
    floor = np.empty(n_c + 1)
    for e in range(n_c + 1):
        floor[e] = math.inf
    for a in range(n_c):
        for b in range(n_c):
            e = abs(b - a)
            floor[e] = min(floor[e], max(t_lo[a] - t_hi[b], t_lo[b] - t_hi[a]))
    for e in range(n_c - 2, -1, -1):
        floor[e] = min(floor[e], floor[e + 1])
    # objects: tracks on the grid (headings when first needed), run boxes
    ox = np.empty((n_k, n_t))
    oy = np.empty((n_k, n_t))
    oc = np.empty((n_k, n_t))
    os_ = np.empty((n_k, n_t))
    orad = np.empty(n_k)
    orun = np.empty((n_k, n_c, 4))
    headed = np.zeros(n_k, dtype=np.bool_)
    live = np.zeros((n_i, n_k), dtype=np.bool_)
    meets = np.zeros((n_i, n_k), dtype=np.bool_)
    for j in range(n_j):
        first = meta[j, 0]
        last = meta[j + 1, 0] if j + 1 < n_j else n_k
        p = meta[j, 2]
        # TTC: equal times only
        for k in range(first, last):
            hl = half[k, 0]
            hw = half[k, 1]
            r = math.hypot(hl, hw)
            orad[k] = r
            n_pred = pred_len[k] if p > 0 else 0
            base = meta[j, 1] + 3 * p * (k - first)
            # the box of every position the object can take (interpolation stays inside)
            x0 = pos[k, 0]
            x1 = x0
            y0 = pos[k, 1]
            y1 = y0
            for q in range(n_pred):
                x0 = min(x0, pred[base + 3 * q + 1])
                x1 = max(x1, pred[base + 3 * q + 1])
                y0 = min(y0, pred[base + 3 * q + 2])
                y1 = max(y1, pred[base + 3 * q + 2])
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
            _track(pos[k, 0], pos[k, 1], pred, base, n_pred, times, ox[k], oy[k])
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
                        _headings(ox[k], oy[k], n_t, yaw[k], oc[k], os_[k])
                        headed[k] = True
                    h = min(t, n - 2)  # the last point of a shorter grid: its last segment
                    if _box_hit(
                        dx,
                        dy,
                        ec[i, t],
                        es[i, t],
                        egos[i, 1],
                        egos[i, 2],
                        oc[k, h],
                        os_[k, h],
                        hl,
                        hw,
                    ):
                        meets[i, k] = True
                        if _from_behind(dx, dy, ec[i, t], es[i, t], oc[k, h], os_[k, h]):
                            break  # the follower's contact, not the plan's (conflict types)
                        if times[t] < ttc[i, j]:
                            ttc[i, j] = times[t]
                        break
        # PET: objects that never meet the ego at equal times, |t_n - t_m| < limit
        for i in range(n_i):
            n = plen[i]
            limit = pet_ref * _nanmin(1.0, ttc[i, j] / times[n - 1])
            if not limit > 0:
                continue
            runs = (n + CHUNK - 1) // CHUNK
            la = egos[i, 1]
            wa = egos[i, 2]
            best = pet[i, j]
            for k in range(first, last):
                if not live[i, k] or meets[i, k]:
                    continue
                hl = half[k, 0]
                hw = half[k, 1]
                reach = erad[i] + orad[k]
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
                                erun[i, a, 0] > orun[k, b, 1]
                                or erun[i, a, 1] < orun[k, b, 0]
                                or erun[i, a, 2] > orun[k, b, 3]
                                or erun[i, a, 3] < orun[k, b, 2]
                            ):
                                continue
                            if not headed[k]:
                                _headings(ox[k], oy[k], n_t, yaw[k], oc[k], os_[k])
                                headed[k] = True
                            # the ego run's lateral axis: the object run's interval on it
                            ax = eaxis[i, a, 0]
                            ay = eaxis[i, a, 1]
                            lo = math.inf
                            hi = -math.inf
                            for m in range(b * CHUNK, min(b * CHUNK + CHUNK, n)):
                                h = min(m, n - 2)
                                centre = ox[k, m] * ax + oy[k, m] * ay
                                rad = hl * abs(oc[k, h] * ax + os_[k, h] * ay) + hw * abs(
                                    oc[k, h] * ay - os_[k, h] * ax
                                )
                                lo = min(lo, centre - rad)
                                hi = max(hi, centre + rad)
                            if lo > eaxis[i, a, 3] or hi < eaxis[i, a, 2]:
                                continue
                            for t in range(a * CHUNK, min(a * CHUNK + CHUNK, n)):
                                for m in range(b * CHUNK, min(b * CHUNK + CHUNK, n)):
                                    dt = abs(times[t] - times[m])
                                    if not (dt < limit and dt < best):
                                        continue
                                    dx = ox[k, m] - ex[i, t]
                                    dy = oy[k, m] - ey[i, t]
                                    if dx * dx + dy * dy > reach * reach:
                                        continue
                                    h = min(m, n - 2)
                                    if _rear_end(ec[i, t], es[i, t], oc[k, h], os_[k, h]):
                                        continue  # following: TTC's and the headways' job
                                    if _box_hit(
                                        dx,
                                        dy,
                                        ec[i, t],
                                        es[i, t],
                                        la,
                                        wa,
                                        oc[k, h],
                                        os_[k, h],
                                        hl,
                                        hw,
                                    ):
                                        best = dt
            pet[i, j] = best
    for i in range(n_i):
        horizon = times[plen[i] - 1]
        for j in range(n_j):
            out[0, i, j] = _nanmin(1.0, _nanmin(ttc[i, j] / horizon, pet[i, j] / pet_ref))
    return out


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


def _pack(
    plans: Sequence[np.ndarray], egos: Sequence[Ego], worlds: Sequence[Objects]
) -> np.ndarray:
    """One flat float array for `_score_scene`: [I, J], per ego [yaw, half length, half width,
    plan length], per world [objects K, prediction points P], the plans' rows, then per world
    its pos (K, 2), yaw (K,), half (K, 2), pred_len (K,) and pred (K, P, 3). Egos must be
    boxes (`half` set)."""
    head: list[float] = [len(plans), len(worlds)]
    for e, p in zip(egos, plans, strict=True):
        head += (e.yaw, *e.half, len(p))  # type: ignore[misc]
    for o in worlds:
        head += (len(o), o.pred.shape[1])
    parts: list = [np.array(head)]
    parts += [p.ravel() for p in plans]
    for o in worlds:
        parts += (o.pos.ravel(), o.yaw, o.half.ravel(), o.pred_len, o.pred.ravel())
    return np.concatenate(parts, dtype=np.float64)


def score_boxes(
    plans: Sequence[np.ndarray], egos: Sequence[Ego], worlds: Sequence[Objects], pet_ref: float
) -> np.ndarray | None:
    """`monitor.safety_score.score_grid` by the kernel: (3, I, J) = ss, ttc, pet, or None when
    a footprint is not a box (the numpy path's case)."""
    if not all(e.half is not None for e in egos):
        return None
    out = _score_scene(_pack(plans, egos, worlds), float(pet_ref))
    return out if len(out) else None
