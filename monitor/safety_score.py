"""Safety score: time to collision and post-encroachment time of plans against world models.

spi-reference "Safety score". For an ordered channel pair (i, j) the ego footprint of channel i
is swept along plan i, and each object of channel j along its prediction, on the plan's time
grid. All ordered pairs whose plans share a time grid (the usual case) are computed in one
vectorised pass: per-call numpy overhead, not arithmetic, dominates at this size.

Exact footprint tests run only on candidates that survive numpy prefilters (bounding circles of
CHUNK-point runs of both sweeps, then bounding circles per time pair):

- box footprints: a closed-form separating-axis test (exact for oriented boxes);
- convex polygons: a vectorised separating-axis test over their vertices;
- non-convex polygons: `shapely.intersects`, vectorised over their candidates.

Touching counts as intersecting everywhere, like shapely's `intersects`.

Decision (grid reading of PET): the ego "occupies the shared region" at plan time t_n when its
footprint there intersects the object's footprint at grid time t_m; PET is the smallest
|t_n - t_m| over such pairs, for objects with no intersection at equal times (n = m).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely

from monitor.frames import ChannelState, Ego, Objects, place
from monitor.prediction import interpolate_tracks


def _directions(centres: np.ndarray, fallback: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heading (cos, sin) at each grid point: the tangent of the segment leaving it (the last
    point keeps the last segment's); a zero-length segment keeps the previous heading, and
    before any motion the `fallback` heading (the vehicle's yaw) holds.

    centres (..., T, 2), fallback (...). Unit vectors, not angles: no arctan2/cos/sin needed.
    """
    seg_x = centres[..., 1:, 0] - centres[..., :-1, 0]
    seg_y = centres[..., 1:, 1] - centres[..., :-1, 1]
    length = np.hypot(seg_x, seg_y)
    ok = length > 1e-9
    if ok.all():
        c = seg_x / length
        s = seg_y / length
    else:
        safe = np.where(ok, length, 1.0)
        c = seg_x / safe
        s = seg_y / safe
        t = seg_x.shape[-1]
        last = np.maximum.accumulate(np.where(ok, np.arange(t), -1), axis=-1)
        moved = last >= 0
        idx = np.maximum(last, 0)
        fb = np.asarray(fallback, dtype=float)[..., None]
        c = np.where(moved, np.take_along_axis(c, idx, axis=-1), np.cos(fb))
        s = np.where(moved, np.take_along_axis(s, idx, axis=-1), np.sin(fb))
    return np.concatenate([c, c[..., -1:]], axis=-1), np.concatenate([s, s[..., -1:]], axis=-1)


