"""Safety score: time to collision and post-encroachment time of a plan against a world model.

spi-reference "Safety score". For an ordered channel pair (i, j) the ego footprint of channel i
is swept along plan i, and each object of channel j along its prediction, on the plan's time
grid. The exact footprint tests run only on candidates that survive two numpy prefilters
(bounding box of the whole ego sweep, then bounding circles per time pair):

- convex footprints (every box, and convex polygons) are tested exactly with the separating
  axis theorem, vectorised in numpy over all candidates: two convex polygons intersect (touching
  included, like shapely's `intersects`) iff no edge normal of either separates them;
- a non-convex polygon footprint goes to `shapely.intersects`, vectorised over its candidates.

Decision (grid reading of PET): the ego "occupies the shared region" at plan time t_n when its
footprint there intersects the object's footprint at grid time t_m; PET is the smallest
|t_n - t_m| over such pairs, for objects with no intersection at equal times (n = m).
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from monitor.frames import ChannelState, Ego, Objects, place
from monitor.prediction import interpolate_tracks


def _headings(centres: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Heading at each grid point: tangent of the segment leaving it (the last point keeps the
    last segment's); a zero-length segment keeps the previous heading, and before any motion
    the `fallback` heading (the vehicle's yaw). centres (..., T, 2), fallback (...)."""
    seg = centres[..., 1:, :] - centres[..., :-1, :]
    ang = np.arctan2(seg[..., 1], seg[..., 0])
    ok = np.abs(seg[..., 0]) + np.abs(seg[..., 1]) > 1e-9
    if not ok.all():
        t = seg.shape[-2]
        last = np.maximum.accumulate(np.where(ok, np.arange(t), -1), axis=-1)
        ang = np.where(
            last >= 0,
            np.take_along_axis(ang, np.maximum(last, 0), axis=-1),
            np.asarray(fallback)[..., None],
        )
    return np.concatenate([ang, ang[..., -1:]], axis=-1)


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


