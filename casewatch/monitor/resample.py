"""Trajectories onto one time grid: what makes the plan and prediction metrics sampling-invariant.

Driving stacks sample their trajectories differently: every 0.1 s, every 0.5 s, or every metre
along the path (Autoware resamples by distance). Point-wise and Fréchet comparisons of raw
samples then measure the sampling, not the driving: a plan stored 0.1 s ago, sampled every
0.5 s, has its points a metre away from the current plan's points along the very same path.

So every plan and prediction is brought onto the **canonical grid** `t_k = k * step` (frame
time base, `step` = the `resample_step` metric parameter) before any metric reads it, over the
time range the trajectory itself covers (never extrapolated). Interpolation is piecewise-cubic
Hermite in time with three-point (non-uniform) derivative estimates at the samples: exact for
motion of constant acceleration, so resampling a constant-acceleration trajectory from any
sampling gives the same grid points to rounding, and on curves the error is O(h^3) instead of
the chord error of linear interpolation (a 15 m chord of a 200 m radius bends 14 cm away from
its straight line).

- Plans: grid points `k * step` inside `[dt_0, dt_last]`.
- Predictions: an object is at its reported position at dt = 0, so a prediction whose first
  point has dt > 0 gets that position as its first sample (spi-reference: "starts from the
  object's current position"); grid points `k * step`, k >= 1, up to the last dt.

spi-reference "Resampling" is the normative description.
"""

from __future__ import annotations

import math

import numpy as np

from casewatch.monitor.frames import Objects
from casewatch.monitor.jit import kernel

#: Tolerance [s] for grid points on the ends of a trajectory (decimal dt values).
GRID_EPS = 1e-9


@kernel
def _slopes(t, v, n, out):  # pragma: no cover - compiled
    """Derivative estimates of samples v[:n] at times t[:n] into out[:n]: the derivative of the
    parabola through each sample and its neighbours (one-sided parabola at the ends; the chord
    for two samples)."""
    if n == 1:
        out[0] = 0.0
        return
    if n == 2:
        s = (v[1] - v[0]) / (t[1] - t[0])
        out[0] = s
        out[1] = s
        return
    for i in range(n):
        # the three samples of the parabola and the point where its derivative is taken
        if i == 0:
            a, b, c = 0, 1, 2
        elif i == n - 1:
            a, b, c = n - 3, n - 2, n - 1
        else:
            a, b, c = i - 1, i, i + 1
        h0 = t[b] - t[a]
        h1 = t[c] - t[b]
        d0 = (v[b] - v[a]) / h0
        d1 = (v[c] - v[b]) / h1
        # Lagrange parabola derivative at t[i]
        x = t[i]
        out[i] = d0 + (d1 - d0) / (h0 + h1) * ((x - t[a]) + (x - t[b]))
    # An end slope of the sign opposite to its interval's secant (the one-sided parabola of
    # samples spaced very unevenly, e.g. a plan by distance of a car starting off: 1 m in 4.4 s,
    # then 1 m in 0.5 s) sends the cubic backwards first; it is set to 0 (the end rule of
    # shape-preserving piecewise-cubic interpolation). Inner slopes cannot: they are weighted
    # means of the two neighbouring secants.
    for i, j in ((0, 1), (n - 1, n - 2)):
        if out[i] * (v[j] - v[i]) * (t[j] - t[i]) < 0.0:
            out[i] = 0.0
    # Overshoot guard (after Fritsch and Carlson): a flat interval (the vehicle stands) keeps
    # its ends flat, and where a slope is over three times the interval's secant in the same
    # direction (a stop or a sharp slow-down between two sparse samples) the cubic would swing
    # past the next sample, so the slopes are scaled back onto Fritsch-Carlson's circle. Motion
    # of constant acceleration between samples of similar spacing never triggers either.
    for i in range(n - 1):
        d = (v[i + 1] - v[i]) / (t[i + 1] - t[i])
        if d == 0.0:
            out[i] = 0.0
            out[i + 1] = 0.0
            continue
        alpha = out[i] / d
        beta = out[i + 1] / d
        if alpha >= 0.0 and beta >= 0.0:
            r = alpha * alpha + beta * beta
            if r > 9.0:
                scale = 3.0 / math.sqrt(r)
                out[i] = scale * alpha * d
                out[i + 1] = scale * beta * d
        elif alpha > 3.0:
            out[i] = 3.0 * d
        elif beta > 3.0:
            out[i + 1] = 3.0 * d


