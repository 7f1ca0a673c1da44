"""Safety score: time to collision and post-encroachment time of plans against world models.

spi-reference "Safety score". For an ordered channel pair (i, j) the ego footprint of channel i
is swept along plan i, and each object of channel j along its prediction, on the plan's time
grid. All ordered pairs whose plans share a time grid (or a prefix of it) are computed in one
pass: per-call overhead, not arithmetic, dominates at this size.

Two implementations of that pass, with the same rules and the same arithmetic:

- box footprints everywhere (egos and objects; the usual case): one compiled kernel call
  (`monitor.safety_kernel`) loops over egos, objects and time pairs; only
  conservative prefilters (bounding boxes of whole sweeps and of CHUNK-point runs, bounding
  circles, time gaps, a lateral separating axis per ego run) run before the exact closed-form
  separating-axis test of two oriented boxes;
- any polygon footprint: the numpy formulation (`score_grid_numpy`), vectorised over candidate
  pairs that survive numpy prefilters (bounding circles of CHUNK-point runs of both sweeps,
  then bounding circles per time pair), with the box test for box pairs, a vectorised
  separating-axis test for convex polygons and `shapely.intersects` for non-convex ones. The
  tests also use it as the kernel's oracle.

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

from casewatch.monitor.frames import ChannelState, Ego, Objects, place
from casewatch.monitor.prediction import interpolate_tracks
from casewatch.monitor.safety_kernel import (
    BEHIND_EPS,
    CHUNK,
    MOTION_EPS,
    REAR_END_COS,
    _last_dt_max,
    _prefix_upto,
    _stands_still,
    score_boxes,
)


def _directions(centres: np.ndarray, fallback: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heading (cos, sin) at each grid point: the tangent of the segment leaving it (the last
    point keeps the last segment's); a segment shorter than MOTION_EPS keeps the previous
    heading, and before any motion the `fallback` heading (the vehicle's yaw) holds.

    centres (M, T, 2), fallback (M,). Unit vectors, not angles: no arctan2/cos/sin needed.
    """
    seg_x = centres[..., 1:, 0] - centres[..., :-1, 0]
    seg_y = centres[..., 1:, 1] - centres[..., :-1, 1]
    length = np.hypot(seg_x, seg_y)
    ok = length > MOTION_EPS
    shape = centres.shape[:-1]
    cos = np.empty(shape)
    sin = np.empty(shape)
    if ok.all():
        np.divide(seg_x, length, out=cos[..., :-1])
        np.divide(seg_y, length, out=sin[..., :-1])
    else:
        safe = np.where(ok, length, 1.0)
        t = seg_x.shape[-1]
        # index of the last moving segment up to each one (-1: none yet), as a flat index
        last = np.maximum.accumulate(np.where(ok, np.arange(t), -1), axis=-1)
        moved = last >= 0
        flat = (np.maximum(last, 0) + np.arange(len(seg_x))[:, None] * t).ravel()
        fb = np.asarray(fallback, dtype=float)[:, None]
        cos[..., :-1] = np.where(
            moved, (seg_x / safe).ravel().take(flat).reshape(moved.shape), np.cos(fb)
        )
        sin[..., :-1] = np.where(
            moved, (seg_y / safe).ravel().take(flat).reshape(moved.shape), np.sin(fb)
        )
    cos[..., -1] = cos[..., -2]
    sin[..., -1] = sin[..., -2]
    return cos, sin


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


