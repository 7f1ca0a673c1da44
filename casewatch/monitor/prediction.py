"""Object Motion Prediction Validation (ompv) and the track interpolation it shares with the
safety score.

`ompv` compares one channel's objects with one earlier observation; `ompv_tick` is what the
motion family calls: every channel's ompv of a tick in one compiled call over the stored
observations (`history.ObjectHistory`, ids as numbers), by `ompv`'s arithmetic, with `ompv`
kept as the reference the tests hold it to."""

from __future__ import annotations

import numpy as np

from casewatch.monitor.frames import Objects
from casewatch.monitor.history import ObjectHistory
from casewatch.monitor.jit import kernel
from casewatch.monitor.similarity import pair_objects


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


@kernel
def _point_at(pos, pred, pred_len, k, t, out):
    """Position of object k at time t into out[0:2]: `interpolate_tracks`'s arithmetic for one
    object and one time (kernel helper)."""
    n = pred_len[k]
    p = pred.shape[1]
    if n == 0 or p == 0:
        out[0] = pos[k, 0]
        out[1] = pos[k, 1]
        return
    idx = 0
    frac = 0.0
    if p > 1:
        # count of real dt <= t, minus one, clipped to [0, max(n - 2, 0)]
        for j in range(n):
            if pred[k, j, 0] <= t:
                idx += 1
        idx = min(max(idx - 1, 0), max(n - 2, 0))
        j1 = min(idx + 1, p - 1)
        t0 = pred[k, idx, 0]
        span = pred[k, j1, 0] - t0
        if span > 0:
            frac = min(max((t - t0) / span, 0.0), 1.0)
    else:
        j1 = 0
    first = pred[k, 0, 0]
    if t < first:
        # before the first predicted point: from the current position towards it
        lead = t / first if first > 0 else 0.0
        out[0] = pos[k, 0] + (pred[k, 0, 1] - pos[k, 0]) * lead
        out[1] = pos[k, 1] + (pred[k, 0, 2] - pos[k, 1]) * lead
        return
    ax, ay = pred[k, idx, 1], pred[k, idx, 2]
    out[0] = ax + (pred[k, j1, 1] - ax) * frac
    out[1] = ay + (pred[k, j1, 2] - ay) * frac


def positions_at(pos: np.ndarray, pred: np.ndarray, pred_len: np.ndarray, t: float) -> np.ndarray:
    """Object positions (K, 2) at one time `t` after the frame time: `interpolate_tracks` at a
    single time, with the same arithmetic; the positions ompv predicts (`_predict`)."""
    return _predict(pos, pred, pred_len, float(t))[0]


@kernel
def _predict(pos, pred, pred_len, elapsed):  # pragma: no cover - compiled
    """Each previous object's predicted position `elapsed` s later, and whether its prediction
    reaches that far (last dt >= elapsed, 1e-9 s tolerance; no prediction always reaches)."""
    n_prev = pos.shape[0]
    p = pred.shape[1]
    reaches = np.empty(n_prev, dtype=np.bool_)
    predicted = np.empty((n_prev, 2))
    for i in range(n_prev):
        n = pred_len[i]
        if p == 0:
            reaches[i] = n == 0
        else:
            last = pred[i, max(n - 1, 0), 0]
            reaches[i] = n == 0 or last >= elapsed - 1e-9
        _point_at(pos, pred, pred_len, i, elapsed, predicted[i])
    return predicted, reaches


#: Resolution [m] of the ompv tolerance: a world frame turned by any angle moves a distance of
#: metres by a few 1e-14 m, and an object exactly the tolerance away must not flip from hit to
#: miss with it; a distance 5e-13 m beyond the tolerance is still a miss
#: (`test_ompv_untracked_ties_within_1e9_break_by_index`).
TOLERANCE_EPS = 1e-13


@kernel
def _ompv_counts(predicted, reaches, cur, pi, ci, tolerance):  # pragma: no cover - compiled
    """(N1, N2) of ompv for the matched pairs (previous pi[r], current ci[r])."""
    n_cur = cur.shape[0]
    seen = np.zeros(n_cur, dtype=np.bool_)
    distinct = 0
    n1 = 0
    for r in range(pi.shape[0]):
        c = ci[r]
        if not seen[c]:
            seen[c] = True
            distinct += 1
        i = pi[r]
        err = np.hypot(predicted[i, 0] - cur[c, 0], predicted[i, 1] - cur[c, 1])
        if reaches[i] and err <= tolerance + TOLERANCE_EPS:
            n1 += 1
    return n1, predicted.shape[0] + n_cur - distinct