@kernel
def _hermite(t, v, m, n, x):  # pragma: no cover - compiled
    """The cubic Hermite interpolant of (t[:n], v[:n]) with slopes m at x (t[0] <= x <= t[-1])."""
    if n == 1:
        return v[0]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if t[mid] <= x:
            lo = mid
        else:
            hi = mid
    h = t[hi] - t[lo]
    s = (x - t[lo]) / h
    if s < 0.0:
        s = 0.0
    elif s > 1.0:
        s = 1.0
    s2 = s * s
    s3 = s2 * s
    return (
        (2 * s3 - 3 * s2 + 1) * v[lo]
        + (s3 - 2 * s2 + s) * h * m[lo]
        + (-2 * s3 + 3 * s2) * v[hi]
        + (s3 - s2) * h * m[hi]
    )


@kernel
def _grid_range(first, last, step):  # pragma: no cover - compiled
    """Indices k0, k1 (inclusive) of the grid points k * step inside [first, last]."""
    # int(): the grid indices must be integers in plain Python too (NUMBA_DISABLE_JIT)
    k0 = int(math.ceil(first / step - GRID_EPS / step))  # noqa: RUF046
    k1 = int(math.floor(last / step + GRID_EPS / step))  # noqa: RUF046
    return k0, k1


@kernel
def _resample_one(t, x, y, n, k0, k1, step, out, row):  # pragma: no cover - compiled
    """Grid points k0..k1 of one trajectory into out[row, :k1 - k0 + 1] as [dt, x, y]."""
    mx = np.empty(n)
    my = np.empty(n)
    _slopes(t, x, n, mx)
    _slopes(t, y, n, my)
    for k in range(k0, k1 + 1):
        g = k * step
        if g < t[0]:
            g2 = t[0]  # within GRID_EPS of the first sample
        elif g > t[n - 1]:
            g2 = t[n - 1]
        else:
            g2 = g
        j = k - k0
        out[row, j, 0] = g
        out[row, j, 1] = _hermite(t, x, mx, n, g2)
        out[row, j, 2] = _hermite(t, y, my, n, g2)


@kernel
def _resample_plan(plan, step):  # pragma: no cover - compiled
    n = plan.shape[0]
    k0, k1 = _grid_range(plan[0, 0], plan[n - 1, 0], step)
    m = max(k1 - k0 + 1, 0)
    out = np.empty((1, m, 3))
    t = np.ascontiguousarray(plan[:, 0])
    x = np.ascontiguousarray(plan[:, 1])
    y = np.ascontiguousarray(plan[:, 2])
    if m > 0:
        _resample_one(t, x, y, n, k0, k1, step, out, 0)
    return out[0]


@kernel
def _on_grid(dt, first, step):  # pragma: no cover - compiled
    """True when dt[j] is (first + j) * step for every j, to within GRID_EPS (nothing to
    resample: the Hermite grid would return the samples themselves, to rounding)."""
    for j in range(dt.shape[0]):  # noqa: SIM110 - a loop, not a generator, inside numba
        if abs(dt[j] - (first + j) * step) > GRID_EPS:
            return False
    return True


def resample_plan(plan: np.ndarray, step: float) -> np.ndarray:
    """A (N, 3) `[dt, x, y]` plan on the grid `k * step` inside its own time range.

    An empty plan stays empty; a plan whose time range holds no grid point (a single point at
    dt = 0.03, say) resamples to no point, and the plan metrics then have no value. A plan
    already on the grid from dt = 0 is returned as it is (the same values to rounding, no work).
    """
    if len(plan) == 0 or _on_grid(plan[:, 0], 0, float(step)):
        return plan
    return _resample_plan(plan, float(step))