#: Chunk pairs above which the PET search runs the lateral-axis prefilter: below, its own
#: dozen numpy calls cost more than the point pairs it would save.
LATERAL_MIN = 128
#: Objects (all worlds) above which the safety score drops those that cannot reach any ego
#: sweep before interpolating them.
REACH_MIN = 12


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
    """Footprints moving on a common time grid of L points, egos (rows 0 .. I-1) and objects
    (rows I ..) in one set of arrays, so that every setup step below is one numpy call for
    both: (M, L) centres and headings as (cos, sin); their CHUNK-point runs (stored
    (CHUNK, M * C), flattened over movers so that candidates gather columns) with bounding
    circles (M, C) including the footprint radius; the bounding box of each whole sweep; per
    mover the radius, box half extents (NaN for polygons), convexity and body-frame polygon;
    per ego run a lateral separating axis."""

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
        "cosf",
        "footprints",
        "half",
        "hi",
        "hl",
        "hw",
        "lo",
        "n_egos",
        "radius",
        "run_cos",
        "run_sin",
        "run_x",
        "run_y",
        "sinf",
        "x",
        "xf",
        "y",
        "yf",
    )

    def __init__(
        self,
        centres: np.ndarray,
        fallback: np.ndarray,
        radius: np.ndarray,
        half: np.ndarray,
        convex: np.ndarray,
        footprints: Sequence[np.ndarray],
        n_egos: int,
    ):
        m, n = centres.shape[:2]
        cos, sin = _directions(centres, fallback)
        x = centres[..., 0]
        y = centres[..., 1]
        self.x = x
        self.y = y
        # Flat copies: candidates are gathered with `take` on (mover * L + time) indices,
        # several times faster than 2-D fancy indexing.
        self.xf = x.ravel()
        self.yf = y.ravel()
        self.cosf = cos.ravel()
        self.sinf = sin.ravel()
        # All four tracks in one array, so each step below is one numpy call, not four.
        stack = np.stack([x, y, cos, sin])
        nc = -(-n // CHUNK)
        if nc * CHUNK > n:  # the last run repeats the last grid point (a real one)
            stack = np.concatenate(
                [stack, np.repeat(stack[..., -1:], nc * CHUNK - n, axis=-1)], axis=-1
            )
        # (4, CHUNK, M * C): reductions over the run run across rows, which numpy does far
        # faster than over a tiny last axis; a column gather is contiguous per run offset
        runs = np.ascontiguousarray(stack.reshape(4, m * nc, CHUNK).transpose(0, 2, 1))
        hi = runs[:2].max(axis=1)
        lo = runs[:2].min(axis=1)
        mid = 0.5 * (hi + lo)
        off = runs[:2] - mid[:, None, :]
        rad = np.sqrt((off * off).sum(axis=0).max(axis=0))
        self.chunk_x = mid[0].reshape(m, nc)
        self.chunk_y = mid[1].reshape(m, nc)
        self.chunk_r = rad.reshape(m, nc) + radius[:, None]
        # bounding box of each whole sweep, footprint included: (2, M) lower and upper corners
        self.lo = lo.reshape(2, m, nc).min(axis=-1) - radius
        self.hi = hi.reshape(2, m, nc).max(axis=-1) + radius
        self.run_x, self.run_y, self.run_cos, self.run_sin = runs
        self.radius = radius
        self.half = half
        self.hl = np.ascontiguousarray(half[:, 0])  # NaN for polygons
        self.hw = np.ascontiguousarray(half[:, 1])
        self.all_boxes = not np.isnan(self.hl).any()
        self.convex = convex
        self.footprints = footprints
        self.n_egos = n_egos
        #: the ego runs' lateral separating axes and intervals (ego_axes, on first use)
        self.axis_x: np.ndarray | None = None
        self.axis_y: np.ndarray | None = None
        self.axis_lo: np.ndarray | None = None
        self.axis_hi: np.ndarray | None = None

    def ego_axes(self) -> None:
        """Per ego run: the unit normal of its first point's heading (the lateral axis) and the
        interval that the run's footprints cover on it. A separating axis for the union of a
        run's footprints separates every pair within it, so this is a conservative,
        orientation-aware prefilter (parallel traffic in the next lane passes the circle tests
        but not this one). Computed on first use: small searches skip that prefilter."""
        if self.axis_x is not None:
            return
        n_egos = self.n_egos
        nc = self.chunk_x.shape[1]
        ego_runs = n_egos * nc
        self.axis_x = -self.run_sin[0, :ego_runs]
        self.axis_y = self.run_cos[0, :ego_runs]
        self.axis_lo, self.axis_hi = self.run_interval(
            np.arange(ego_runs),
            np.repeat(self.hl[:n_egos], nc),
            np.repeat(self.hw[:n_egos], nc),
            np.repeat(self.radius[:n_egos], nc),
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


def _ego_centres(plans: Sequence[np.ndarray], length: int) -> np.ndarray:
    """(I, L, 2) ego sweeps on the longest grid (L points). A shorter plan is padded by
    repeating its last point: zero-length segments keep its last heading, so its real points
    get exactly the poses of its own grid, and the padding (never tested) stays inside its
    real sweep."""
    if all(len(p) == length for p in plans):
        return np.stack([p[:, 1:3] for p in plans])
    centres = np.empty((len(plans), length, 2))
    for a, p in enumerate(plans):
        centres[a, : len(p)] = p[:, 1:3]
        centres[a, len(p) :] = p[-1, 1:3]
    return centres


def _reachable(objects: Objects, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(K,) bool: objects whose every possible position (current position and prediction
    points; interpolation stays in their bounding box) plus footprint radius can touch the box
    [lo, hi] that holds all ego sweeps (footprints included)."""
    pos = objects.pos
    r = objects.radii
    if objects.pred.shape[1]:
        # (K, 2, P) contiguous: numpy reduces a long last axis far faster than a middle one
        pxy = np.ascontiguousarray(objects.pred[:, :, 1:3].transpose(0, 2, 1))
        if (objects.pred_len == 0).any():  # rows without prediction hold padding zeros
            none = (objects.pred_len == 0)[:, None, None]
            pxy = np.where(none, pos[:, :, None], pxy)
        p0 = np.minimum(pxy.min(axis=2), pos) - r[:, None]
        p1 = np.maximum(pxy.max(axis=2), pos) + r[:, None]
    else:
        p0 = pos - r[:, None]
        p1 = pos + r[:, None]
    return ((p0 <= hi) & (p1 >= lo)).all(axis=1)


def _movers(
    plans: Sequence[np.ndarray],
    egos: Sequence[Ego],
    worlds: Sequence[Objects],
    times: np.ndarray,
) -> tuple[_Movers, np.ndarray] | None:
    """Egos and the objects that can reach the box holding every ego sweep, on the grid
    `times`, with each mover's world index (-1 for egos); None when no object can."""
    n_pts = len(times)
    ego_c = _ego_centres(plans, n_pts)
    ego_half = np.array([e.half if e.half is not None else (np.nan, np.nan) for e in egos])
    if np.isnan(ego_half).any():
        ego_r = np.array([e.radius for e in egos])
    else:  # the corners' distance from the centre, as Ego.radius computes it
        ego_r = np.hypot(ego_half[:, 0], ego_half[:, 1])
    if sum(len(o) for o in worlds) <= REACH_MIN:
        # Few objects: interpolating them all costs less than the reachable-box test (the
        # sweep bounding boxes drop far ones later anyway).
        keep = [np.ones(len(o), dtype=bool) for o in worlds]
        pairs = list(zip(worlds, keep, strict=True))
        every = [True] * len(pairs)
        counts = [len(o) for o in worlds]
    else:
        reach = ego_r.max()
        ex = ego_c[..., 0]
        ey = ego_c[..., 1]
        lo = np.array([ex.min() - reach, ey.min() - reach])
        hi = np.array([ex.max() + reach, ey.max() + reach])
        keep = [_reachable(o, lo, hi) for o in worlds]
        counts = [int(np.count_nonzero(m)) for m in keep]
        if not any(counts):
            return None
        pairs = [(o, m) for o, m in zip(worlds, keep, strict=True) if m.any()]
        every = [bool(m.all()) for _, m in pairs]
    # One interpolation per world: each world usually predicts on one shared grid (the
    # interpolation's fast path), but grids differ between stacks.
    tracks = [
        interpolate_tracks(o.pos, o.pred, o.pred_len, times)
        if e
        else interpolate_tracks(o.pos[m], o.pred[m], o.pred_len[m], times)
        for (o, m), e in zip(pairs, every, strict=True)
    ]

    def cat(field: str, ego_part: np.ndarray) -> np.ndarray:
        parts = [ego_part]
        for (o, m), e in zip(pairs, every, strict=True):
            v = getattr(o, field)
            parts.append(v if e else v[m])
        return np.concatenate(parts)

    movers = _Movers(
        np.concatenate([ego_c, *tracks]),
        cat("yaw", np.array([e.yaw for e in egos])),
        cat("radii", ego_r),
        cat("half", ego_half),
        cat("convex", np.array([e.convex for e in egos])),
        # a list: worlds pad their polygons to different vertex counts
        [e.footprint for e in egos]
        + [
            fp
            for (o, m), e in zip(pairs, every, strict=True)
            for fp in (o.footprints if e else o.footprints[m])
        ],
        len(plans),
    )
    owner = np.repeat(np.arange(-1, len(worlds)), [len(plans), *counts])
    return movers, owner


def _exact(
    mv: _Movers,
    i: np.ndarray,
    k: np.ndarray,
    fi: np.ndarray,
    fk: np.ndarray,
    fh: np.ndarray,
) -> np.ndarray:
    """Exact footprint tests of ego i against object k (mover rows): (C,) bool. fi = i * L + n
    and fk = k * L + m are flat grid indices of the ego and object poses; fh = k * L + m'
    indexes the object heading (m' = m except at the last point of a shorter grid, see
    score_grid)."""
    if mv.all_boxes:
        return boxes_intersect(
            mv.xf.take(fk) - mv.xf.take(fi),
            mv.yf.take(fk) - mv.yf.take(fi),
            mv.cosf.take(fi),
            mv.sinf.take(fi),
            mv.hl.take(i),
            mv.hw.take(i),
            mv.cosf.take(fh),
            mv.sinf.take(fh),
            mv.hl.take(k),
            mv.hw.take(k),
        )
    ehalf = mv.half[i]
    ohalf = mv.half[k]
    boxes = ~(np.isnan(ehalf[:, 0]) | np.isnan(ohalf[:, 0]))
    hit = np.zeros(len(k), dtype=bool)
    if boxes.any():
        bfi, bfk, bfh = fi[boxes], fk[boxes], fh[boxes]
        hit[boxes] = boxes_intersect(
            mv.xf.take(bfk) - mv.xf.take(bfi),
            mv.yf.take(bfk) - mv.yf.take(bfi),
            mv.cosf.take(bfi),
            mv.sinf.take(bfi),
            ehalf[boxes, 0],
            ehalf[boxes, 1],
            mv.cosf.take(bfh),
            mv.sinf.take(bfh),
            ohalf[boxes, 0],
            ohalf[boxes, 1],
        )
    for row in np.nonzero(~boxes)[0]:
        # Polygon footprints are rare; one candidate at a time keeps ragged vertex counts simple.
        a = place(
            mv.footprints[i[row]],
            np.array([mv.xf[fi[row]], mv.yf[fi[row]]]),
            np.arctan2(mv.sinf[fi[row]], mv.cosf[fi[row]]),
        )
        b = place(
            mv.footprints[k[row]],
            np.array([mv.xf[fk[row]], mv.yf[fk[row]]]),
            np.arctan2(mv.sinf[fh[row]], mv.cosf[fh[row]]),
        )
        if mv.convex[i[row]] and mv.convex[k[row]]:
            hit[row] = convex_intersects(a[None], b[None])[0]
        else:
            hit[row] = shapely.intersects(shapely.polygons(a), shapely.polygons(b))
    return hit


def _rear_end(mv: _Movers, fi: np.ndarray, fh: np.ndarray) -> np.ndarray:
    """Conflict types (spi-reference "Safety score"): the ego (pose fi) and the object
    (heading fh) head less than REAR_END_ANGLE apart."""
    return mv.cosf.take(fi) * mv.cosf.take(fh) + mv.sinf.take(fi) * mv.sinf.take(fh) > REAR_END_COS


def _from_behind(mv: _Movers, fi: np.ndarray, fk: np.ndarray, fh: np.ndarray) -> np.ndarray:
    """A rear-end contact with the object's centre behind the ego's: the follower's."""
    ahead = (mv.xf.take(fk) - mv.xf.take(fi)) * mv.cosf.take(fi) + (
        mv.yf.take(fk) - mv.yf.take(fi)
    ) * mv.sinf.take(fi)
    return _rear_end(mv, fi, fh) & (ahead < -BEHIND_EPS)


def score_grid_numpy(
    plans: Sequence[np.ndarray],
    egos: Sequence[Ego],
    worlds: Sequence[Objects],
    pet_ref: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`score_grid` in numpy, for any footprints (the path of scenes with a polygon, and the
    tests' oracle for the kernel). (ss, ttc, pet), each (I, J): plans I (>= 2 points each)
    with their egos against world models J (each with >= 1 object).

    The plans' time grids must be prefixes of the longest one (one grid, or stacks planning
    the same steps over different horizons). Everything is computed once on the longest grid
    (L points); plan i only uses its first N_i points, for its ego and for the objects, whose
    poses on a prefix grid are those of the long grid except the heading at the last point
    (spi-reference: the last point keeps the last segment's heading), which is the long
    grid's heading at N_i - 2.

    TTC first (equal times only); PET then only needs time pairs with
    |t_n - t_m| < pet_ref * min(1, ttc / H), since larger ones cannot lower the score.
    """
    lengths = np.array([len(p) for p in plans])
    longest = int(lengths.argmax())
    times = plans[longest][:, 0]
    n_pts = len(times)
    horizon = times[lengths - 1]  # (I,)
    n_i, n_j = len(plans), len(worlds)
    ttc = np.full((n_i, n_j), np.inf)
    pet = np.full((n_i, n_j), np.inf)
    # Prefilter 0: objects that can come near any ego sweep at all, before interpolating.
    found = _movers(plans, egos, worlds, times)
    if found is None:
        return np.ones((n_i, n_j)), ttc, pet
    mv, owner = found
    # Prefilter 1: bounding boxes of the whole sweeps, (ego i, object k) pairs that can meet.
    elo, ehi = mv.lo[:, :n_i, None], mv.hi[:, :n_i, None]
    pi, pk = np.nonzero(((mv.lo[:, None, n_i:] <= ehi) & (mv.hi[:, None, n_i:] >= elo)).all(axis=0))
    if len(pi) == 0:
        return np.ones((n_i, n_j)), ttc, pet
    pk += n_i  # mover rows
    uniform = bool((lengths == n_pts).all())
    plen = lengths.take(pi)  # per candidate pair: its plan's length
    # TTC: the diagonal n = m, bounding circles, then the exact test.
    dx = mv.x[pk] - mv.x[pi]
    dy = mv.y[pk] - mv.y[pi]
    reach = mv.radius.take(pi) + mv.radius.take(pk)
    near = dx * dx + dy * dy <= (reach * reach)[:, None]
    if not uniform:
        near &= np.arange(n_pts) < plen[:, None]
    cp, cn = np.nonzero(near)
    colliding = np.zeros(len(pi), dtype=bool)
    if len(cp):
        i = pi.take(cp)
        k = pk.take(cp)
        fk = k * n_pts + cn
        fh = fk if uniform else k * n_pts + np.minimum(cn, plen.take(cp) - 2)
        fi = i * n_pts + cn
        hit = np.flatnonzero(_exact(mv, i, k, fi, fk, fh))
        if len(hit):
            # candidates come in (pair, time) order: a pair's first hit is its first contact,
            # and a pair whose first contact is from behind counts for neither TTC nor PET
            pair, first = np.unique(cp.take(hit), return_index=True)
            colliding[pair] = True
            first = hit.take(first)
            first = first[~_from_behind(mv, fi.take(first), fk.take(first), fh.take(first))]
            at = (i.take(first), owner.take(k.take(first)))
            np.minimum.at(ttc, at, times.take(cn.take(first)))
    limit = pet_ref * np.minimum(1.0, ttc / horizon[:, None])
    # PET: only pairs that never meet at equal times, within their time limit.
    lim = np.where(colliding, -np.inf, limit[pi, owner.take(pk)])
    keep = np.flatnonzero(lim > 0)
    if len(keep):
        _pet(
            mv,
            owner,
            times,
            pi.take(keep),
            pk.take(keep),
            lim.take(keep),
            plen.take(keep),
            uniform,
            pet,
        )
    ss = np.minimum(1.0, np.minimum(ttc / horizon[:, None], pet / pet_ref))
    return ss, ttc, pet


_GAPS: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}


def _chunk_gaps(times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(C, C) smallest time difference between two runs of the grid (negative when their
    ranges overlap) and (C,) first index of each run; cached per grid (grids repeat)."""
    key = times.tobytes()
    got = _GAPS.get(key)
    if got is None:
        n_pts = len(times)
        starts = np.arange(-(-n_pts // CHUNK)) * CHUNK
        t_lo = times[starts]
        t_hi = times[np.minimum(starts + CHUNK - 1, n_pts - 1)]
        gap = np.maximum(t_lo[:, None] - t_hi[None, :], t_lo[None, :] - t_hi[:, None])
        if len(_GAPS) > 64:
            _GAPS.clear()
        got = _GAPS[key] = (gap, starts)
    return got


def _pet(
    mv: _Movers,
    owner: np.ndarray,
    times: np.ndarray,
    pi: np.ndarray,
    pk: np.ndarray,
    limit: np.ndarray,
    plen: np.ndarray,
    uniform: bool,
    pet: np.ndarray,
) -> None:
    """Lower pet[i, j] to the smallest |t_n - t_m| < limit at which ego i (time n) meets
    object k of world j (time m), for the candidate pairs (pi, pk) with their limits and
    their plans' lengths (n, m < plen; `uniform`: every plan spans the whole grid)."""
    n_pts = len(times)
    nc = mv.chunk_x.shape[1]
    gap, starts = _chunk_gaps(times)
    # (pair, ego chunk, object chunk); gap < 0 means overlapping time ranges
    dx = mv.chunk_x[pi][:, :, None] - mv.chunk_x[pk][:, None, :]
    dy = mv.chunk_y[pi][:, :, None] - mv.chunk_y[pk][:, None, :]
    reach = mv.chunk_r[pi][:, :, None] + mv.chunk_r[pk][:, None, :]
    near = (dx * dx + dy * dy <= reach * reach) & (gap < limit[:, None, None])
    if not uniform:
        inside = starts < plen[:, None]  # runs that start inside the plan's grid
        near &= inside[:, :, None] & inside[:, None, :]
    cp, ca, cb = np.nonzero(near)
    if len(cp) == 0:
        return
    i = pi.take(cp)
    k = pk.take(cp)
    er = i * nc + ca
    orow = k * nc + cb
    if len(cp) > LATERAL_MIN:
        hl = mv.hl.take(k)
        if not uniform:
            # A run holding the last point of a shorter grid has there a heading the long
            # grid's run does not show: project that run by its bounding radius (conservative).
            last = plen.take(cp) - 1
            cut = (last < n_pts - 1) & (last // CHUNK == cb)
            if cut.any():
                hl = np.where(cut, np.nan, hl)
        # Lateral separating axis of the ego run: drop chunk pairs it separates.
        mv.ego_axes()
        assert mv.axis_x is not None and mv.axis_y is not None  # set by ego_axes
        assert mv.axis_lo is not None and mv.axis_hi is not None
        lo, hi = mv.run_interval(
            orow, hl, mv.hw.take(k), mv.radius.take(k), mv.axis_x.take(er), mv.axis_y.take(er)
        )
        sel = np.flatnonzero((lo <= mv.axis_hi.take(er)) & (hi >= mv.axis_lo.take(er)))
        if len(sel) == 0:
            return
        cp, ca, cb, i, k, er, orow = (v.take(sel) for v in (cp, ca, cb, i, k, er, orow))
    # Each remaining chunk pair compares its CHUNK ego points with its CHUNK object points by
    # broadcasting (CHUNK, CHUNK, C), the long candidate axis innermost (numpy is slow on tiny
    # inner axes); only survivors become flat candidate indices.
    ex = mv.run_x.take(er, axis=1)[:, None, :]
    ey = mv.run_y.take(er, axis=1)[:, None, :]
    ox = mv.run_x.take(orow, axis=1)[None, :, :]
    oy = mv.run_y.take(orow, axis=1)[None, :, :]
    r = mv.radius.take(k) + mv.radius.take(i)
    dx = ox - ex
    dy = oy - ey
    a, b, c = np.nonzero(dx * dx + dy * dy <= r * r)
    if len(c) == 0:
        return
    # Padded run entries repeat the last grid point; n = m pairs cannot hit here (these objects
    # never meet the ego at equal times), so neither needs filtering.
    n = np.minimum(ca.take(c) * CHUNK + a, n_pts - 1)
    m = np.minimum(cb.take(c) * CHUNK + b, n_pts - 1)
    dt = np.abs(times.take(n) - times.take(m))
    cpc = cp.take(c)
    ok = dt < limit.take(cpc)
    if not uniform:
        own = plen.take(cpc)
        ok &= (n < own) & (m < own)
    sel = np.flatnonzero(ok)
    i = i.take(c).take(sel)
    k = k.take(c).take(sel)
    n = n.take(sel)
    m = m.take(sel)
    fk = k * n_pts + m
    fh = fk if uniform else k * n_pts + np.minimum(m, plen.take(cpc.take(sel)) - 2)
    fi = i * n_pts + n
    hit = _exact(mv, i, k, fi, fk, fh) & ~_rear_end(mv, fi, fh)
    if hit.any():
        np.minimum.at(pet, (i[hit], owner.take(k[hit])), dt.take(sel)[hit])


def score_grid(
    plans: Sequence[np.ndarray],
    egos: Sequence[Ego],
    worlds: Sequence[Objects],
    pet_ref: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ss, ttc, pet), each (I, J), of plans I (>= 2 points each, time grids prefixes of the
    longest) with their egos against world models J (each with >= 1 object); see
    `score_grid_numpy` for the rules. Box footprints everywhere take the compiled kernel, any
    polygon the numpy path."""
    out = score_boxes(plans, egos, worlds, pet_ref)
    if out is None:
        return score_grid_numpy(plans, egos, worlds, pet_ref)
    return out[0], out[1], out[2]


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


def _prefix_groups(plans: dict[str, np.ndarray]) -> list[list[str]]:
    """Channels grouped so that within a group every plan's time grid is a prefix of the
    group's longest plan (one `score_grid` pass each). Longest first, so a group's first
    member holds its grid. Grids are compared bytewise (cheaper than `np.array_equal` on
    these short arrays): identical bytes are identical grids; the rare equal grids with
    different bytes (-0.0 and 0.0) just take passes of their own, with the same results."""
    groups: list[list[str]] = []
    heads: list[bytes] = []
    for c in sorted(plans, key=lambda c: -len(plans[c])):
        dt = plans[c][:, 0].tobytes()
        for g, head in zip(groups, heads, strict=True):
            if head.startswith(dt):
                g.append(c)
                break
        else:
            groups.append([c])
            heads.append(dt)
    return groups


def prediction_horizon(objects: Objects) -> float:
    """The longest prediction of a world model [s] (infinite when no object has one: objects
    without prediction stay where they are, over any horizon)."""
    lens = objects.pred_len
    if len(lens) == 0 or objects.pred.shape[1] == 0:
        return math.inf
    last = _last_dt_max(objects.pred, lens)
    return math.inf if last == -math.inf else float(last)  # -inf: no object predicts


def _upto(plan: np.ndarray, limit: float) -> np.ndarray:
    """`plan[plan[:, 0] <= limit]`: a slice (no mask, no copy) when those rows are a prefix."""
    n = _prefix_upto(plan, limit)
    if n < 0:
        return plan[plan[:, 0] <= limit]
    return plan if n == len(plan) else plan[:n]


def safety_matrix(
    channels: list[str],
    states: dict[str, ChannelState],
    pet_ref: float,
    standing_is_clear: bool = False,
) -> dict[tuple[str, str], float | None]:
    """ss_ij for every ordered pair of declared channels: None when i or j is absent or plan i
    is empty; 1.0 when plan i has one point or channel j sees no object.

    Plan i is compared with world model j over the horizon both cover (spi-reference "Safety
    score", common horizon): cut to j's longest prediction. Beyond it j says nothing about
    where its objects go; read as "staying at their last point" they stood in the plan's way
    (a plan of 8 s against predictions of 2 s ran into every lead it followed).

    `standing_is_clear` (the engine sets it with `plan_standstill` > 0, spi-reference
    "Standing plans"): a plan whose points all coincide scores 1.0 against every world model;
    it drives into nothing."""
    out: dict[tuple[str, str], float | None] = {}
    present = [c for c in channels if c in states]
    worlds = [j for j in present if len(states[j].objects)]
    scored: dict[str, np.ndarray] = {}
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
        standing = standing_is_clear and _stands_still(plan)
        if len(plan) >= 2 and worlds and not standing:
            scored[i] = plan
    if not scored:
        return out
    by_horizon: dict[float, list[str]] = {}
    for j in worlds:
        by_horizon.setdefault(prediction_horizon(states[j].objects), []).append(j)
    for horizon, group in by_horizon.items():
        cut = {i: _upto(plan, horizon + 1e-9) for i, plan in scored.items()}
        cut = {i: plan for i, plan in cut.items() if len(plan) >= 2}
        if not cut:
            continue
        world_objects = [states[j].objects for j in group]
        for members in _prefix_groups(cut):
            ss = score_grid(
                [cut[i] for i in members],
                [states[i].ego for i in members],
                world_objects,
                pet_ref,
            )[0]
            for i, row in zip(members, ss.tolist(), strict=True):
                for j, v in zip(group, row, strict=True):
                    out[(i, j)] = v
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
            score[i] = min(v for v in vals if v is not None)
    if not score:
        return None
    best = max(score.values())
    tied = [c for c in channels if c in score and score[c] == best]
    if previous in tied:
        return previous
    return tied[0]
