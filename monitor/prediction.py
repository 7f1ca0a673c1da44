"""Object Motion Prediction Validation (ompv) and the track interpolation it shares with the
safety score."""

from __future__ import annotations

from bisect import bisect_right

import numpy as np

from monitor.frames import Objects
from monitor.similarity import pair_objects


def interpolate_tracks(
    pos: np.ndarray, pred: np.ndarray, pred_len: np.ndarray, times: np.ndarray
) -> np.ndarray:
    """Object positions (K, T, 2) at `times` (T,) after the frame time.

    Linear interpolation inside each prediction; before the first predicted point the object
    moves linearly from its current position (which is where it is at dt = 0); after the last
    point it stays there; without a prediction it stays where it is.
    """
    k, t = len(pos), len(times)
    if k == 0 or pred.shape[1] == 0:
        return np.broadcast_to(pos[:, None, :], (k, t, 2)).copy()
    dt = pred[:, :, 0]
    xy = pred[:, :, 1:3]
    p = pred.shape[1]
    if p > 1 and bool((pred_len == p).all()) and bool((dt == dt[0]).all()):
        # Common case: every object predicted on the same time grid, one searchsorted.
        g = dt[0]
        # np.minimum/np.maximum rather than np.clip: same values, a fraction of the overhead
        i1 = np.minimum(np.maximum(np.searchsorted(g, times, side="right") - 1, 0), p - 2)
        g0 = g.take(i1)
        f1 = np.minimum(np.maximum((times - g0) / (g.take(i1 + 1) - g0), 0.0), 1.0)
        a = xy[:, i1]
        out = a + (xy[:, i1 + 1] - a) * f1[None, :, None]
        if g[0] > 0 and times[0] < g[0]:
            before = times < g[0]
            lead = (times[before] / g[0])[None, :, None]
            out[:, before] = pos[:, None, :] + (xy[:, None, 0, :] - pos[:, None, :]) * lead
        return out
    out = np.broadcast_to(pos[:, None, :], (k, t, 2)).copy()
    have = pred_len > 0
    rows = np.arange(k)[:, None]
    if p == 1:
        idx = np.zeros((k, t), dtype=int)
        frac = np.zeros((k, t))
    else:
        valid = np.arange(p)[None, :] < pred_len[:, None]
        dtm = np.where(valid, dt, np.inf)
        idx = (dtm[:, None, :] <= times[None, :, None]).sum(-1) - 1
        idx = np.clip(idx, 0, np.maximum(pred_len - 2, 0)[:, None])
        t0 = dt[rows, idx]
        t1 = dt[rows, np.minimum(idx + 1, p - 1)]
        span = t1 - t0
        frac = np.clip(
            np.divide(times[None, :] - t0, span, out=np.zeros_like(t0), where=span > 0), 0.0, 1.0
        )
    a = xy[rows, idx]
    b = xy[rows, np.minimum(idx + 1, p - 1)]
    inside = a + (b - a) * frac[..., None]
    # Before the first predicted point: from the current position towards it.
    first_dt = dt[:, 0]
    before = times[None, :] < first_dt[:, None]
    lead = np.divide(
        times[None, :], first_dt[:, None], out=np.zeros((k, t)), where=first_dt[:, None] > 0
    )
    towards = pos[:, None, :] + (xy[:, None, 0, :] - pos[:, None, :]) * lead[..., None]
    inside = np.where(before[..., None], towards, inside)
    return np.where(have[:, None, None], inside, out)


def _shared_grid(pred: np.ndarray, pred_len: np.ndarray) -> np.ndarray | None:
    """The prediction time grid when every object is predicted on the same one (>= 2 points),
    else None."""
    p = pred.shape[1]
    if p < 2 or not (pred_len == p).all():
        return None
    dt = pred[:, :, 0]
    return dt[0] if (dt == dt[0]).all() else None


def positions_at(pos: np.ndarray, pred: np.ndarray, pred_len: np.ndarray, t: float) -> np.ndarray:
    """Object positions (K, 2) at one time `t` after the frame time: `interpolate_tracks` at a
    single time, with the same arithmetic (the shared-grid case on Python scalars)."""
    g = _shared_grid(pred, pred_len) if len(pos) else None
    if g is None:
        return interpolate_tracks(pos, pred, pred_len, np.array([t]))[:, 0]
    grid = g.tolist()
    if grid[0] > 0 and t < grid[0]:
        return pos + (pred[:, 0, 1:3] - pos) * (t / grid[0])
    i1 = min(max(bisect_right(grid, t) - 1, 0), len(grid) - 2)
    f1 = min(max((t - grid[i1]) / (grid[i1 + 1] - grid[i1]), 0.0), 1.0)
    a = pred[:, i1, 1:3]
    return a + (pred[:, i1 + 1, 1:3] - a) * f1


def ompv(prev: Objects, elapsed: float, cur: Objects, tolerance: float, gate: float) -> float:
    """Share of objects that followed their prediction: N1 / N2 (1.0 when N2 = 0).

    `prev` are the channel's objects `elapsed` seconds ago. A previous object is moved to its
    predicted position now; one whose prediction does not reach `elapsed` is a miss (an absent
    prediction means "stays where it is", so it always reaches). It followed when the current
    object of the same id (or, when the channel does not track, the nearest within `gate`) is
    within `tolerance`. N2 = previous objects + current objects that are new.
    """
    n_prev, n_cur = len(prev), len(cur)
    if n_prev == 0:
        return 1.0 if n_cur == 0 else 0.0  # every current object is new: a miss
    plen = prev.pred_len
    if prev.pred.shape[1]:
        last_dt = prev.pred[np.arange(n_prev), np.maximum(plen - 1, 0), 0]
        reaches = (plen == 0) | (last_dt >= elapsed - 1e-9)
    else:
        reaches = plen == 0
    predicted = positions_at(prev.pos, prev.pred, plen, elapsed)
    index_cur = {oid: i for i, oid in enumerate(cur.ids)}
    tracked = n_cur > 0 and any(oid in index_cur for oid in prev.ids)
    if tracked or n_cur == 0:
        # Decision: a channel tracks when at least one id carries over between the two ticks.
        pairs = [(i, index_cur[oid]) for i, oid in enumerate(prev.ids) if oid in index_cur]
        pi = np.array([i for i, _ in pairs], dtype=int)
        ci = np.array([c for _, c in pairs], dtype=int)
    else:
        # No stable ids: the nearest current object to each predicted position, within the gate.
        cand = np.nonzero(reaches)[0]
        pa, ci, _ = pair_objects(predicted[cand], cur.pos, gate)
        pi = cand[pa]
    n_new = n_cur - len(set(ci.tolist()))
    if len(pi):
        diff = predicted[pi] - cur.pos[ci]
        err = np.hypot(diff[:, 0], diff[:, 1])
        n1 = int(np.count_nonzero(reaches[pi] & (err <= tolerance)))
    else:
        n1 = 0
    return n1 / (n_prev + n_new)