@kernel
def _resample_predictions(pos, pred, pred_len, step):  # pragma: no cover - compiled
    """(K, M, 3) predictions on the grid k * step, k >= 1, and (K,) lengths (see module)."""
    k_count = pred.shape[0]
    lens = np.zeros(k_count, dtype=np.int64)
    last = np.zeros(k_count, dtype=np.int64)
    width = 0
    for k in range(k_count):
        n = pred_len[k]
        if n == 0:
            continue
        _, k1 = _grid_range(0.0, pred[k, n - 1, 0], step)
        last[k] = k1
        if k1 > width:
            width = k1
    out = np.zeros((k_count, width, 3))
    cap = pred.shape[1] + 1
    t = np.empty(cap)
    x = np.empty(cap)
    y = np.empty(cap)
    for k in range(k_count):
        n = pred_len[k]
        if n == 0 or last[k] < 1:
            continue
        m = 0
        if pred[k, 0, 0] > GRID_EPS:
            t[0] = 0.0
            x[0] = pos[k, 0]
            y[0] = pos[k, 1]
            m = 1
        for i in range(n):
            t[m] = pred[k, i, 0]
            x[m] = pred[k, i, 1]
            y[m] = pred[k, i, 2]
            m += 1
        _resample_one(t, x, y, m, 1, last[k], step, out, k)
        lens[k] = last[k]
        # padding rows repeat the last point, as `Objects.pred` does
        for j in range(last[k], width):
            out[k, j, 0] = out[k, last[k] - 1, 0]
            out[k, j, 1] = out[k, last[k] - 1, 1]
            out[k, j, 2] = out[k, last[k] - 1, 2]
    return out, lens


@kernel
def _predictions_grid_start(pred, pred_len, step):  # pragma: no cover - compiled
    """1 when every prediction is already on the grid step, 2 step, ... (or absent), 0 when
    every one is on the grid 0, step, 2 step, ... (its dt = 0 point is the object's position),
    -1 otherwise: only then is there interpolation to do."""
    start = -1
    for k in range(pred.shape[0]):
        n = pred_len[k]
        if n == 0:
            continue
        first = 0 if abs(pred[k, 0, 0]) <= GRID_EPS else 1
        if (start >= 0 and first != start) or not _on_grid(pred[k, :n, 0], first, step):
            return -1
        start = first
    return 1 if start == -1 else start


def resample_objects(objects: Objects, step: float) -> Objects:
    """The same objects with every prediction on the grid `k * step`, k >= 1 (see module).

    A prediction shorter than one step (or none) becomes "no prediction": the object stays
    where it is, which is also what its position says at dt = 0.
    """
    if len(objects) == 0 or objects.pred.shape[1] == 0:
        return objects
    start = _predictions_grid_start(objects.pred, objects.pred_len, float(step))
    if start == 1:
        return objects
    return objects_on_grid(objects, start, step)


def with_predictions(objects: Objects, pred: np.ndarray, pred_len: np.ndarray) -> Objects:
    """`dataclasses.replace(objects, pred=pred, pred_len=pred_len)` without its generic
    field walk (a few microseconds per channel and tick); a test holds it to `replace` over
    every field of `Objects`."""
    o = objects
    return Objects(
        o.ids,
        o.cls,
        o.pos,
        o.yaw,
        o.vel,
        o.footprints,
        pred,
        pred_len,
        o.convex,
        o.half,
        o._areas,
        o._radii,
    )