def ompv(
    prev: Objects,
    elapsed: float,
    cur: Objects,
    tolerance: float,
    gate: float,
    standing: float = 0.0,
) -> float:
    """Share of objects that followed their prediction: N1 / N2 (1.0 when N2 = 0).

    `prev` are the channel's objects `elapsed` seconds ago. A previous object is moved to its
    predicted position now; one whose prediction does not reach `elapsed` is a miss (an absent
    prediction means "stays where it is", so it always reaches). It followed when the current
    object of the same id (or, when the channel does not track, the nearest within `gate`) is
    within `tolerance` (to `TOLERANCE_EPS`: a distance of exactly the tolerance stays a hit
    when the world frame turns). N2 = previous objects + current objects that are new.

    `standing` > 0 (spi-reference "Standing objects"): only previous objects found again now
    that were predicted to move or moved more than `standing` metres over `elapsed` count
    (N2 = those, N1 = those that followed). A standing object's prediction holds trivially, and
    a queue of them at a red light outvoted every moving car whose prediction was wrong; an
    object new or gone since is a question of existence (lone_age's), not of prediction, and
    counted as a miss it took ompv to exactly 0 whenever the one moving car in view had
    entered it in the last `ompv_lookback` seconds (9 % of nominal ticks of the sweep).

    The id lookup stays in Python (ids are strings); prediction and counting are compiled, and
    the nearest matching is `similarity.pair_objects` (called from Python: numba's disk cache
    would not notice a change to a kernel of another module compiled into this one).
    """
    n_prev, n_cur = len(prev), len(cur)
    if n_prev == 0 and standing > 0.0:
        return 1.0  # nothing was predicted: nothing to check
    if n_prev == 0:
        return 1.0 if n_cur == 0 else 0.0  # every current object is new: a miss
    index_cur = dict(zip(cur.ids, range(n_cur), strict=True))  # a repeated id: its last index
    match = np.array([index_cur.get(oid, -1) for oid in prev.ids], dtype=np.int64)
    # Decision: a channel tracks when at least one id carries over between the two ticks; the
    # tracked case (the common one) is one compiled call from prediction to counts.
    n1, n2, tracked, predicted, reaches = _ompv_tracked(
        prev.pos,
        prev.pred,
        prev.pred_len,
        float(elapsed),
        cur.pos,
        match,
        float(tolerance),
        float(standing),
    )
    if not tracked:
        return _nearest_ompv(
            predicted, reaches, prev.pos, cur.pos, float(tolerance), gate, float(standing)
        )
    if standing <= 0.0:
        return n1 / n2
    return 1.0 if n2 == 0 else n1 / n2


def _nearest_ompv(
    predicted: np.ndarray,
    reaches: np.ndarray,
    prev_pos: np.ndarray,
    cur_pos: np.ndarray,
    tolerance: float,
    gate: float,
    standing: float,
) -> float:
    """ompv of a channel that does not track (no id carried over): each predicted position
    (`_predict`) paired with the nearest current object within `gate`, then counted as the
    tracked case counts (`ompv`)."""
    cand = np.flatnonzero(reaches)
    pa, ci, _ = pair_objects(predicted.take(cand, axis=0), cur_pos, gate)
    pi = cand.take(pa)
    if standing <= 0.0:
        n1, n2 = _ompv_counts(predicted, reaches, cur_pos, pi, ci, tolerance)
        return n1 / n2
    n1, n2 = _standing_counts(predicted, reaches, prev_pos, cur_pos, pi, ci, tolerance, standing)
    return 1.0 if n2 == 0 else n1 / n2


@kernel
def _ompv_tracked(prev_pos, pred, pred_len, elapsed, cur_pos, match, tolerance, standing):
    """(N1, N2, tracked, predicted, reaches) of ompv when the channel tracks (some previous
    object's id is among the current ones, `match` >= 0, or there is no current object):
    `_predict`, then the id pairs counted by `_ompv_counts` (`standing` <= 0) or
    `_standing_counts`. Not tracked: counts 0 and the predictions, for the nearest matching."""
    predicted, reaches = _predict(prev_pos, pred, pred_len, elapsed)
    found = 0
    for i in range(match.shape[0]):
        if match[i] >= 0:
            found += 1
    if found == 0 and cur_pos.shape[0] > 0:
        return 0, 0, False, predicted, reaches
    pi = np.empty(found, dtype=np.int64)
    ci = np.empty(found, dtype=np.int64)
    r = 0
    for i in range(match.shape[0]):
        if match[i] >= 0:
            pi[r] = i
            ci[r] = match[i]
            r += 1
    if standing <= 0.0:
        n1, n2 = _ompv_counts(predicted, reaches, cur_pos, pi, ci, tolerance)
    else:
        n1, n2 = _standing_counts(
            predicted, reaches, prev_pos, cur_pos, pi, ci, tolerance, standing
        )
    return n1, n2, True, predicted, reaches


