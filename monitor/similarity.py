"""Cross-channel similarity metrics (spi-reference: "Cross-channel metrics").

Pure functions on one channel pair; arrays in, numbers out. `None` means "no value".
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import shapely

from monitor.frames import ChannelState, Objects

#: Pairing distance resolution [m]: closer distances are ties.
PAIRING_EPS = 1e-9


def inv(d: np.ndarray | float) -> np.ndarray | float:
    """spi-reference: inv(d) = 1 / (1 + d)."""
    return 1.0 / (1.0 + d)


def angdiff(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray | float:
    """Absolute heading difference wrapped into [0, pi]."""
    d = np.abs(np.remainder(np.asarray(a) - np.asarray(b), 2 * math.pi))
    return np.minimum(d, 2 * math.pi - d)


def pair_objects(
    pos_a: np.ndarray, pos_b: np.ndarray, gate: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Greedy global nearest matching (spi-reference "Object pairing").

    Returns (index in A, index in B, centre distance) of the accepted pairs, in acceptance
    order. Ties break by (distance, index in A, index in B): a lexsort on exactly those keys.
    """
    if len(pos_a) == 0 or len(pos_b) == 0:
        empty = np.zeros(0, dtype=int)
        return empty, empty, np.zeros(0)
    diff = pos_a[:, None, :] - pos_b[None, :, :]
    dist = np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))
    # Decision: distances equal to within 1e-9 m are ties (broken by index), so that float
    # noise from a change of world frame cannot reorder the matching.
    ia, ib = np.nonzero(dist <= gate + PAIRING_EPS)
    if len(ia) == 0:
        empty = np.zeros(0, dtype=int)
        return empty, empty, np.zeros(0)
    dv = np.round(dist[ia, ib] / PAIRING_EPS)
    order = np.lexsort((ib, ia, dv))
    # Greedy acceptance is inherently sequential; the loop runs over gated candidates only.
    used_a = np.zeros(len(pos_a), dtype=bool)
    used_b = np.zeros(len(pos_b), dtype=bool)
    acc_a: list[int] = []
    acc_b: list[int] = []
    for i, j in zip(ia[order].tolist(), ib[order].tolist(), strict=True):
        if not used_a[i] and not used_b[j]:
            used_a[i] = used_b[j] = True
            acc_a.append(i)
            acc_b.append(j)
    pa = np.array(acc_a, dtype=int)
    pb = np.array(acc_b, dtype=int)
    return pa, pb, dist[pa, pb]


def weighted_pointwise(
    p: np.ndarray, q: np.ndarray, lengths: np.ndarray | None, decay: float
) -> np.ndarray:
    """spi-reference: S = sum_n w_n inv(|P_n - Q_n|) / sum_n w_n, w_n = k^(n-1).

    `p`, `q` (M, L, 2); `lengths` (M,) limits each row to its first `lengths[m]` points
    (None = all L points).
    """
    d = np.hypot(p[..., 0] - q[..., 0], p[..., 1] - q[..., 1])
    w = _weights(decay, p.shape[1])
    if lengths is None:
        return (inv(d) @ w) / w.sum()
    n = p.shape[1]
    wm = np.where((_ARANGE[:n] if n <= len(_ARANGE) else np.arange(n)) < lengths[:, None], w, 0.0)
    return (wm * inv(d)).sum(axis=1) / wm.sum(axis=1)


#: 0, 1, 2, ... (a slice is cheaper than np.arange per call)
_ARANGE = np.arange(1024)


@lru_cache(maxsize=64)
def _weights(decay: float, n: int) -> np.ndarray:
    """w_n = k^(n-1), n = 1 .. N (read-only: cached and shared)."""
    w = decay ** np.arange(n, dtype=float)
    w.flags.writeable = False
    return w


def _pad_to(xy: np.ndarray, n: np.ndarray, length: int) -> np.ndarray:
    """Rows of (M, P, 2) padded (already by last point) or cut to `length` columns, each row's
    points beyond its own length replaced by its last point."""
    m, p = xy.shape[0], xy.shape[1]
    if p >= length and bool((n == length).all()):
        return xy[:, :length]
    if p < length:
        xy = np.concatenate([xy, np.repeat(xy[:, -1:, :], length - p, axis=1)], axis=1)
    else:
        xy = xy[:, :length]
    cols = np.minimum(np.arange(length)[None, :], (n - 1)[:, None])
    return xy[np.arange(m)[:, None], cols]