def convex_intersects(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Separating-axis test for convex polygons a (C, Va, 2), b (C, Vb, 2): (C,) bool.

    Zero-length edges (padding) give zero axes, which never separate, so padding is harmless.
    """
    ea = np.roll(a, -1, axis=1) - a
    eb = np.roll(b, -1, axis=1) - b
    axes = np.concatenate([ea, eb], axis=1)[..., ::-1] * np.array([1.0, -1.0])
    pa = np.einsum("cad,cvd->cav", axes, a)
    pb = np.einsum("cad,cvd->cav", axes, b)
    separated = (pa.max(-1) < pb.min(-1)) | (pb.max(-1) < pa.min(-1))
    return ~separated.any(-1)


#: Grid points per chunk in the coarse (chunk-pair) prefilter of the PET search.
CHUNK = 5


def _runs(values: np.ndarray) -> np.ndarray:
    """(..., N) -> (..., C, CHUNK): consecutive runs of CHUNK grid points, the last run padded
    by repeating the last point (a real grid point)."""
    n = values.shape[-1]
    nc = -(-n // CHUNK)
    pad = nc * CHUNK - n
    if pad:
        values = np.concatenate([values, np.repeat(values[..., -1:], pad, axis=-1)], axis=-1)
    return values.reshape(*values.shape[:-1], nc, CHUNK)


def _chunk_circles(
    run_x: np.ndarray, run_y: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounding circles of the runs (..., C, CHUNK): centre x, centre y, radius (..., C)
    (footprint radii are added by the caller)."""
    mx = 0.5 * (run_x.max(axis=-1) + run_x.min(axis=-1))
    my = 0.5 * (run_y.max(axis=-1) + run_y.min(axis=-1))
    ox = run_x - mx[..., None]
    oy = run_y - my[..., None]
    return mx, my, np.sqrt(np.max(ox * ox + oy * oy, axis=-1))


def boxes_intersect(
    dx: np.ndarray,
    dy: np.ndarray,
    ca: np.ndarray,
    sa: np.ndarray,
    la: np.ndarray | float,
    wa: np.ndarray | float,
    cb: np.ndarray,
    sb: np.ndarray,
    lb: np.ndarray,
    wb: np.ndarray,
) -> np.ndarray:
    """Closed-form separating-axis test for oriented boxes: (C,) bool, touching intersects.

    Box a has heading (cos, sin) = (ca, sa) and half extents (la, wa); box b likewise; (dx, dy)
    is centre b minus centre a. On each of the four box axes the other box projects to
    l |cos| + w |sin| around its centre, so four comparisons decide: the same test as
    `convex_intersects`, without building vertices.
    """
    cd = np.abs(ca * cb + sa * sb)  # |cos(hb - ha)|
    sd = np.abs(sb * ca - cb * sa)  # |sin(hb - ha)|
    sep = np.abs(dx * ca + dy * sa) > la + lb * cd + wb * sd
    sep |= np.abs(dy * ca - dx * sa) > wa + lb * sd + wb * cd
    sep |= np.abs(dx * cb + dy * sb) > lb + la * cd + wa * sd
    sep |= np.abs(dy * cb - dx * sb) > wb + la * sd + wa * cd
    return ~sep


class _Movers:
    """Footprints moving on a common time grid, (M, N) arrays: centres x, y, heading as
    (cos, sin), chunk circles (M, C) with the footprint radius included, and per mover the
    radius, box half extents (NaN for polygons), convexity and body-frame polygon."""

    __slots__ = (
        "all_boxes",
        "axis_hi",
        "axis_lo",
        "axis_x",
        "axis_y",
        "chunk_r",
        "chunk_x",
        "chunk_y",
        "convex",
        "cos",
        "cosf",
        "footprints",
        "half",
        "hi_x",
        "hi_y",
        "hl",
        "hl_or_nan",
        "hw",
        "hw_or_nan",
        "lo_x",
        "lo_y",
        "radius",
        "run_cos",
        "run_sin",
        "run_x",
        "run_y",
        "sin",
        "sinf",
        "x",
        "xf",
        "y",
        "yf",
    )  # fmt: skip

    def __init__(self, centres: np.ndarray, direction: tuple[np.ndarray, np.ndarray],
                 radius: np.ndarray,
                 half: np.ndarray, convex: np.ndarray, footprints: list[np.ndarray],
                 lateral: bool = True):  # fmt: skip
        self.x = centres[..., 0]
        self.y = centres[..., 1]
        self.cos, self.sin = direction
        # Flat copies: candidates are gathered with `take` on (mover * N + time) indices,
        # several times faster than 2-D fancy indexing.
        self.xf = self.x.ravel()
        self.yf = self.y.ravel()
        self.cosf = self.cos.ravel()
        self.sinf = self.sin.ravel()
        # (M * C, CHUNK) runs of the grid, flattened over movers for row gathers
        run_x = _runs(self.x)
        run_y = _runs(self.y)
        self.chunk_x, self.chunk_y, rad = _chunk_circles(run_x, run_y)
        self.chunk_r = rad + radius[:, None]
        # stored transposed, (CHUNK, M * C), so a column gather is contiguous per run offset
        self.run_x = np.ascontiguousarray(run_x.reshape(-1, CHUNK).T)
        self.run_y = np.ascontiguousarray(run_y.reshape(-1, CHUNK).T)
        self.run_cos = np.ascontiguousarray(_runs(self.cos).reshape(-1, CHUNK).T)
        self.run_sin = np.ascontiguousarray(_runs(self.sin).reshape(-1, CHUNK).T)
        half_l = half[:, 0] if half is not None else np.full(len(radius), np.nan)
        half_w = half[:, 1] if half is not None else np.full(len(radius), np.nan)
        self.radius = radius
        # bounding box of the whole sweep, footprint included
        self.lo_x = self.x.min(axis=1) - radius
        self.hi_x = self.x.max(axis=1) + radius
        self.lo_y = self.y.min(axis=1) - radius
        self.hi_y = self.y.max(axis=1) + radius
        self.half = half
        self.hl = np.ascontiguousarray(half[:, 0]) if half is not None else None
        self.hw = np.ascontiguousarray(half[:, 1]) if half is not None else None
        self.hl_or_nan = half_l
        self.hw_or_nan = half_w
        self.all_boxes = half is not None and not np.isnan(half[:, 0]).any()
        self.convex = convex
        self.footprints = footprints
        if lateral:
            # Per run: the unit normal of its first point's heading (the lateral axis) and the
            # interval that the run's footprints cover on it. A separating axis for the union
            # of a run's footprints separates every pair within it, so this is a
            # conservative, orientation-aware prefilter (parallel traffic in the next lane
            # passes the circle tests but not this one).
            nc = run_x.shape[1]
            self.axis_x = -self.run_sin[0]
            self.axis_y = self.run_cos[0]
            self.axis_lo, self.axis_hi = self.run_interval(
                np.arange(self.run_x.shape[1]),
                np.repeat(half_l, nc),
                np.repeat(half_w, nc),
                np.repeat(radius, nc),
                self.axis_x,
                self.axis_y,
            )

    def run_interval(
        self,
        rows: np.ndarray,
        half_l: np.ndarray,
        half_w: np.ndarray,
        radius: np.ndarray,
        ax: np.ndarray,
        ay: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Interval (lo, hi) per run row covered on axis (ax, ay) by the run's footprints:
        a box projects to l |u . a| + w |v . a| around its centre, a polygon (NaN half
        extents) to its bounding radius."""
        px = self.run_x.take(rows, axis=1)
        py = self.run_y.take(rows, axis=1)
        c = self.run_cos.take(rows, axis=1)
        s = self.run_sin.take(rows, axis=1)
        centre = px * ax + py * ay
        rad = half_l * np.abs(c * ax + s * ay) + half_w * np.abs(c * ay - s * ax)
        if np.isnan(half_l).any():
            rad = np.where(np.isnan(half_l), radius, rad)
        return (centre - rad).min(axis=0), (centre + rad).max(axis=0)


def _egos(plans: Sequence[np.ndarray], egos: Sequence[Ego]) -> _Movers:
    centres = np.stack([p[:, 1:3] for p in plans])
    heading = _directions(centres, np.array([e.yaw for e in egos]))
    return _Movers(
        centres,
        heading,
        np.array([e.radius for e in egos]),
        np.array([e.half if e.half is not None else (np.nan, np.nan) for e in egos]),
        np.array([e.convex for e in egos]),
        [e.footprint for e in egos],
    )


def _reachable(objects: Objects, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(K,) bool: objects whose every possible position (current position and prediction
    points; interpolation stays in their bounding box) plus footprint radius can touch the box
    [lo, hi] that holds all ego sweeps (footprints included)."""
    pos = objects.pos
    r = objects.radii
    if objects.pred.shape[1]:
        px = objects.pred[:, :, 1]
        py = objects.pred[:, :, 2]
        if (objects.pred_len == 0).any():  # rows without prediction hold padding zeros
            none = (objects.pred_len == 0)[:, None]
            px = np.where(none, pos[:, 0:1], px)
            py = np.where(none, pos[:, 1:2], py)
        x0 = np.minimum(px.min(axis=1), pos[:, 0])
        x1 = np.maximum(px.max(axis=1), pos[:, 0])
        y0 = np.minimum(py.min(axis=1), pos[:, 1])
        y1 = np.maximum(py.max(axis=1), pos[:, 1])
    else:
        x0 = x1 = pos[:, 0]
        y0 = y1 = pos[:, 1]
    return (x0 - r <= hi[0]) & (x1 + r >= lo[0]) & (y0 - r <= hi[1]) & (y1 + r >= lo[1])


def _objects(
    worlds: Sequence[Objects], keep: Sequence[np.ndarray], times: np.ndarray
) -> tuple[_Movers, np.ndarray]:
    """The kept objects of all world models on the grid, and each one's world index."""
    pos = np.concatenate([o.pos[m] for o, m in zip(worlds, keep, strict=True)])
    pred_shapes = {o.pred.shape[1] for o in worlds}
    if len(pred_shapes) == 1:
        # Same padded prediction length everywhere (the usual case): one interpolation.
        pred = np.concatenate([o.pred[m] for o, m in zip(worlds, keep, strict=True)])
        plen = np.concatenate([o.pred_len[m] for o, m in zip(worlds, keep, strict=True)])
        centres = interpolate_tracks(pos, pred, plen, times)
    else:
        centres = np.concatenate(
            [
                interpolate_tracks(o.pos[m], o.pred[m], o.pred_len[m], times)
                for o, m in zip(worlds, keep, strict=True)
            ]
        )
    yaw = np.concatenate([o.yaw[m] for o, m in zip(worlds, keep, strict=True)])
    owner = np.repeat(np.arange(len(worlds)), [int(m.sum()) for m in keep])
    movers = _Movers(
        centres,
        _directions(centres, yaw),
        np.concatenate([o.radii[m] for o, m in zip(worlds, keep, strict=True)]),
        np.concatenate([o.half[m] for o, m in zip(worlds, keep, strict=True)]),
        np.concatenate([o.convex[m] for o, m in zip(worlds, keep, strict=True)]),
        [fp for o, m in zip(worlds, keep, strict=True) for fp in o.footprints[m]],
        lateral=False,
    )
    return movers, owner


def _exact(
    eg: _Movers, ob: _Movers, i: np.ndarray, k: np.ndarray, fi: np.ndarray, fk: np.ndarray
) -> np.ndarray:
    """Exact footprint tests of ego i against object k, at the flat grid indices fi = i * N + n
    and fk = k * N + m: (C,) bool."""
    if eg.all_boxes and ob.all_boxes:
        return boxes_intersect(
            ob.xf.take(fk) - eg.xf.take(fi), ob.yf.take(fk) - eg.yf.take(fi),
            eg.cosf.take(fi), eg.sinf.take(fi), eg.hl.take(i), eg.hw.take(i),
            ob.cosf.take(fk), ob.sinf.take(fk), ob.hl.take(k), ob.hw.take(k),
        )  # fmt: skip
    ehalf = eg.half[i]
    ohalf = ob.half[k]
    boxes = ~(np.isnan(ehalf[:, 0]) | np.isnan(ohalf[:, 0]))
    hit = np.zeros(len(k), dtype=bool)
    if boxes.any():
        bfi, bfk = fi[boxes], fk[boxes]
        hit[boxes] = boxes_intersect(
            ob.xf.take(bfk) - eg.xf.take(bfi), ob.yf.take(bfk) - eg.yf.take(bfi),
            eg.cosf.take(bfi), eg.sinf.take(bfi), ehalf[boxes, 0], ehalf[boxes, 1],
            ob.cosf.take(bfk), ob.sinf.take(bfk), ohalf[boxes, 0], ohalf[boxes, 1],
        )  # fmt: skip
    hf = np.arctan2(eg.sinf, eg.cosf)
    ohf = np.arctan2(ob.sinf, ob.cosf)
    for row in np.nonzero(~boxes)[0]:
        # Polygon footprints are rare; one candidate at a time keeps ragged vertex counts simple.
        a = place(eg.footprints[i[row]], np.array([eg.xf[fi[row]], eg.yf[fi[row]]]), hf[fi[row]])
        b = place(ob.footprints[k[row]], np.array([ob.xf[fk[row]], ob.yf[fk[row]]]), ohf[fk[row]])
        if eg.convex[i[row]] and ob.convex[k[row]]:
            hit[row] = convex_intersects(a[None], b[None])[0]
        else:
            hit[row] = shapely.intersects(shapely.polygons(a), shapely.polygons(b))
    return hit


def score_grid(
    plans: Sequence[np.ndarray],
    egos: Sequence[Ego],
    worlds: Sequence[Objects],
    pet_ref: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ss, ttc, pet), each (I, J): plans I (all on the same time grid, >= 2 points) with their
    egos against world models J (each with >= 1 object).

    TTC first (equal times only); PET then only needs time pairs with
    |t_n - t_m| < pet_ref * min(1, ttc / H), since larger ones cannot lower the score.
    """
    times = plans[0][:, 0]
    horizon = float(times[-1])
    n_i, n_j = len(plans), len(worlds)
    eg = _egos(plans, egos)
    ttc = np.full((n_i, n_j), np.inf)
    # Prefilter 0: objects that can come near any ego sweep at all, before interpolating.
    box_lo = np.array([eg.lo_x.min(), eg.lo_y.min()])
    box_hi = np.array([eg.hi_x.max(), eg.hi_y.max()])
    keep = [_reachable(o, box_lo, box_hi) for o in worlds]
    if not any(m.any() for m in keep):
        return np.ones((n_i, n_j)), ttc, np.full((n_i, n_j), np.inf)
    ob, owner = _objects(worlds, keep, times)
    pet = np.full((n_i, n_j), np.inf)
    # Prefilter 1: bounding boxes of the whole sweeps, (ego i, object k) pairs that can meet.
    pi, pk = np.nonzero(
        (ob.lo_x[None] <= eg.hi_x[:, None])
        & (ob.hi_x[None] >= eg.lo_x[:, None])
        & (ob.lo_y[None] <= eg.hi_y[:, None])
        & (ob.hi_y[None] >= eg.lo_y[:, None])
    )
    if len(pi) == 0:
        return np.ones((n_i, n_j)), ttc, pet
    # TTC: the diagonal n = m, bounding circles, then the exact test.
    dx = ob.x[pk] - eg.x[pi]
    dy = ob.y[pk] - eg.y[pi]
    reach = eg.radius[pi] + ob.radius[pk]
    cp, cn = np.nonzero(dx * dx + dy * dy <= (reach * reach)[:, None])
    colliding = np.zeros(len(pi), dtype=bool)
    if len(cp):
        n_pts = len(times)
        hit = _exact(eg, ob, pi[cp], pk[cp], pi[cp] * n_pts + cn, pk[cp] * n_pts + cn)
        if hit.any():
            np.minimum.at(ttc, (pi[cp[hit]], owner[pk[cp[hit]]]), times[cn[hit]])
            colliding[cp[hit]] = True
    limit = pet_ref * np.minimum(1.0, ttc / horizon)
    # PET: only pairs that never meet at equal times, within their time limit.
    lim = np.where(colliding, -np.inf, limit[pi, owner[pk]])
    keep = lim > 0
    if keep.any():
        _pet(eg, ob, owner, times, pi[keep], pk[keep], lim[keep], pet)
    ss = np.minimum(1.0, np.minimum(ttc / horizon, pet / pet_ref))
    return ss, ttc, pet


def _pet(
    eg: _Movers,
    ob: _Movers,
    owner: np.ndarray,
    times: np.ndarray,
    pi: np.ndarray,
    pk: np.ndarray,
    limit: np.ndarray,
    pet: np.ndarray,
) -> None:
    """Lower pet[i, j] to the smallest |t_n - t_m| < limit at which ego i (time n) meets
    object k of world j (time m), for the candidate pairs (pi, pk) with their limits."""
    n_pts = eg.x.shape[1]
    nc = eg.chunk_x.shape[1]
    starts = np.arange(nc) * CHUNK
    t_lo = times[starts]
    t_hi = times[np.minimum(starts + CHUNK - 1, n_pts - 1)]
    gap = np.maximum(t_lo[:, None] - t_hi[None, :], t_lo[None, :] - t_hi[:, None])
    # (pair, ego chunk, object chunk); gap < 0 means overlapping time ranges
    dx = eg.chunk_x[pi][:, :, None] - ob.chunk_x[pk][:, None, :]
    dy = eg.chunk_y[pi][:, :, None] - ob.chunk_y[pk][:, None, :]
    reach = eg.chunk_r[pi][:, :, None] + ob.chunk_r[pk][:, None, :]
    near = (dx * dx + dy * dy <= reach * reach) & (gap[None] < limit[:, None, None])
    cp, ca, cb = np.nonzero(near)
    if len(cp) == 0:
        return
    i = pi.take(cp)
    k = pk.take(cp)
    er = i * nc + ca
    orow = k * nc + cb
    # Lateral separating axis of the ego run: drop chunk pairs it separates.
    lo, hi = ob.run_interval(
        orow, ob.hl_or_nan.take(k), ob.hw_or_nan.take(k), ob.radius.take(k),
        eg.axis_x.take(er), eg.axis_y.take(er),
    )  # fmt: skip
    sel = np.flatnonzero((lo <= eg.axis_hi.take(er)) & (hi >= eg.axis_lo.take(er)))
    if len(sel) == 0:
        return
    cp, ca, cb, i, k, er, orow = (v.take(sel) for v in (cp, ca, cb, i, k, er, orow))
    # Each remaining chunk pair compares its CHUNK ego points with its CHUNK object points by
    # broadcasting (C, CHUNK, CHUNK); only survivors become flat candidate indices.
    # (CHUNK, CHUNK, C) with the long candidate axis innermost: numpy is slow on tiny inner axes
    ex = eg.run_x.take(er, axis=1)[:, None, :]
    ey = eg.run_y.take(er, axis=1)[:, None, :]
    ox = ob.run_x.take(orow, axis=1)[None, :, :]
    oy = ob.run_y.take(orow, axis=1)[None, :, :]
    r = ob.radius.take(k) + eg.radius.take(i)
    dx = ox - ex
    dy = oy - ey
    a, b, c = np.nonzero(dx * dx + dy * dy <= r * r)
    if len(c) == 0:
        return
    # Padded run entries repeat the last grid point; n = m pairs cannot hit here (these objects
    # never meet the ego at equal times), so neither needs filtering.
    last = n_pts - 1
    n = np.minimum(ca.take(c) * CHUNK + a, last)
    m = np.minimum(cb.take(c) * CHUNK + b, last)
    dt = np.abs(times.take(n) - times.take(m))
    sel = np.flatnonzero(dt < limit.take(cp.take(c)))
    i = i.take(c).take(sel)
    k = k.take(c).take(sel)
    n = n.take(sel)
    m = m.take(sel)
    dt = dt.take(sel)
    hit = _exact(eg, ob, i, k, i * n_pts + n, k * n_pts + m)
    if hit.any():
        np.minimum.at(pet, (i[hit], owner[k[hit]]), dt[hit])


def safety_score(
    plan: np.ndarray, ego: Ego, objects: Objects, pet_ref: float
) -> tuple[float | None, float, float]:
    """(ss, ttc, pet) of one plan against one world model. ss is None for an empty plan,
    1.0 for a one-point plan (spi-reference) or no objects; ttc and pet are inf when nothing
    meets."""
    if len(plan) == 0:
        return None, math.inf, math.inf
    if len(plan) < 2 or len(objects) == 0:
        return 1.0, math.inf, math.inf
    ss, ttc, pet = score_grid([plan], [ego], [objects], pet_ref)
    return float(ss[0, 0]), float(ttc[0, 0]), float(pet[0, 0])


def safety_matrix(
    channels: list[str], states: dict[str, ChannelState], pet_ref: float
) -> dict[tuple[str, str], float | None]:
    """ss_ij for every ordered pair of declared channels: None when i or j is absent or plan i
    is empty; 1.0 when plan i has one point or channel j sees no object."""
    out: dict[tuple[str, str], float | None] = {}
    present = [c for c in channels if c in states]
    worlds = [j for j in present if len(states[j].objects)]
    grids: dict[bytes, list[str]] = {}
    for i in channels:
        for j in channels:
            out[(i, j)] = None
        if i not in states:
            continue
        plan = states[i].plan
        if len(plan) == 0:
            continue
        for j in present:
            out[(i, j)] = 1.0
        if len(plan) >= 2 and worlds:
            grids.setdefault(plan[:, 0].tobytes(), []).append(i)
    for members in grids.values():
        ss, _, _ = score_grid(
            [states[i].plan for i in members],
            [states[i].ego for i in members],
            [states[j].objects for j in worlds],
            pet_ref,
        )
        for a, i in enumerate(members):
            for b, j in enumerate(worlds):
                out[(i, j)] = float(ss[a, b])
    return out


def arbitrate(
    channels: list[str],
    matrix: dict[tuple[str, str], float | None],
    previous: str | None,
) -> str | None:
    """Recommended channel: argmax_i of min_j ss_ij over the world models present.

    Decision: a channel is a candidate when its own plan has a value against at least one world
    model; missing world models are left out (so one channel dropping out still leaves a
    recommendation). Ties keep the previous recommendation, else the first declared channel.
    None when no channel has a value.
    """
    score: dict[str, float] = {}
    for i in channels:
        vals = [matrix[(i, j)] for j in channels if matrix.get((i, j)) is not None]
        if vals:
            score[i] = min(vals)  # type: ignore[type-var]
    if not score:
        return None
    best = max(score.values())
    tied = [c for c in channels if c in score and score[c] == best]
    if previous in tied:
        return previous
    return tied[0]