@kernel
def _standing_counts(predicted, reaches, prev_pos, cur_pos, pi, ci, tolerance, standing):
    """(N1, N2) of ompv with `standing` > 0: over the previous objects found again (partner
    ci[r] of pi[r]; the last pairing of an object wins, as a numpy assignment does), those
    predicted to move or that moved more than `standing` count, and those within the tolerance
    of their prediction, whose prediction reaches, followed."""
    partner = np.full(prev_pos.shape[0], -1, dtype=np.int64)
    for r in range(pi.shape[0]):
        partner[pi[r]] = ci[r]
    n1 = 0
    n2 = 0
    for i in range(prev_pos.shape[0]):
        c = partner[i]
        if c < 0:
            continue
        err = np.hypot(predicted[i, 0] - cur_pos[c, 0], predicted[i, 1] - cur_pos[c, 1])
        moved = np.hypot(cur_pos[c, 0] - prev_pos[i, 0], cur_pos[c, 1] - prev_pos[i, 1])
        drift = np.hypot(predicted[i, 0] - prev_pos[i, 0], predicted[i, 1] - prev_pos[i, 1])
        if drift > standing or moved > standing:
            n2 += 1
            if reaches[i] and err <= tolerance + TOLERANCE_EPS:
                n1 += 1
    return n1, n2


@kernel
def _ompv_observed(
    prev_pos, pred, pred_len, prev_codes, elapsed, cur_pos, cur_codes, distinct, tolerance, standing
):  # pragma: no cover
    """`ompv` of one channel against one stored observation, ids as numbers; (value, 0), or
    (0.0, 1) when the channel does not track (the nearest matching, `_nearest_ompv`, is
    the caller's: it is another module's kernel). `distinct`: no current id is repeated, so
    the first current object of an id is its only one, and objects listed in the same order
    as before are found at once."""
    n_prev = prev_pos.shape[0]
    n_cur = cur_pos.shape[0]
    if n_prev == 0 and standing > 0.0:
        return 1.0, 0  # nothing was predicted: nothing to check
    if n_prev == 0:
        return (1.0 if n_cur == 0 else 0.0), 0  # every current object is new: a miss
    match = np.empty(n_prev, dtype=np.int64)
    if distinct:
        hint = 0  # where the previous object's successor would be, same order kept
        for i in range(n_prev):
            code = prev_codes[i]
            m = -1
            if hint < n_cur and cur_codes[hint] == code:
                m = hint
            else:
                for j in range(n_cur):
                    if cur_codes[j] == code:
                        m = j
                        break
            match[i] = m
            if m >= 0:
                hint = m + 1
    else:
        for i in range(n_prev):
            m = -1
            for j in range(n_cur - 1, -1, -1):  # a repeated id: its last index
                if cur_codes[j] == prev_codes[i]:
                    m = j
                    break
            match[i] = m
    n1, n2, tracked, _, _ = _ompv_tracked(
        prev_pos, pred, pred_len, elapsed, cur_pos, match, tolerance, standing
    )
    if not tracked:
        return 0.0, 1
    if standing <= 0.0:
        return n1 / n2, 0
    return (1.0 if n2 == 0 else n1 / n2), 0