def hold_standing(plan: np.ndarray, radius: float) -> np.ndarray:
    """A plan whose points all lie within `radius` metres of its first point, as a plan that
    stands at that point (spi-reference "Standing plans"); any other plan as it is.

    Planners publish a standing plan with the same sample noise as a moving one (0.1-0.2 m
    along, a few cm across, every sample). Read as a path, that noise is a zigzag of tenths of
    a metre: headings from its segments turned the ego's footprint across its neighbours in the
    safety score, and two such zigzags read as different paths in chpps and crpps."""
    if radius <= 0.0 or len(plan) < 2:
        return plan  # off (the study's reading): no work on the hot path
    if not _stands(plan, float(radius)):
        return plan
    out = plan.copy()
    out[:, 1] = plan[0, 1]
    out[:, 2] = plan[0, 2]
    return out


@kernel
def _stands(plan, radius):  # pragma: no cover - compiled
    """False when `np.hypot(plan[:, 1] - plan[0, 1], plan[:, 2] - plan[0, 2]).max() >= radius`
    (numpy's max: NaN when any distance is NaN, and NaN >= radius is False)."""
    best = -np.inf
    for i in range(plan.shape[0]):
        d = np.hypot(plan[i, 1] - plan[0, 1], plan[i, 2] - plan[0, 2])
        if math.isnan(d):
            return True
        if d > best:
            best = d
    return not best >= radius


@kernel
def _scale_of(half):  # pragma: no cover - compiled
    """1 / half when `half` is a normal power of two, else 0: then (t - tk) / half and
    (t - tk) * (1 / half) are the same double for every t (both the exact (t - tk) 2^-e,
    rounded once the same way), and a multiplication is cheaper than a division."""
    if not (half >= 1e-300 and half <= 1e300):
        return 0.0
    m, _ = math.frexp(half)
    return 1.0 / half if m == 0.5 else 0.0


@kernel
def _smooth_plan(plan, half):  # pragma: no cover - compiled
    """Each point replaced by a least-squares quadratic in time through the points within
    `half` seconds of it, evaluated at its time (points with fewer than three neighbours,
    themselves included, are kept)."""
    n = plan.shape[0]
    out = plan.copy()
    scale = _scale_of(half)
    lo = 0
    hi = 0
    for k in range(n):
        tk = plan[k, 0]
        while lo < n and plan[lo, 0] < tk - half - 1e-9:
            lo += 1
        if hi < k:
            hi = k
        while hi < n and plan[hi, 0] <= tk + half + 1e-9:
            hi += 1
        m = hi - lo
        if m < 3:
            continue
        # normal equations of x(t) = c0 + c1 u + c2 u^2, u = (t - tk) / half
        s0, s1, s2, s3, s4, bx0, bx1, bx2, by0, by1, by2 = _sums(plan, lo, hi, tk, half, scale)
        # Cramer's rule for the constant term c0 of the symmetric 3x3 system
        det = s0 * (s2 * s4 - s3 * s3) - s1 * (s1 * s4 - s2 * s3) + s2 * (s1 * s3 - s2 * s2)
        if abs(det) < 1e-12:
            continue
        cx = (
            bx0 * (s2 * s4 - s3 * s3) - s1 * (bx1 * s4 - s3 * bx2) + s2 * (bx1 * s3 - s2 * bx2)
        ) / det
        cy = (
            by0 * (s2 * s4 - s3 * s3) - s1 * (by1 * s4 - s3 * by2) + s2 * (by1 * s3 - s2 * by2)
        ) / det
        out[k, 1] = cx
        out[k, 2] = cy
    return out


@kernel
def _sums(plan, lo, hi, tk, half, scale):  # pragma: no cover - compiled
    """`_smooth_plan`'s sums over the points lo..hi-1, in their order, of u = (t - tk) / half,
    computed as (t - tk) * scale where `_scale_of` gave a scale (the same doubles)."""
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    s4 = 0.0
    bx0 = bx1 = bx2 = 0.0
    by0 = by1 = by2 = 0.0
    for j in range(lo, hi):
        d = plan[j, 0] - tk
        u = d * scale if scale != 0.0 else d / half
        u2 = u * u
        s0 += 1.0
        s1 += u
        s2 += u2
        s3 += u2 * u
        s4 += u2 * u2
        bx0 += plan[j, 1]
        bx1 += plan[j, 1] * u
        bx2 += plan[j, 1] * u2
        by0 += plan[j, 2]
        by1 += plan[j, 2] * u
        by2 += plan[j, 2] * u2
    return s0, s1, s2, s3, s4, bx0, bx1, bx2, by0, by1, by2


