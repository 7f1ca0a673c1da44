"""Metrics over a channel's (or pair's) recent past: els_var and chpps, and the histories the
motion family keeps (`PlanHistory` of plans, `ObjectHistory` of objects for ompv).

The ELS windows live in `monitor.engine`; the stored plans live in a `PlanHistory`, packed so
that one compiled call cuts the current plan of every channel against each of its stored plans.

Why packed: a frame's chpps is ~40 plan pairs of 30-50 points. Cut with Python bisects and
numpy slices, then compared pair by pair, the pairs cost more in glue than in arithmetic.
The motion family's tick (`families/prediction.py`): `_tick_cut` pushes the tick's plans and
writes every cut sequence straight into the history's work space (the crpps inputs of the
tick ride in the same call), `monitor.frechet.pair_distances_into` computes every pair's
discrete Fréchet distance in one compiled call, and `_finish` turns the distances into the
scores and the family's output rows: three kernel calls, whatever the number of channels and
stored plans. `_cut`, `frame_inputs`, `chpps_frame` and `_combine` are the formulation this
replaced (`chpps` of one plan uses it), kept as the reference the tests hold the tick to.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from casewatch.monitor.frechet import frechet_pairs
from casewatch.monitor.jit import kernel

#: Tolerance [s] when clipping plans to their common time range: frame times and dt values are
#: decimal numbers, so `dt - age` lands a few ulps off the grid.
TIME_EPS = 1e-9


def els_var(window: Sequence[float], size: int) -> float | None:
    """Sample variance (divisor n - 1) of the last `size` ELS values; None until full."""
    if len(window) < size:
        return None
    return _sample_variance(np.array(window[-size:], dtype=float))


@kernel
def _sample_variance(x):  # pragma: no cover - compiled
    """np.var(x, ddof=1)'s arithmetic (mean first, then the squared deviations)."""
    n = x.shape[0]
    total = 0.0
    for v in x:
        total += v
    mean = total / n
    ss = 0.0
    for v in x:
        ss += (v - mean) * (v - mean)
    return ss / (n - 1)


class PlanHistory:
    """The last `size` plans of every channel, plus the current one, packed for `_cut`.

    Channel c's plans sit in a ring of `size + 1` slots: `plans[c, slot, :lens[c, slot]]` is a
    plan's [dt, x, y] rows (the rest of the row is padding), `times[c, slot]` its frame time,
    `head[c]` the newest slot and `count[c]` how many slots hold a plan. One slot more than
    `plan_history` because the current plan is pushed before the cut and is not a stored one.
    A plan longer than the buffer's width widens the buffer (all channels, once).

    The engine pushes only non-empty plans (spi-reference: the channel keeps its non-empty
    plans); an empty plan pushed anyway holds its rank and never overlaps. `push` is the
    reference formulation; the motion family's tick pushes with `_push_plan` inside
    `chpps_tick`, into the same arrays by the same rule.

    `coords`, `starts` and `table` are the tick's work space (`chpps_tick`): the cut sequences,
    where each Fréchet line starts in `coords`, and the pair table; `coords` grows when a tick
    needs more points.
    """

    __slots__ = (
        "coords",
        "count",
        "head",
        "lens",
        "max_gap",
        "plans",
        "segs",
        "starts",
        "table",
        "times",
    )

    def __init__(self, channels: int, size: int, max_gap: float, width: int = 64):
        if channels < 1 or size < 1 or width < 1:
            raise ValueError(
                f"PlanHistory needs channels, size and width >= 1 (got {channels}, {size}, {width})"
            )
        slots = size + 1
        self.plans = np.zeros((channels, slots, width, 3))
        #: segs[c, slot, q]: length of the plan's segment from row q to row q + 1, computed
        #: once when the plan is pushed (`_cut` reads a stored plan's every frame it stays)
        self.segs = np.zeros((channels, slots, width))
        self.lens = np.zeros((channels, slots), dtype=np.int64)
        self.times = np.zeros((channels, slots))
        self.count = np.zeros(channels, dtype=np.int64)
        self.head = np.zeros(channels, dtype=np.int64)
        self.max_gap = max_gap
        self.coords = np.zeros((64, 2))
        # pairs of a tick: the given ones (at most one per pair of channels) and the stored plans
        cap = channels * slots + channels * channels
        self.starts = np.zeros(2 * cap + 1, dtype=np.int64)
        self.table = np.zeros((cap, 5))

    def push(self, channel: int, t: float, plan: np.ndarray) -> None:
        """Store `plan` ((n, 3) [dt, x, y]) of `channel` at frame time `t`; the history restarts
        first when `t` is more than `max_gap` (+1e-9 s) after the channel's previous plan."""
        n = len(plan)
        if n > self.plans.shape[2]:
            self.widen(max(n, 2 * self.plans.shape[2]))
        count = int(self.count[channel])
        head = int(self.head[channel])
        # the newest slot's time is the channel's previous push
        if count and t - float(self.times[channel, head]) > self.max_gap + 1e-9:
            count = 0
        slot = (head + 1) % self.plans.shape[1]
        self.plans[channel, slot, :n] = plan
        _segments(self.plans[channel, slot], n, self.segs[channel, slot])
        self.lens[channel, slot] = n
        self.times[channel, slot] = t
        self.count[channel] = min(count + 1, self.plans.shape[1])
        self.head[channel] = slot

    def widen(self, width: int) -> None:
        """Room for plans of `width` points (every channel's buffer, the stored plans kept)."""
        old = self.plans
        self.plans = np.zeros((*old.shape[:2], width, 3))
        self.plans[:, :, : old.shape[2]] = old
        old_segs = self.segs
        self.segs = np.zeros((*old.shape[:2], width))
        self.segs[:, :, : old.shape[2]] = old_segs