@kernel
def _ompv_tick(
    t,
    chans,
    times,
    count,
    head,
    n_obj,
    n_pred,
    pos,
    pred,
    pred_len,
    codes,
    lookback,
    max_gap,
    tolerance,
    standing,
    vals,
    has,
    row0,
    pending,
    elapsed,
):  # pragma: no cover - compiled
    """ompv of every channel at t in one call, over `history.ObjectHistory`'s arrays: what the
    motion family did per channel with a `TimedHistory` of `Objects`, by the same rules.

    `chans[c]`: (present, positions, predictions, prediction lengths, id numbers, no id
    repeated) of channel c. A present channel whose previous observation is within max_gap
    (+1e-9 s) is compared with its newest observation at least `lookback` old (spi-reference
    "ompv" Decision), into vals[row0 + c] (has: it has a value); then its observation is
    stored (the history restarting after a gap) and the observations older than the newest
    one at least `lookback` old are dropped. An absent channel has no value and stores
    nothing.

    Returns the number of channels that do not track (`pending[c]`: the slot compared with,
    `elapsed[c]` its age: the caller computes their value), or -1 with nothing changed when
    the arrays need room (`ObjectHistory.fit`)."""
    n_ch, slots = times.shape
    for c in range(n_ch):
        ch = chans[c]
        if ch[0] and (
            ch[1].shape[0] > codes.shape[2] or ch[2].size > pred.shape[2] or count[c] >= slots
        ):
            return -1
    gap = max_gap + 1e-9
    n_pending = 0
    for c in range(n_ch):
        ch = chans[c]
        row = row0 + c
        has[row] = False
        pending[c] = -1
        if not ch[0]:
            continue
        cur_pos = ch[1]
        cur_pred = ch[2]
        cur_len = ch[3]
        cur_codes = ch[4]
        distinct = ch[5]
        k = count[c]
        h = head[c]
        if k > 0 and t - times[c, h] <= gap:
            for r in range(k):  # newest first
                s = (h - r + slots) % slots
                if t - times[c, s] >= lookback:
                    n = n_obj[c, s]
                    p = n_pred[c, s]
                    value, untracked = _ompv_observed(
                        pos[c, s, : 2 * n].reshape((n, 2)),
                        pred[c, s, : 3 * n * p].reshape((n, p, 3)),
                        pred_len[c, s, :n],
                        codes[c, s, :n],
                        t - times[c, s],
                        cur_pos,
                        cur_codes,
                        distinct,
                        tolerance,
                        standing,
                    )
                    if untracked:
                        pending[c] = s
                        elapsed[c] = t - times[c, s]
                        n_pending += 1
                    else:
                        vals[row] = value
                        has[row] = True
                    break
        if k > 0 and t - times[c, h] > gap:
            k = 0
        s = (h + 1) % slots
        n = cur_pos.shape[0]
        p = cur_pred.shape[1]
        for i in range(n):
            pred_len[c, s, i] = cur_len[i]
            codes[c, s, i] = cur_codes[i]
        # into the flat block in C order, whatever the layout of the frame's arrays
        for i in range(n):
            pos[c, s, 2 * i] = cur_pos[i, 0]
            pos[c, s, 2 * i + 1] = cur_pos[i, 1]
        m = 0
        for i in range(n):
            for j in range(p):
                pred[c, s, m] = cur_pred[i, j, 0]
                pred[c, s, m + 1] = cur_pred[i, j, 1]
                pred[c, s, m + 2] = cur_pred[i, j, 2]
                m += 3
        n_obj[c, s] = n
        n_pred[c, s] = p
        times[c, s] = t
        k += 1
        # keep one observation at least lookback old, and everything newer
        while k > 1 and t - times[c, (s - k + 2 + slots) % slots] >= lookback:
            k -= 1
        count[c] = k
        head[c] = s
    return n_pending


def ompv_tick(
    history: ObjectHistory,
    t: float,
    chans: tuple[tuple[bool, np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool], ...],
    params: tuple[float, float, float, float, float],
    vals: np.ndarray,
    has: np.ndarray,
    row0: int,
    first: int | None = None,
) -> None:
    """ompv of every channel at t into vals[row0 + c] / has[row0 + c] (`_ompv_tick`), room
    made when needed, the channels that do not track by the nearest matching. `params`:
    (lookback - 1e-9 s, max_gap, tolerance, gate, standing). `first`: what a call of
    `_ompv_tick` with these arguments already returned (the motion family calls the kernel
    itself and this only when that is not 0)."""
    lookback, max_gap, tolerance, gate, standing = params
    h = history
    state = (lookback, max_gap, tolerance, standing, vals, has, row0, h.pending, h.elapsed)
    n_pending = _ompv_tick(t, chans, *h.state, *state) if first is None else first
    while n_pending < 0:
        h.fit(max(len(ch[1]) for ch in chans), max(ch[2].size for ch in chans))
        n_pending = _ompv_tick(t, chans, *h.state, *state)
    if n_pending:
        for c, s in enumerate(h.pending.tolist()):
            if s < 0:
                continue
            n = int(h.n_obj[c, s])
            p = int(h.n_pred[c, s])
            prev_pos = h.pos[c, s, : 2 * n].reshape(n, 2).copy()
            predicted, reaches = _predict(
                prev_pos,
                h.pred[c, s, : 3 * n * p].reshape(n, p, 3).copy(),
                h.pred_len[c, s, :n].copy(),
                float(h.elapsed[c]),
            )
            vals[row0 + c] = _nearest_ompv(
                predicted, reaches, prev_pos, chans[c][1], tolerance, gate, standing
            )
            has[row0 + c] = True