def _chunk_circles(centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bounding circles of consecutive runs of CHUNK grid points: centres (..., C, 2) and radii
    (..., C) of the point sets (footprint radii are added by the caller)."""
    n = centres.shape[-2]
    nc = -(-n // CHUNK)
    pad = nc * CHUNK - n
    if pad:
        last = np.repeat(centres[..., -1:, :], pad, axis=-2)
        centres = np.concatenate([centres, last], axis=-2)
    runs = centres.reshape(*centres.shape[:-2], nc, CHUNK, 2)
    mid = 0.5 * (runs.max(axis=-2) + runs.min(axis=-2))
    off = runs - mid[..., None, :]
    return mid, np.sqrt(np.max(np.einsum("...d,...d->...", off, off), axis=-1))


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


class Sweep:
    """Footprint centres and headings of one or more movers on a time grid, flattened to
    (M * N,) arrays (row-major: mover, then time) so candidate gathers are single `take`s,
    plus bounding circles of CHUNK-point runs (centre and radius, footprint radius included)
    for the coarse prefilter."""

    __slots__ = ("chunk_r", "chunk_x", "chunk_y", "cos", "heading", "n", "sin", "x", "y")

    def __init__(self, centres: np.ndarray, heading: np.ndarray, radius: np.ndarray):
        # centres (M, N, 2), heading (M, N), radius (M,)
        self.n = centres.shape[1]
        self.x = centres[..., 0].ravel()
        self.y = centres[..., 1].ravel()
        self.heading = heading.ravel()
        self.cos = np.cos(self.heading)
        self.sin = np.sin(self.heading)
        mid, rad = _chunk_circles(centres)
        self.chunk_x = mid[..., 0]
        self.chunk_y = mid[..., 1]
        self.chunk_r = rad + radius[:, None]


def object_sweep(objects: Objects, times: np.ndarray) -> Sweep:
    """Objects moved along their predictions on the plan's time grid."""
    centres = interpolate_tracks(objects.pos, objects.pred, objects.pred_len, times)
    return Sweep(centres, _headings(centres, objects.yaw), objects.radii)


def ego_sweep(plan: np.ndarray, ego: Ego) -> Sweep:
    """The ego footprint along a plan, heading = path tangent."""
    centres = plan[None, :, 1:3]
    return Sweep(centres, _headings(centres, np.asarray([ego.yaw])), np.array([ego.radius]))


class SweepCache:
    """Per-frame cache of object sweeps per (channel, time grid), so the ordered pairs (i, j)
    of one tick share world model j when their plans use the same grid (the usual case)."""

    def __init__(self) -> None:
        self._objects: dict[tuple[str, bytes], Sweep] = {}

    def objects_on_grid(self, channel: str, objects: Objects, times: np.ndarray) -> Sweep:
        key = (channel, times.tobytes())
        hit = self._objects.get(key)
        if hit is None:
            hit = object_sweep(objects, times)
            self._objects[key] = hit
        return hit


def _exact(
    ego: Ego,
    es: Sweep,
    objects: Objects,
    os_: Sweep,
    k: np.ndarray,
    n: np.ndarray,
    m: np.ndarray,
) -> np.ndarray:
    """Exact footprint tests of the ego at grid n against object k at grid m: (C,) bool."""
    f = k * os_.n + m
    if ego.half is not None:
        half = objects.half[k]
        boxes = ~np.isnan(half[:, 0])
        if boxes.all():
            return boxes_intersect(
                os_.x.take(f) - es.x.take(n), os_.y.take(f) - es.y.take(n),
                es.cos.take(n), es.sin.take(n), ego.half[0], ego.half[1],
                os_.cos.take(f), os_.sin.take(f), half[:, 0], half[:, 1],
            )  # fmt: skip
    else:
        boxes = np.zeros(len(k), dtype=bool)
    hit = np.zeros(len(k), dtype=bool)
    if boxes.any():
        fb, nb, kb = f[boxes], n[boxes], k[boxes]
        hit[boxes] = boxes_intersect(
            os_.x[fb] - es.x[nb], os_.y[fb] - es.y[nb], es.cos[nb], es.sin[nb],
            ego.half[0], ego.half[1],  # type: ignore[index]
            os_.cos[fb], os_.sin[fb], objects.half[kb, 0], objects.half[kb, 1],
        )  # fmt: skip
    rest = ~boxes
    fr, nr, kr = f[rest], n[rest], k[rest]
    ego_poly = place(ego.footprint[None], np.column_stack([es.x[nr], es.y[nr]]), es.heading[nr])
    obj_poly = place(objects.footprints[kr], np.column_stack([os_.x[fr], os_.y[fr]]),
                     os_.heading[fr])  # fmt: skip
    convex = objects.convex[kr] & ego.convex
    sub = np.zeros(len(kr), dtype=bool)
    if convex.any():
        sub[convex] = convex_intersects(ego_poly[convex], obj_poly[convex])
    if (~convex).any():
        sub[~convex] = shapely.intersects(
            shapely.polygons(ego_poly[~convex]), shapely.polygons(obj_poly[~convex])
        )
    hit[rest] = sub
    return hit


def safety_score(
    plan: np.ndarray,
    ego: Ego,
    objects: Objects,
    pet_ref: float,
    sweep: Sweep | None = None,
) -> tuple[float | None, float, float]:
    """(ss, ttc, pet) of one plan against one world model. ss is None for an empty plan,
    1.0 for a one-point plan (spi-reference); ttc and pet are inf when nothing meets.

    TTC first (equal times only, K x N circle prefilter); PET then only needs time pairs with
    |t_n - t_m| < pet_ref * min(1, ttc / H), since larger ones cannot lower the score.
    """
    n_pts = len(plan)
    if n_pts == 0:
        return None, math.inf, math.inf
    if n_pts < 2 or len(objects) == 0:
        return 1.0, math.inf, math.inf
    times = plan[:, 0]
    horizon = float(times[-1])
    os_ = object_sweep(objects, times) if sweep is None else sweep
    es = ego_sweep(plan, ego)
    k_obj = len(objects)
    # TTC: the diagonal n = m, bounding circles first.
    dx = os_.x.reshape(k_obj, n_pts) - es.x
    dy = os_.y.reshape(k_obj, n_pts) - es.y
    reach = objects.radii + ego.radius
    dk, dn = np.nonzero(dx * dx + dy * dy <= (reach * reach)[:, None])
    ttc = math.inf
    colliding = np.zeros(k_obj, dtype=bool)
    if len(dk):
        hit = _exact(ego, es, objects, os_, dk, dn, dn)
        if hit.any():
            ttc = float(times[dn[hit]].min())
            colliding[dk[hit]] = True
    limit = pet_ref * min(1.0, ttc / horizon)
    pet = math.inf
    if limit > 0:
        pet = _pet(ego, es, objects, os_, times, colliding, limit)
    return min(1.0, ttc / horizon, pet / pet_ref), ttc, pet


def _pet(
    ego: Ego,
    es: Sweep,
    objects: Objects,
    os_: Sweep,
    times: np.ndarray,
    colliding: np.ndarray,
    limit: float,
) -> float:
    """Smallest |t_n - t_m| < limit at which the ego (time n) meets an object (time m) that
    never meets it at equal times; inf when none. Chunk circles, then point circles, then the
    exact test."""
    n_pts = len(times)
    nc = es.chunk_x.shape[1]
    starts = np.arange(nc) * CHUNK
    t_lo = times[starts]
    t_hi = times[np.minimum(starts + CHUNK - 1, n_pts - 1)]
    gap = np.maximum(t_lo[:, None] - t_hi[None, :], t_lo[None, :] - t_hi[:, None])
    time_ok = gap < limit  # (ego chunk, object chunk); gap < 0 means overlapping ranges
    dx = es.chunk_x[0][None, :, None] - os_.chunk_x[:, None, :]
    dy = es.chunk_y[0][None, :, None] - os_.chunk_y[:, None, :]
    reach = es.chunk_r[0][None, :, None] + os_.chunk_r[:, None, :]
    near = (dx * dx + dy * dy <= reach * reach) & time_ok
    if colliding.any():
        near &= ~colliding[:, None, None]
    ck, ca, cb = np.nonzero(near)
    if len(ck) == 0:
        return math.inf
    off = np.arange(CHUNK)
    n = ((ca * CHUNK)[:, None, None] + off[None, :, None]).repeat(CHUNK, axis=2).ravel()
    m = ((cb * CHUNK)[:, None, None] + off[None, None, :]).repeat(CHUNK, axis=1).ravel()
    k = np.repeat(ck, CHUNK * CHUNK)
    ok = (n < n_pts) & (m < n_pts) & (n != m)
    k, n, m = k[ok], n[ok], m[ok]
    f = k * n_pts + m
    dt = np.abs(times.take(n) - times.take(m))
    ddx = os_.x.take(f) - es.x.take(n)
    ddy = os_.y.take(f) - es.y.take(n)
    r = objects.radii.take(k) + ego.radius
    ok = (dt < limit) & (ddx * ddx + ddy * ddy <= r * r)
    if not ok.any():
        return math.inf
    k, n, m, dt = k[ok], n[ok], m[ok], dt[ok]
    hit = _exact(ego, es, objects, os_, k, n, m)
    return float(dt[hit].min()) if hit.any() else math.inf


def safety_matrix(
    channels: list[str], states: dict[str, ChannelState], pet_ref: float
) -> dict[tuple[str, str], float | None]:
    """ss_ij for every ordered pair of declared channels; None when i or j is absent or plan i
    is empty."""
    cache = SweepCache()
    out: dict[tuple[str, str], float | None] = {}
    for i in channels:
        si = states.get(i)
        for j in channels:
            sj = states.get(j)
            if si is None or sj is None:
                out[(i, j)] = None
                continue
            plan = si.plan
            sweep = None
            if len(plan) >= 2 and len(sj.objects):
                sweep = cache.objects_on_grid(j, sj.objects, plan[:, 0])
            out[(i, j)] = safety_score(plan, si.ego, sj.objects, pet_ref, sweep)[0]
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