def object_similarities(a: Objects, b: Objects, gate: float, decay: float) -> dict[str, float]:
    """ocs, ols, oos, oas, ots for one channel pair."""
    na, nb = len(a), len(b)
    out = {"ocs": float(inv(abs(na - nb)))}
    if na == 0 and nb == 0:
        # spi-reference: 1.0 when both channels see nothing.
        out.update(ols=1.0, oos=1.0, oas=1.0, ots=1.0)
        return out
    ia, ib, dist = pair_objects(a.pos, b.pos, gate)
    if len(ia) == 0:
        # spi-reference Decision: 0.0 when objects exist but no pair forms.
        out.update(ols=0.0, oos=0.0, oas=0.0, ots=0.0)
        return out
    n_pairs = len(ia)
    # x.sum() / n is np.mean's own arithmetic, without its Python-level wrapper
    out["ols"] = float(inv(dist).sum() / n_pairs)
    out["oos"] = float((1.0 - angdiff(a.yaw.take(ia), b.yaw.take(ib)) / math.pi).sum() / n_pairs)
    area_a = a.areas.take(ia)
    area_b = b.areas.take(ib)
    hi = np.maximum(area_a, area_b)
    lo = np.minimum(area_a, area_b)
    # spi-reference: a pair of zero-area footprints scores 1.0.
    ratio = np.divide(lo, hi, out=np.ones_like(hi), where=hi > 0)
    out["oas"] = float(ratio.sum() / n_pairs)
    xa, la = a.prediction_xy()
    xb, lb = b.prediction_xy()
    la, lb = la[ia], lb[ib]
    length = np.maximum(la, lb)
    lmax = int(length.max())
    pa = _pad_to(xa[ia], la, lmax)
    pb = _pad_to(xb[ib], lb, lmax)
    out["ots"] = float(weighted_pointwise(pa, pb, length, decay).sum() / n_pairs)
    return out


def ego_similarities(a: ChannelState, b: ChannelState) -> dict[str, float]:
    """els and eos."""
    d = math.hypot(a.ego.x - b.ego.x, a.ego.y - b.ego.y)
    return {
        "els": 1.0 / (1.0 + d),
        "eos": 1.0 - float(angdiff(a.ego.yaw, b.ego.yaw)) / math.pi,
    }


def ets(plan_a: np.ndarray, plan_b: np.ndarray, decay: float) -> float | None:
    """Weighted point-wise similarity of the plans truncated to the shorter; None if one is
    empty."""
    n = min(len(plan_a), len(plan_b))
    if n == 0:
        return None
    return float(weighted_pointwise(plan_a[None, :n, 1:3], plan_b[None, :n, 1:3], None, decay)[0])


def frechet(p: np.ndarray, q: np.ndarray) -> float:
    """Discrete Fréchet distance of two (n, 2) point sequences (shapely/GEOS).

    A one-point sequence is not a LineString; its discrete Fréchet distance to Q is the largest
    distance from that point to a point of Q, which we compute directly.
    """
    if len(p) == 1 or len(q) == 1:
        one, other = (p, q) if len(p) == 1 else (q, p)
        return float(np.max(np.hypot(*(other - one[0]).T)))
    return float(shapely.frechet_distance(shapely.linestrings(p), shapely.linestrings(q)))


def crpps_inputs(plan_a: np.ndarray, plan_b: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The two point sequences whose Fréchet distance is `crpps_distance` (None if a plan is
    empty): the engine batches them with the chpps inputs into one GEOS call."""
    if len(plan_a) == 0 or len(plan_b) == 0:
        return None
    horizon = min(plan_a[-1, 0], plan_b[-1, 0]) + 1e-9
    pa = plan_a[plan_a[:, 0] <= horizon, 1:3]
    pb = plan_b[plan_b[:, 0] <= horizon, 1:3]
    pb = pb - pb[0] + pa[0]
    return pa, pb


def crpps_distance(plan_a: np.ndarray, plan_b: np.ndarray) -> float | None:
    """fd(plan_A, plan_B') with plan B translated so its first point is plan A's first point,
    both plans cut to their common horizon.

    Decision: the study's channels plan over different horizons (e.g. 5 s and 3 s). Compared
    whole, the extra seconds of the longer plan alone set the Frechet distance (tens of metres
    at road speed), so crpps would sit near 0 however well the channels agree. Like `ets`,
    which the study truncates to the shorter plan, crpps compares the points with
    `dt <= min(horizon_A, horizon_B)`.
    """
    inputs = crpps_inputs(plan_a, plan_b)
    return None if inputs is None else frechet(*inputs)
