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
    seg = np.diff(centres, axis=-2)
    ok = np.hypot(seg[..., 0], seg[..., 1]) > 1e-9
    ang = np.arctan2(seg[..., 1], seg[..., 0])
    t = seg.shape[-2]
    last = np.maximum.accumulate(np.where(ok, np.arange(t), -1), axis=-1)
    head = np.where(
        last >= 0,
        np.take_along_axis(ang, np.maximum(last, 0), axis=-1),
        np.asarray(fallback)[..., None],
    )
    return np.concatenate([head, head[..., -1:]], axis=-1)


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


class SweepCache:
    """Per-frame cache of ego sweeps (per plan) and object positions (per channel and grid),
    so an ordered pair reuses what the other pairs of the same tick already computed."""

    def __init__(self) -> None:
        self._objects: dict[tuple[str, bytes], tuple[np.ndarray, np.ndarray]] = {}

    def objects_on_grid(
        self, channel: str, objects: Objects, times: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        key = (channel, times.tobytes())
        hit = self._objects.get(key)
        if hit is None:
            centres = interpolate_tracks(objects.pos, objects.pred, objects.pred_len, times)
            hit = (centres, _headings(centres, objects.yaw))
            self._objects[key] = hit
        return hit


def ego_sweep(plan: np.ndarray, ego: Ego) -> tuple[np.ndarray, np.ndarray]:
    """Ego centres (N, 2) and footprints (N, V, 2) along a plan."""
    centres = plan[:, 1:3]
    head = _headings(centres, np.asarray(ego.yaw))
    return centres, place(ego.footprint[None], centres, head)


def safety_score(
    plan: np.ndarray,
    ego: Ego,
    objects: Objects,
    pet_ref: float,
    centres_obj: np.ndarray | None = None,
    head_obj: np.ndarray | None = None,
) -> tuple[float | None, float, float]:
    """(ss, ttc, pet) of one plan against one world model. ss is None for an empty plan,
    1.0 for a one-point plan (spi-reference); ttc and pet are inf when nothing meets."""
    n = len(plan)
    if n == 0:
        return None, math.inf, math.inf
    if n < 2:
        return 1.0, math.inf, math.inf
    times = plan[:, 0]
    horizon = float(times[-1])
    k = len(objects)
    if k == 0:
        return 1.0, math.inf, math.inf
    if centres_obj is None or head_obj is None:
        centres_obj = interpolate_tracks(objects.pos, objects.pred, objects.pred_len, times)
        head_obj = _headings(centres_obj, objects.yaw)
    centres, ego_poly = ego_sweep(plan, ego)
    r_e = ego.radius
    r_o = objects.radii
    # Prefilter 1: objects whose sweep comes near the bounding box of the ego sweep.
    lo = centres.min(axis=0) - r_e
    hi = centres.max(axis=0) + r_e
    reach = r_o[:, None]
    near = np.any(
        (centres_obj[..., 0] >= lo[0] - reach)
        & (centres_obj[..., 0] <= hi[0] + reach)
        & (centres_obj[..., 1] >= lo[1] - reach)
        & (centres_obj[..., 1] <= hi[1] + reach),
        axis=1,
    )
    kn = np.nonzero(near)[0]
    if len(kn) == 0:
        return 1.0, math.inf, math.inf
    # Prefilter 2: bounding circles for every (object, ego time n, object time m); only time
    # pairs closer than pet_ref can lower the score (pet / pet_ref >= 1 otherwise).
    q = centres_obj[kn]  # (Kn, N, 2)
    dx = centres[None, :, None, 0] - q[:, None, :, 0]
    dy = centres[None, :, None, 1] - q[:, None, :, 1]
    reach2 = (r_e + r_o[kn])[:, None, None] ** 2
    band = np.abs(times[:, None] - times[None, :]) < pet_ref
    cand = (dx * dx + dy * dy <= reach2) & band[None]
    ck, cn, cm = np.nonzero(cand)
    if len(ck) == 0:
        return 1.0, math.inf, math.inf
    obj = kn[ck]
    obj_poly = place(objects.footprints[obj], q[ck, cm], head_obj[kn][ck, cm])
    hit = np.zeros(len(ck), dtype=bool)
    convex = objects.convex[obj] & ego.convex
    if convex.all():
        hit = convex_intersects(ego_poly[cn], obj_poly)
    else:
        if convex.any():
            hit[convex] = convex_intersects(ego_poly[cn[convex]], obj_poly[convex])
        rest = ~convex
        hit[rest] = shapely.intersects(
            shapely.polygons(ego_poly[cn[rest]]), shapely.polygons(obj_poly[rest])
        )
    ck, cn, cm = ck[hit], cn[hit], cm[hit]
    if len(ck) == 0:
        return 1.0, math.inf, math.inf
    simultaneous = cn == cm
    ttc = float(times[cn[simultaneous]].min()) if simultaneous.any() else math.inf
    colliding = np.zeros(len(kn), dtype=bool)
    colliding[ck[simultaneous]] = True
    pet_rows = ~colliding[ck]
    pet = (
        float(np.min(np.abs(times[cn[pet_rows]] - times[cm[pet_rows]])))
        if pet_rows.any()
        else math.inf
    )
    ss = min(1.0, ttc / horizon, pet / pet_ref)
    return ss, ttc, pet


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
            if len(plan) >= 2 and len(sj.objects):
                centres, head = cache.objects_on_grid(j, sj.objects, plan[:, 0])
                out[(i, j)] = safety_score(plan, si.ego, sj.objects, pet_ref, centres, head)[0]
            else:
                out[(i, j)] = safety_score(plan, si.ego, sj.objects, pet_ref)[0]
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