class _IdCodes(dict):
    """Object id -> a number, a new one for an id not seen before (`dict.__getitem__` calls
    `__missing__`), so that kernels match ids as integers."""

    __slots__ = ("next",)

    def __init__(self) -> None:
        super().__init__()
        self.next = 0

    def __missing__(self, key: object) -> int:
        code = self.next
        self.next += 1
        self[key] = code
        return code


class ObjectHistory:
    """Each channel's recent observations of its objects, for ompv's lookback (spi-reference
    "ompv"): what a `TimedHistory` of `Objects` held (the reference in
    tests/monitor/reference_windows.py), in preallocated arrays that `prediction.ompv_tick`
    reads and updates in one compiled call per tick.

    Channel c's observations sit in a ring of `slots` slots, oldest to newest ending at
    `head[c]`, `count[c]` of them: slot s holds the frame time `times[c, s]`, `n_obj[c, s]` = n
    objects with their positions `pos[c, s, :2 n]` (the (n, 2) array, flat), predictions
    `pred[c, s, :3 n p]` (the (n, p, 3) `Objects.pred`, flat, p = `n_pred[c, s]`: the frame's
    padding kept, ompv reads the width as `Objects.pred`'s), real prediction lengths
    `pred_len` and ids as numbers (`codes`, from `codes_of`). Flat, an observation is one
    contiguous block to copy in and to read back as its arrays. `fit` grows the arrays when a
    tick brings more objects or prediction points, or needs another slot.

    `pending`, `elapsed`: the tick's channels whose ompv needs the nearest matching (no id
    carried over, `prediction.ompv_tick`): the slot compared with and its age, -1 otherwise.
    """

    __slots__ = (
        "codes",
        "count",
        "elapsed",
        "head",
        "ids",
        "n_obj",
        "n_pred",
        "pending",
        "pos",
        "pred",
        "pred_len",
        "state",
        "times",
    )

    #: ids remembered before `forget_unused` drops those no observation holds any more
    ID_LIMIT = 1 << 16

    def __init__(self, channels: int, slots: int = 8, objects: int = 8, points: int = 32):
        """Room for `objects` objects of `points`-point predictions in each of `slots`
        observations per channel, to begin with."""
        if channels < 1 or slots < 2 or objects < 1 or points < 1:
            raise ValueError(
                f"ObjectHistory needs channels, objects, points >= 1 and slots >= 2 (got "
                f"{channels}, {objects}, {points}, {slots})"
            )
        self.times = np.zeros((channels, slots))
        self.count = np.zeros(channels, dtype=np.int64)
        self.head = np.zeros(channels, dtype=np.int64)
        self.n_obj = np.zeros((channels, slots), dtype=np.int64)
        self.n_pred = np.zeros((channels, slots), dtype=np.int64)
        self.pos = np.zeros((channels, slots, 2 * objects))
        self.pred = np.zeros((channels, slots, 3 * objects * points))
        self.pred_len = np.zeros((channels, slots, objects), dtype=np.int64)
        self.codes = np.zeros((channels, slots, objects), dtype=np.int64)
        self.pending = np.full(channels, -1, dtype=np.int64)
        self.elapsed = np.zeros(channels)
        #: object id -> its number (`codes_of`)
        self.ids = _IdCodes()
        self._state()

    def _state(self) -> None:
        #: the arrays `prediction._ompv_tick` takes, in its order (rebuilt when they grow)
        self.state = (
            self.times,
            self.count,
            self.head,
            self.n_obj,
            self.n_pred,
            self.pos,
            self.pred,
            self.pred_len,
            self.codes,
        )

    def codes_of(self, ids: list[str]) -> np.ndarray:
        """The numbers of `ids` (equal ids, equal numbers), as int64."""
        return np.array(list(map(self.ids.__getitem__, ids)), dtype=np.int64)

    def forget_unused(self) -> None:
        """Drop the ids no stored observation holds once more than `ID_LIMIT` are known (call
        between ticks: a tick's current ids are not stored yet). An id seen again later gets a
        new number, which nothing stored can match: matching is unchanged, memory bounded."""
        ids = self.ids
        if len(ids) <= self.ID_LIMIT:
            return
        live: set[int] = set()
        slots = self.times.shape[1]
        for c in range(len(self.count)):
            head = int(self.head[c])
            for r in range(int(self.count[c])):
                s = (head - r) % slots
                live.update(self.codes[c, s, : self.n_obj[c, s]].tolist())
        kept = [(k, v) for k, v in ids.items() if v in live]
        ids.clear()  # the same dict: a family may hold it
        ids.update(kept)

    def fit(self, objects: int, values: int) -> None:
        """Room for a tick of `objects` objects whose predictions hold `values` numbers per
        channel and one more observation per channel (`prediction.ompv_tick` asks for it)."""
        channels, slots = self.times.shape
        k = self.codes.shape[2]
        p = self.pred.shape[2]
        full = bool((self.count >= slots).any())
        new_slots = 2 * slots if full else slots
        new_k = k if objects <= k else max(objects, 2 * k)
        new_p = p if values <= p else max(values, 2 * p)
        if (new_slots, new_k, new_p) == (slots, k, p):
            return
        # observations oldest first into slots 0.., so the ring may grow
        order = [
            [(int(self.head[c]) - int(self.count[c]) + 1 + r) % slots for r in range(slots)]
            for c in range(channels)
        ]
        idx = np.array(order, dtype=np.int64)
        rows = np.arange(channels)[:, None]

        def moved(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
            """a's observations in order, in an array of the new sizes."""
            src = a[rows, idx]
            out = np.zeros((channels, new_slots, *shape), dtype=a.dtype)
            out[tuple(slice(0, n) for n in src.shape)] = src
            return out

        self.times = moved(self.times, ())
        self.n_obj = moved(self.n_obj, ())
        self.n_pred = moved(self.n_pred, ())
        self.pos = moved(self.pos, (2 * new_k,))
        self.pred = moved(self.pred, (new_p,))
        self.pred_len = moved(self.pred_len, (new_k,))
        self.codes = moved(self.codes, (new_k,))
        self.head = np.maximum(self.count - 1, 0).astype(np.int64)
        self._state()


#: Columns of the pair table `_cut` returns, one row per Fréchet pair of the frame: owner
#: (channel index for a chpps pair, channels + k for the k-th crpps pair), weight w_j, the
#: distance when a sequence has one point (computed directly), the pair's slot in the Fréchet
#: batch (-1: computed directly), and the geometry index of its first sequence in the
#: coordinate array (the second's is one more).
OWNER, WEIGHT, DIRECT, SLOT, GEOM = range(5)


@kernel
def _bisect(a, n, x, right):  # pragma: no cover - compiled
    """Python's `bisect_left` (right=False) or `bisect_right` (right=True) on a[:n]."""
    lo = 0
    hi = n
    while lo < hi:
        mid = (lo + hi) // 2
        if (x < a[mid]) if right else not (a[mid] < x):
            hi = mid
        else:
            lo = mid + 1
    return lo


@kernel
def _arc_length(rows, first, n):  # pragma: no cover - compiled
    """Length [m] of the polyline through rows[first:first + n] ([dt, x, y] rows)."""
    total = 0.0
    for q in range(first + 1, first + n):
        total += math.hypot(rows[q, 1] - rows[q - 1, 1], rows[q, 2] - rows[q - 1, 2])
    return total


@kernel
def _along(rows, first, n, length, n_out, off_x, off_y, coords, pos):  # pragma: no cover
    """n_out points evenly spaced by arc length over the first `length` metres of the
    polyline through rows[first:first + n], moved by (off_x, off_y), into coords[pos:]."""
    q = first  # the segment rows[q] -> rows[q + 1] holds the next point
    walked = 0.0  # arc length at rows[q]
    seg = math.hypot(rows[q + 1, 1] - rows[q, 1], rows[q + 1, 2] - rows[q, 2]) if n > 1 else 0.0
    for j in range(n_out):
        target = length * j / (n_out - 1) if n_out > 1 else 0.0
        while q < first + n - 2 and walked + seg < target:
            walked += seg
            q += 1
            seg = math.hypot(rows[q + 1, 1] - rows[q, 1], rows[q + 1, 2] - rows[q, 2])
        frac = 0.0 if n == 1 or seg <= 0.0 else min(max((target - walked) / seg, 0.0), 1.0)
        nxt = q + 1 if n > 1 else q
        coords[pos + j, 0] = rows[q, 1] + (rows[nxt, 1] - rows[q, 1]) * frac + off_x
        coords[pos + j, 1] = rows[q, 2] + (rows[nxt, 2] - rows[q, 2]) * frac + off_y


@kernel
def _segments(rows, n, out):  # pragma: no cover - compiled
    """out[q] = length of the segment rows[q] -> rows[q + 1] ([dt, x, y] rows), q < n - 1:
    the `math.hypot` `_arc_length` and `_along` take, computed once."""
    for q in range(n - 1):
        out[q] = math.hypot(rows[q + 1, 1] - rows[q, 1], rows[q + 1, 2] - rows[q, 2])


@kernel
def _arc_length_segs(segs, first, n):  # pragma: no cover - compiled
    """`_arc_length` of rows[first:first + n] from their segment lengths (same sum, same
    order)."""
    total = 0.0
    for q in range(first + 1, first + n):
        total += segs[q - 1]
    return total


@kernel
def _along_segs(rows, segs, first, n, length, n_out, off_x, off_y, coords, pos):  # pragma: no cover
    """`_along` with the segment lengths read from `segs` (`_segments` of rows), not
    recomputed: the same points, bit for bit."""
    q = first  # the segment rows[q] -> rows[q + 1] holds the next point
    walked = 0.0  # arc length at rows[q]
    seg = segs[q] if n > 1 else 0.0
    for j in range(n_out):
        target = length * j / (n_out - 1) if n_out > 1 else 0.0
        while q < first + n - 2 and walked + seg < target:
            walked += seg
            q += 1
            seg = segs[q]
        frac = 0.0 if n == 1 or seg <= 0.0 else min(max((target - walked) / seg, 0.0), 1.0)
        nxt = q + 1 if n > 1 else q
        coords[pos + j, 0] = rows[q, 1] + (rows[nxt, 1] - rows[q, 1]) * frac + off_x
        coords[pos + j, 1] = rows[q, 2] + (rows[nxt, 2] - rows[q, 2]) * frac + off_y


@kernel
def _common_path(p, q):  # pragma: no cover - compiled
    """`common_path` on (n, 3) rows (x, y in columns 1 and 2)."""
    n_out = max(p.shape[0], q.shape[0])
    length = min(_arc_length(p, 0, p.shape[0]), _arc_length(q, 0, q.shape[0]))
    out = np.empty((2 * n_out, 2))
    _along(p, 0, p.shape[0], length, n_out, 0.0, 0.0, out, 0)
    _along(q, 0, q.shape[0], length, n_out, 0.0, 0.0, out, n_out)
    return out


def common_path(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two point sequences (n, 2) and (m, 2) as paths (spi-reference chpps, crpps): each
    resampled to max(n, m) points evenly spaced by arc length over the length both cover, so
    that their Fréchet distance measures where the paths go, not how fast they are driven."""
    rows = np.zeros((len(p) + len(q), 3))
    rows[: len(p), 1:] = p
    rows[len(p) :, 1:] = q
    out = _common_path(rows[: len(p)], rows[len(p) :])
    n_out = max(len(p), len(q))
    return out[:n_out], out[n_out:]


@kernel
def _kept_points(plan, begin, horizon):  # pragma: no cover - compiled
    """The points of `plan` whose dt lies in [begin, horizon], packed first into a zeroed
    (len(plan), 3) array (x, y in columns 1 and 2), and their count."""
    kept = np.zeros((plan.shape[0], 3))
    n = 0
    for i in range(plan.shape[0]):
        if begin <= plan[i, 0] <= horizon:
            kept[n, 1] = plan[i, 1]
            kept[n, 2] = plan[i, 2]
            n += 1
    return kept, n


@kernel
def _crpps_path(plan_a, plan_b):  # pragma: no cover - compiled
    """`crpps_path` in one compiled call: the rows of both plans inside their common time
    range (+-1e-9 s), plan B's translated so that its first kept point is plan A's first kept
    point, then `_common_path` of the two."""
    horizon = min(plan_a[-1, 0], plan_b[-1, 0]) + 1e-9
    begin = max(plan_a[0, 0], plan_b[0, 0]) - 1e-9
    pa, na = _kept_points(plan_a, begin, horizon)
    pb, nb = _kept_points(plan_b, begin, horizon)
    if na == 0 or nb == 0:
        return np.empty((0, 2)), 0
    x0, y0 = pb[0, 1], pb[0, 2]
    for i in range(nb):
        pb[i, 1] = pb[i, 1] - x0 + pa[0, 1]
        pb[i, 2] = pb[i, 2] - y0 + pa[0, 2]
    return _common_path(pa[:na], pb[:nb]), max(na, nb)


def crpps_path(plan_a: np.ndarray, plan_b: np.ndarray) -> tuple[np.ndarray, int]:
    """The crpps inputs of two non-empty plans ((N, 3) [dt, x, y]) in one compiled call
    (spi-reference crpps): both cut to their common time range, plan B moved onto plan A's
    first kept point, then `common_path` of the two. Returns (out, n): the two sequences are
    out[:n] and out[n:]; n = 0 when the plans share no time."""
    return _crpps_path(plan_a, plan_b)


@kernel
def _cut(plans, segs, lens, times, count, head, t, decay, pair_xy, pair_lens):  # pragma: no cover
    """Every Fréchet pair of the frame, written into one coordinate array.

    Pairs, in this order: the given pairs (sequence 2k and 2k+1 of `pair_xy`, lengths in
    `pair_lens`), then per channel whose newest plan is from time `t`, that plan against each
    stored plan, most recent first, cut to their common time range (spi-reference, chpps).
    Sequences of pairs whose sequences both have two points or more come first, pair by pair
    (geometry 2m, 2m+1 for the m-th such pair: what `frechet_pairs` gets); pairs with a one-point
    sequence follow, their distance computed here (largest distance from the point to a point
    of the other sequence, as `similarity.frechet` does).

    A chpps pair compares **paths** (spi-reference chpps): both cut sequences, the stored one
    moved onto the current one's first point, are resampled to the same number of points
    (the larger of their two counts) evenly spaced by arc length over the length both cover.
    A plan whose speed profile changed along an unchanged path then reads fd = 0.

    Returns (coords (n, 2), geometry index per point, pair table (see OWNER..GEOM), number of
    points for `frechet_pairs`, number of pairs for it).
    """
    n_ch, slots = lens.shape
    n_given = pair_lens.shape[0] // 2
    cap = n_given + n_ch * (slots - 1)
    # per pair: slot, start, length of its first and second sequence (slot -1: pair_xy)
    src = np.empty((cap, 6), dtype=np.int64)
    owner = np.empty(cap, dtype=np.int64)
    weight = np.empty(cap)
    raw = np.empty((cap, 2), dtype=np.int64)  # chpps pairs: the cut lengths before resampling
    common = np.empty(cap)  # chpps pairs: the path length both cover [m]
    k = 0
    off = 0
    for i in range(n_given):
        lp = pair_lens[2 * i]
        lq = pair_lens[2 * i + 1]
        src[k, 0] = -1
        src[k, 1] = off
        src[k, 2] = lp
        src[k, 3] = -1
        src[k, 4] = off + lp
        src[k, 5] = lq
        owner[k] = n_ch + i
        weight[k] = 1.0
        off += lp + lq
        k += 1
    for c in range(n_ch):
        if count[c] == 0:
            continue
        h = head[c]
        nc = lens[c, h]
        if times[c, h] != t or nc == 0:
            continue  # no plan from this frame: no value
        cur = plans[c, h, :, 0]
        c0 = cur[0]
        c1 = cur[nc - 1]
        for rank in range(count[c] - 1):
            s = (h - 1 - rank + slots) % slots
            ns = lens[c, s]
            if ns == 0:
                continue
            age = t - times[c, s]
            sdt = plans[c, s, :, 0]
            lo = max(c0, sdt[0] - age) - TIME_EPS
            hi = min(c1, sdt[ns - 1] - age) + TIME_EPS
            if lo > hi:
                continue  # disjoint ranges (the bisects below would say so too, slower)
            # Both dt columns increase strictly: the common range is one slice of each.
            a = _bisect(cur, nc, lo, False)
            b = _bisect(cur, nc, hi, True)
            sa = _bisect(sdt, ns, lo + age, False)
            sb = _bisect(sdt, ns, hi + age, True)
            if a >= b or sa >= sb:
                continue  # Decision: a common range with no sample of one plan is no overlap
            n_out = max(b - a, sb - sa)
            src[k, 0] = h
            src[k, 1] = a
            src[k, 2] = n_out
            src[k, 3] = s
            src[k, 4] = sa
            src[k, 5] = n_out
            raw[k, 0] = b - a
            raw[k, 1] = sb - sa
            common[k] = min(
                _arc_length_segs(segs[c, h], a, b - a), _arc_length_segs(segs[c, s], sa, sb - sa)
            )
            owner[k] = c
            # Decision: j is the rank among stored plans (1 = most recent), skipped included.
            weight[k] = decay ** float(rank)
            k += 1
    n_geos = 0
    geos_points = 0
    total = 0
    for i in range(k):
        total += src[i, 2] + src[i, 5]
        if src[i, 2] > 1 and src[i, 5] > 1:
            n_geos += 1
            geos_points += src[i, 2] + src[i, 5]
    coords = np.empty((total, 2))
    index = np.empty(total, dtype=np.int64)
    table = np.empty((k, 5))
    at_geos = 0  # next point / geometry of the multi-point part
    g_geos = 0
    at_one = geos_points  # next point / geometry of the one-point part
    g_one = 2 * n_geos
    for i in range(k):
        lp = src[i, 2]
        lq = src[i, 5]
        multi = lp > 1 and lq > 1
        pos = at_geos if multi else at_one
        g = g_geos if multi else g_one
        start = pos
        for side in range(2):
            slot = src[i, 3 * side]
            first = src[i, 3 * side + 1]
            # spi-reference chpps Decision: the stored plan moves onto the current plan's first
            # common point (a plan that moves with the localisation estimate is not unstable)
            off_x = 0.0
            off_y = 0.0
            if slot >= 0 and side == 1:
                o = owner[i]
                off_x = plans[o, src[i, 0], src[i, 1], 1] - plans[o, slot, first, 1]
                off_y = plans[o, src[i, 0], src[i, 1], 2] - plans[o, slot, first, 2]
            n_side = src[i, 3 * side + 2]
            if slot < 0:
                for j in range(n_side):
                    coords[pos + j, 0] = pair_xy[first + j, 0]
                    coords[pos + j, 1] = pair_xy[first + j, 1]
            else:
                _along_segs(
                    plans[owner[i], slot],
                    segs[owner[i], slot],
                    first,
                    raw[i, side],
                    common[i],
                    n_side,
                    off_x,
                    off_y,
                    coords,
                    pos,
                )
            index[pos : pos + n_side] = g + side
            pos += n_side
        table[i, OWNER] = owner[i]
        table[i, WEIGHT] = weight[i]
        table[i, GEOM] = g
        if multi:
            table[i, DIRECT] = np.nan
            table[i, SLOT] = g // 2
            at_geos = pos
            g_geos += 2
        else:
            # The one point and the other sequence (P's point when both have one).
            one = start if lp == 1 else start + lp
            other = start + lp if lp == 1 else start
            n_other = lq if lp == 1 else lp
            best = -np.inf
            for j in range(other, other + n_other):
                d = np.hypot(coords[j, 0] - coords[one, 0], coords[j, 1] - coords[one, 1])
                if d > best:
                    best = d
            table[i, DIRECT] = best
            table[i, SLOT] = -1
            at_one = pos
            g_one += 2
    return coords, index, table, geos_points, n_geos


@kernel
def _combine(distances, table, n_ch, n_out):  # pragma: no cover - compiled
    """Row 0: chpps of each channel (sum_j w_j inv(fd_j) / sum_j w_j in rank order), then the
    Fréchet distance of each given pair; row 1: 1.0 where row 0 holds a value."""
    out = np.zeros((2, n_out))
    num = np.zeros(n_out)
    den = np.zeros(n_out)
    for i in range(table.shape[0]):
        o = int(table[i, OWNER])
        slot = int(table[i, SLOT])
        d = distances[slot] if slot >= 0 else table[i, DIRECT]
        w = table[i, WEIGHT]
        num[o] += w / (1.0 + d)
        den[o] += w
        out[0, o] = d
        out[1, o] = 1.0
    for o in range(n_ch):
        if out[1, o] > 0.0:
            out[0, o] = num[o] / den[o]
    return out


def tick_rows(n_channels: int, n_pairs: int) -> dict[str, int]:
    """The motion family's output rows (`_finish`, `prediction.ompv_tick`): the first row of
    the per-channel chpps, of the per-channel ompv and of the per-pair crpps, then `worst`:
    the unsuffixed chpps, ompv, crpps and crpps_mean in that order; `size` rows in all."""
    worst = 2 * n_channels + n_pairs
    return {
        "chpps": 0,
        "ompv": n_channels,
        "crpps": 2 * n_channels,
        "worst": worst,
        "size": worst + 4,
    }


@kernel
def decay_weights(decay, n):  # pragma: no cover - compiled
    """w_j = decay ** j for the ranks j < n, as `_cut` computes each (`_tick_cut` reads them
    from this table instead of a power per pair)."""
    out = np.empty(n)
    for rank in range(n):
        out[rank] = decay ** float(rank)
    return out


@kernel
def _push_plan(plans, segs, lens, times, count, head, c, t, plan, max_gap):  # pragma: no cover
    """`PlanHistory.push` of channel c's plan at t (the buffer wide enough), by the same rule:
    the history restarts when t is more than max_gap (+1e-9 s) after the channel's newest
    plan."""
    n = plan.shape[0]
    slots = lens.shape[1]
    k = count[c]
    h = head[c]
    if k > 0 and t - times[c, h] > max_gap + 1e-9:
        k = 0
    slot = (h + 1) % slots
    for r in range(n):
        plans[c, slot, r, 0] = plan[r, 0]
        plans[c, slot, r, 1] = plan[r, 1]
        plans[c, slot, r, 2] = plan[r, 2]
    _segments(plans[c, slot], n, segs[c, slot])
    lens[c, slot] = n
    times[c, slot] = t
    count[c] = min(k + 1, slots)
    head[c] = slot


@kernel
def _tick_cut(
    t,
    plans_now,
    given,
    n_given,
    plans,
    segs,
    lens,
    times,
    count,
    head,
    max_gap,
    weights,
    coords,
    starts,
    table,
    push,
):  # pragma: no cover - compiled
    """The tick's plans pushed (when `push`: channel c's plan `plans_now[c]` joins its history
    when it is not empty; an absent channel's is empty), then `_cut`'s pairs of the tick, in its
    order and with its arithmetic, written into the history's work space: line g of the
    Fréchet batch is `coords[starts[g]:starts[g + 1]]` (pair m: lines 2m and 2m + 1),
    `table[:k]` the pair table (`_cut`'s columns; OWNER n_channels + i: the i-th given pair).
    `given[i]` (i < n_given) is (present, P, Q): the crpps inputs of pair i (`given` holds one
    absent entry when there is no pair).

    Returns (status, k, n_geos, need): status 0 done; 1 a plan is longer than the buffer is
    wide (need: its length; nothing pushed); 2 `coords` holds fewer than `need` points (the
    plans were pushed: grow it and call again with `push` off)."""
    n_ch, slots = lens.shape
    if push:
        for c in range(n_ch):  # every plan fits before any is pushed: a refusal changes nothing
            if plans_now[c].shape[0] > plans.shape[2]:
                return 1, 0, 0, plans_now[c].shape[0]
        for c in range(n_ch):
            if plans_now[c].shape[0] > 0:
                _push_plan(plans, segs, lens, times, count, head, c, t, plans_now[c], max_gap)
    cap = n_given + n_ch * (slots - 1)
    # per pair: slot, start, length of its first and second sequence (slot -1: a given pair;
    # start then its index among the given pairs)
    src = np.empty((cap, 6), dtype=np.int64)
    owner = np.empty(cap, dtype=np.int64)
    weight = np.empty(cap)
    raw = np.empty((cap, 2), dtype=np.int64)  # chpps pairs: the cut lengths before resampling
    common = np.empty(cap)  # chpps pairs: the path length both cover [m]
    k = 0
    for i in range(n_given):
        if not given[i][0]:
            continue
        src[k, 0] = -1
        src[k, 1] = i
        src[k, 2] = given[i][1].shape[0]
        src[k, 3] = -1
        src[k, 4] = i
        src[k, 5] = given[i][2].shape[0]
        owner[k] = n_ch + i
        weight[k] = 1.0
        k += 1
    for c in range(n_ch):
        if count[c] == 0:
            continue
        h = head[c]
        nc = lens[c, h]
        if times[c, h] != t or nc == 0:
            continue  # no plan from this frame: no value
        cur = plans[c, h, :, 0]
        c0 = cur[0]
        c1 = cur[nc - 1]
        for rank in range(count[c] - 1):
            s = (h - 1 - rank + slots) % slots
            ns = lens[c, s]
            if ns == 0:
                continue
            age = t - times[c, s]
            sdt = plans[c, s, :, 0]
            lo = max(c0, sdt[0] - age) - TIME_EPS
            hi = min(c1, sdt[ns - 1] - age) + TIME_EPS
            if lo > hi:
                continue
            a = _bisect(cur, nc, lo, False)
            b = _bisect(cur, nc, hi, True)
            sa = _bisect(sdt, ns, lo + age, False)
            sb = _bisect(sdt, ns, hi + age, True)
            if a >= b or sa >= sb:
                continue  # Decision: a common range with no sample of one plan is no overlap
            n_out = max(b - a, sb - sa)
            src[k, 0] = h
            src[k, 1] = a
            src[k, 2] = n_out
            src[k, 3] = s
            src[k, 4] = sa
            src[k, 5] = n_out
            raw[k, 0] = b - a
            raw[k, 1] = sb - sa
            common[k] = min(
                _arc_length_segs(segs[c, h], a, b - a), _arc_length_segs(segs[c, s], sa, sb - sa)
            )
            owner[k] = c
            # Decision: j is the rank among stored plans (1 = most recent), skipped included.
            weight[k] = weights[rank]  # decay ** float(rank) (`decay_weights`)
            k += 1
    n_geos = 0
    geos_points = 0
    total = 0
    for i in range(k):
        total += src[i, 2] + src[i, 5]
        if src[i, 2] > 1 and src[i, 5] > 1:
            n_geos += 1
            geos_points += src[i, 2] + src[i, 5]
    if total > coords.shape[0]:
        return 2, 0, 0, total
    at_geos = 0  # next point of the multi-point part
    m_geos = 0  # next pair of it
    at_one = geos_points  # next point of the one-point part
    starts[0] = 0
    for i in range(k):
        lp = src[i, 2]
        lq = src[i, 5]
        multi = lp > 1 and lq > 1
        pos = at_geos if multi else at_one
        start = pos
        for side in range(2):
            slot = src[i, 3 * side]
            first = src[i, 3 * side + 1]
            n_side = src[i, 3 * side + 2]
            if multi:
                starts[2 * m_geos + side] = pos
            if slot < 0:
                seq = given[first][2] if side else given[first][1]
                for j in range(n_side):
                    coords[pos + j, 0] = seq[j, 0]
                    coords[pos + j, 1] = seq[j, 1]
            else:
                # spi-reference chpps Decision: the stored plan moves onto the current plan's
                # first common point (a plan that moves with the localisation estimate is not
                # unstable)
                o = owner[i]
                off_x = 0.0
                off_y = 0.0
                if side == 1:
                    off_x = plans[o, src[i, 0], src[i, 1], 1] - plans[o, slot, first, 1]
                    off_y = plans[o, src[i, 0], src[i, 1], 2] - plans[o, slot, first, 2]
                _along_segs(
                    plans[o, slot],
                    segs[o, slot],
                    first,
                    raw[i, side],
                    common[i],
                    n_side,
                    off_x,
                    off_y,
                    coords,
                    pos,
                )
            pos += n_side
        table[i, OWNER] = owner[i]
        table[i, WEIGHT] = weight[i]
        table[i, GEOM] = 0.0
        if multi:
            table[i, DIRECT] = np.nan
            table[i, SLOT] = m_geos
            m_geos += 1
            starts[2 * m_geos] = pos
            at_geos = pos
        else:
            # The one point and the other sequence (P's point when both have one).
            one = start if lp == 1 else start + lp
            other = start + lp if lp == 1 else start
            n_other = lq if lp == 1 else lp
            best = -np.inf
            for j in range(other, other + n_other):
                d = np.hypot(coords[j, 0] - coords[one, 0], coords[j, 1] - coords[one, 1])
                if d > best:
                    best = d
            table[i, DIRECT] = best
            table[i, SLOT] = -1
            at_one = pos
    return 0, k, n_geos, 0


@kernel
def _worst_row(vals, has, first, n, row):  # pragma: no cover - compiled
    """vals[row] = `family.worst` (use_max False) of vals[first:first + n]: no value when
    there are none or one has none, else Python's `min` (the first of equal values; a NaN
    first stays, a later one is passed over)."""
    if n == 0:
        has[row] = False
        return
    best = vals[first]
    for j in range(first, first + n):
        if not has[j]:
            has[row] = False
            return
        if vals[j] < best:
            best = vals[j]
    vals[row] = best
    has[row] = True


@kernel
def _finish(distances, table, k, n_ch, n_pairs, vals, has, nones, fd):  # pragma: no cover
    """The chpps and crpps rows of the motion family's output (`tick_rows`) from the tick's
    pair table and Fréchet distances, as `_combine` and the family computed them (chpps:
    sum_j w_j inv(fd_j) / sum_j w_j in table order; crpps: inv(fd) per pair), then the
    unsuffixed rows (the ompv rows are written before) and the rows with no value.

    Returns (mask, count, mean_left): `nones[:count]` the rows with no value, `mask` their bits
    (-1 beyond 62 rows); mean_left: crpps_mean is the caller's to compute from the pairs'
    distances, written into `fd` (three pairs or more: numpy's pairwise sum)."""
    num = np.zeros(n_ch)
    den = np.zeros(n_ch)
    crpps = 2 * n_ch
    for c in range(n_ch):
        has[c] = False
    for i in range(n_pairs):
        has[crpps + i] = False
    for r in range(k):
        o = int(table[r, OWNER])
        slot = int(table[r, SLOT])
        d = distances[slot] if slot >= 0 else table[r, DIRECT]
        if o < n_ch:
            w = table[r, WEIGHT]
            num[o] += w / (1.0 + d)
            den[o] += w
            has[o] = True
        else:
            fd[o - n_ch] = d
            has[crpps + o - n_ch] = True
    for c in range(n_ch):
        if has[c]:
            vals[c] = num[c] / den[c]
    all_pairs = n_pairs > 0
    for i in range(n_pairs):
        if has[crpps + i]:
            vals[crpps + i] = 1.0 / (1.0 + fd[i])
        else:
            all_pairs = False
    worst = crpps + n_pairs
    _worst_row(vals, has, 0, n_ch, worst)
    _worst_row(vals, has, n_ch, n_ch, worst + 1)
    _worst_row(vals, has, crpps, n_pairs, worst + 2)
    # Decision: no crpps_mean when any pair has none.
    mean_left = all_pairs and n_pairs > 2
    has[worst + 3] = all_pairs and not mean_left
    if has[worst + 3]:
        # np.add.reduce of one value is that value, of two their sum
        mean = fd[0] if n_pairs == 1 else (fd[0] + fd[1]) / 2
        vals[worst + 3] = 1.0 / (1.0 + mean)
    n_rows = worst + 4
    count = 0
    mask = 0
    for j in range(n_rows):
        if not has[j]:
            nones[count] = j
            count += 1
            if n_rows <= 62:
                mask |= 1 << j
    if n_rows > 62:
        mask = -1
    return mask, count, mean_left


_NO_XY = np.zeros((0, 2))
_NO_LENS = np.zeros(0, dtype=np.int64)
_NO_DISTANCES = np.zeros(0)


def frame_inputs(
    history: PlanHistory,
    t: float,
    decay: float,
    pairs: Sequence[tuple[np.ndarray, np.ndarray] | None] = (),
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
    """`_cut` of the frame at time `t`: `pairs` are extra (P, Q) (n, 2) point-sequence pairs
    (the crpps inputs; None entries are skipped) that go first. See `_cut` for the result."""
    given = [x for x in pairs if x is not None]
    if given:
        seqs = [s for pair in given for s in pair]
        xy = np.concatenate(seqs)
        lens = np.array([len(s) for s in seqs], dtype=np.int64)
    else:
        xy, lens = _NO_XY, _NO_LENS
    return _cut(
        history.plans,
        history.segs,
        history.lens,
        history.times,
        history.count,
        history.head,
        t,
        decay,
        xy,
        lens,
    )


def chpps_frame(
    history: PlanHistory,
    t: float,
    decay: float,
    pairs: Sequence[tuple[np.ndarray, np.ndarray] | None] = (),
) -> tuple[list[float | None], list[float | None]]:
    """chpps of every channel of `history` at frame time `t` (None: no plan from this frame,
    or no stored plan overlaps), and the discrete Fréchet distance of each of `pairs` (None
    for a None entry), with one `frechet_pairs` call for all of them (spi-reference "Discrete
    Fréchet distance"). Push the frame's plans into `history` first."""
    coords, index, table, n_points, n_geos = frame_inputs(history, t, decay, pairs)
    distances = frechet_pairs(coords[:n_points], index[:n_points]) if n_geos else _NO_DISTANCES
    n_ch = len(history.count)
    values, has = _combine(distances, table, n_ch, n_ch + len(pairs) - pairs.count(None)).tolist()
    chpps_values = [v if h else None for v, h in zip(values[:n_ch], has[:n_ch], strict=True)]
    fd = iter(values[n_ch:])
    return chpps_values, [None if x is None else next(fd) for x in pairs]


def chpps(
    current: np.ndarray, stored: Sequence[tuple[float, np.ndarray]], decay: float
) -> float | None:
    """Channel Planned Path Similarity of one plan against stored ones.

    `current` (N, 3) plan; `stored` the earlier plans, most recent first, as (age [s], plan).
    Stored plan j (rank j = 1 most recent) is shifted into the current time base (dt - age),
    both plans are clipped to their common time range, f_j = inv(fd). Score = weighted mean
    with w_j = k^(j-1) over the stored plans that overlap; None when none overlaps. (The
    engine keeps a `PlanHistory` and calls `chpps_frame`; this builds one for a single call.)
    """
    if len(current) == 0:
        return None
    width = max([len(current)] + [len(p) for _, p in stored])
    history = PlanHistory(1, max(len(stored), 1), float("inf"), width)
    for age, plan in reversed(stored):
        history.push(0, -age, plan)  # at t = 0, so that t - (-age) == age exactly
    history.push(0, 0.0, current)
    return chpps_frame(history, 0.0, decay)[0][0]