def smooth_plan(plan: np.ndarray, span: float) -> np.ndarray:
    """The plan with its sample noise smoothed (spi-reference "Plan smoothing"): every point
    replaced by a least-squares quadratic in time through the points within span / 2 of it.
    Exact for motion of constant acceleration; `span` 0 returns the plan as it is."""
    if span <= 0.0 or len(plan) < 3:
        return plan
    return _smooth_plan(np.ascontiguousarray(plan, dtype=float), 0.5 * float(span))


@kernel
def _prepare_plan(plan, half, smooth, step, radius):  # pragma: no cover - compiled
    """`hold_standing(resample_plan(smooth_plan(plan, 2 half), step), radius)` in one call
    (`smooth`: span > 0), for a C-contiguous float plan: the same kernels in the same order."""
    p = plan
    if smooth and plan.shape[0] >= 3:
        p = _smooth_plan(plan, half)
    if p.shape[0] > 0 and not _on_grid(p[:, 0], 0, step):
        p = _resample_plan(p, step)
    if not radius <= 0.0 and p.shape[0] >= 2 and _stands(p, radius):
        out = p.copy()
        for i in range(p.shape[0]):
            out[i, 1] = p[0, 1]
            out[i, 2] = p[0, 2]
        p = out
    return p


@kernel
def prepare_channel(plan, pred, pred_len, half, smooth, step, radius):  # pragma: no cover
    """A channel's resampling in one call (the engine's per-tick step, issue 36): its plan as
    `prepare_plan` gives it (C-contiguous), and what `resample_objects` does with its
    predictions: 1 nothing (none, or already on the grid from `step`), 0 drop their dt = 0
    point, -1 interpolate (`_predictions_grid_start`)."""
    p = np.ascontiguousarray(_prepare_plan(plan, half, smooth, step, radius))
    if pred.shape[0] == 0 or pred.shape[1] == 0:
        return p, 1
    return p, _predictions_grid_start(pred, pred_len, step)


def objects_on_grid(objects: Objects, start: int, step: float) -> Objects:
    """`resample_objects(objects, step)` once `prepare_channel` said `start` (not 1) for them."""
    if start == 0:  # on the grid from dt = 0: the grid points are the samples after the first
        # contiguous, like every other prediction array: one compiled layout per kernel
        pred = np.ascontiguousarray(objects.pred[:, 1:])
        lens = np.maximum(objects.pred_len - 1, 0)
    else:
        pred, lens = _resample_predictions(objects.pos, objects.pred, objects.pred_len, float(step))
    return with_predictions(objects, pred, lens)


def plan_settings(span: float, step: float, radius: float) -> tuple[float, bool, float, float]:
    """The compiled plan preparation's settings (`_prepare_plan`, `prepare_channel`) from the
    metric options: half the smoothing span, whether to smooth at all (`smooth_plan`'s test,
    NaN included), the grid step and the standstill radius."""
    return 0.5 * float(span), not span <= 0.0, float(step), float(radius)


def prepare_plan(plan: np.ndarray, span: float, step: float, radius: float) -> np.ndarray:
    """A plan as every metric reads it: smoothed (`smooth_plan`), on the canonical grid
    (`resample_plan`), a standing one standing (`hold_standing`); one compiled call for the
    usual C-contiguous float plan (the engine's per-channel step, issue 36), else the three
    functions in turn."""
    if plan.dtype == np.float64 and plan.flags.c_contiguous and plan.ndim == 2:
        return _prepare_plan(plan, *plan_settings(span, step, radius))
    return hold_standing(resample_plan(smooth_plan(plan, span), step), radius)
