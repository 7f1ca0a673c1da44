"""Comfort scores: hcs (driven ego history) and ppcs (current plan), from local cubic fits.

spi-reference "hcs and ppcs" is the normative text; the reasons, in short:

- **Noise.** Localisation reports positions with 5-15 cm of unsmoothed noise. Differentiated
  three times at 0.1 s, that is tens of m/s^3 of "jerk" on a car standing still. A least-squares
  cubic fitted to the positions of a `comfort_span` window (3 s by default) and differentiated
  analytically at the window's centre turns 0.12 m of noise into about 0.1 m/s^2 and 1 m/s^3,
  while a harsh brake (-6 m/s^2) or a swerve still reads as one. The price is latency: hcs at
  tick t describes the motion at t - span / 2.
- **Sampling.** The fit reads sample times, not indices, so a window sampled every 0.1 s, 0.5 s
  or every metre gives the same derivatives of the same motion.
- **Frame.** Velocity, acceleration and jerk are fitted in the world frame; the acceleration is
  split along and across the fitted velocity (differentiate, then rotate: the centripetal term
  `v^2 / R` stays in `a_lat`). Below `STILL_SPEED` the direction of travel is undefined and the
  whole acceleration counts as longitudinal, which keeps the score rotation-invariant.
- **Jerk.** The jerk term is the magnitude of the jerk vector, longitudinal and lateral
  (Decision; the study reads longitudinal jerk only). With the study's NV steepness, the
  acceleration term alone can never take a lateral manoeuvre below 0.8: a swerve is recognised
  by its lateral jerk.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from casewatch.monitor.jit import kernel

#: A cubic needs four samples.
MIN_POINTS = 4

#: Below this fitted speed [m/s] the direction of travel is undefined (see module docstring).
STILL_SPEED = 0.5

#: Tolerance [s] on window ends (decimal sample times).
TIME_EPS = 1e-9


def nv(s: np.ndarray | float, steepness: float) -> np.ndarray | float:
    """spi-reference Decision: symmetric NV(s) = 2 / (1 + exp(-w |s|)) - 1, in [0, 1)."""
    return 2.0 / (1.0 + np.exp(-steepness * np.abs(s))) - 1.0


@kernel
def _solve4(m, b):  # pragma: no cover - compiled
    """Solve the 4x4 system m z = b (two right-hand sides, columns of b) in place by Gaussian
    elimination with partial pivoting; returns False when m is singular."""
    for col in range(4):
        piv = col
        for r in range(col + 1, 4):
            if abs(m[r, col]) > abs(m[piv, col]):
                piv = r
        if abs(m[piv, col]) < 1e-12:
            return False
        if piv != col:
            for c in range(4):
                m[col, c], m[piv, c] = m[piv, c], m[col, c]
            for c in range(2):
                b[col, c], b[piv, c] = b[piv, c], b[col, c]
        for r in range(col + 1, 4):
            f = m[r, col] / m[col, col]
            for c in range(col, 4):
                m[r, c] -= f * m[col, c]
            for c in range(2):
                b[r, c] -= f * b[col, c]
    for col in range(3, -1, -1):
        for c in range(2):
            s = b[col, c]
            for k in range(col + 1, 4):
                s -= m[col, k] * b[k, c]
            b[col, c] = s / m[col, col]
    return True


@kernel
def _fit(times, xy, lo, hi, centre, half, out):  # pragma: no cover - compiled
    """Least-squares cubic through samples lo..hi-1 (times relative to `centre`, scaled by
    `half`); writes velocity, acceleration and jerk at the centre into out[0:6] as
    (vx, vy, ax, ay, jx, jy). False when the samples do not determine a cubic."""
    if hi - lo < 4:
        return False
    m = np.zeros((4, 4))
    b = np.zeros((4, 2))
    p = np.empty(4)
    for i in range(lo, hi):
        tau = (times[i] - centre) / half
        p[0] = 1.0
        p[1] = tau
        p[2] = tau * tau
        p[3] = tau * tau * tau
        for r in range(4):
            b[r, 0] += p[r] * xy[i, 0]
            b[r, 1] += p[r] * xy[i, 1]
            for c in range(4):
                m[r, c] += p[r] * p[c]
    if not _solve4(m, b):
        return False
    # x(t) = sum_k b_k ((t - centre) / half)^k: derivatives at the centre
    for c in range(2):
        out[c] = b[1, c] / half
        out[2 + c] = 2.0 * b[2, c] / (half * half)
        out[4 + c] = 6.0 * b[3, c] / (half * half * half)
    return True


@kernel
def _comfort_kernel(times, xy, centres, half, steepness):  # pragma: no cover - compiled
    """Comfort score from cubic fits centred on each of `centres` (window +- half); peaks of
    |a_lon|, |a_lat| and |jerk| over the centres. NaN when a window holds too few samples."""
    n = times.shape[0]
    pa_lon = 0.0
    pa_lat = 0.0
    pj = 0.0
    d = np.empty(6)
    lo = 0
    hi = 0
    for c in centres:
        while lo < n and times[lo] < c - half - TIME_EPS:
            lo += 1
        if hi < lo:
            hi = lo
        while hi < n and times[hi] <= c + half + TIME_EPS:
            hi += 1
        if not _fit(times, xy, lo, hi, c, half, d):
            return math.nan
        speed = math.hypot(d[0], d[1])
        if speed >= STILL_SPEED:
            ux = d[0] / speed
            uy = d[1] / speed
            a_lon = d[2] * ux + d[3] * uy
            a_lat = -d[2] * uy + d[3] * ux
        else:
            a_lon = math.hypot(d[2], d[3])
            a_lat = 0.0
        pa_lon = max(pa_lon, abs(a_lon))
        pa_lat = max(pa_lat, abs(a_lat))
        pj = max(pj, math.hypot(d[4], d[5]))
    v_lon = 2.0 / (1.0 + math.exp(-steepness * pa_lon)) - 1.0
    v_lat = 2.0 / (1.0 + math.exp(-steepness * pa_lat)) - 1.0
    v_jerk = 2.0 / (1.0 + math.exp(-steepness * pj)) - 1.0
    return 1.0 - ((v_lon + v_lat) / 2 + v_jerk) / 2


@kernel
def _uniform_kernel(xy, first, last, proj, half, steepness, col=0):  # pragma: no cover
    """`_comfort_kernel` for samples on a uniform grid with windows of 2h + 1 samples centred
    on samples first..last: every window has the same design, so each fit is three dot
    products with the rows of the least-squares projection `proj` (4, 2h + 1). x and y are
    the columns `col` and `col + 1` of `xy` (1: a plan's [dt, x, y] rows, read in place)."""
    h = (proj.shape[1] - 1) // 2
    pa_lon = 0.0
    pa_lat = 0.0
    pj = 0.0
    for i in range(first, last + 1):
        c1x = c1y = c2x = c2y = c3x = c3y = 0.0
        for j in range(2 * h + 1):
            x = xy[i - h + j, col]
            y = xy[i - h + j, col + 1]
            c1x += proj[1, j] * x
            c1y += proj[1, j] * y
            c2x += proj[2, j] * x
            c2y += proj[2, j] * y
            c3x += proj[3, j] * x
            c3y += proj[3, j] * y
        vx = c1x / half
        vy = c1y / half
        ax = 2.0 * c2x / (half * half)
        ay = 2.0 * c2y / (half * half)
        speed = math.hypot(vx, vy)
        if speed >= STILL_SPEED:
            a_lon = (ax * vx + ay * vy) / speed
            a_lat = (-ax * vy + ay * vx) / speed
        else:
            a_lon = math.hypot(ax, ay)
            a_lat = 0.0
        pa_lon = max(pa_lon, abs(a_lon))
        pa_lat = max(pa_lat, abs(a_lat))
        pj = max(pj, 6.0 * math.hypot(c3x, c3y) / (half * half * half))
    v_lon = 2.0 / (1.0 + math.exp(-steepness * pa_lon)) - 1.0
    v_lat = 2.0 / (1.0 + math.exp(-steepness * pa_lat)) - 1.0
    v_jerk = 2.0 / (1.0 + math.exp(-steepness * pj)) - 1.0
    return 1.0 - ((v_lon + v_lat) / 2 + v_jerk) / 2


@kernel
def _uniform(rows, step):  # pragma: no cover - compiled
    """True when consecutive sample times (column 0 of `rows`) are `step` apart (to
    TIME_EPS)."""
    for i in range(rows.shape[0] - 1):
        if abs(rows[i + 1, 0] - rows[i, 0] - step) > TIME_EPS:
            return False
    return True


@lru_cache(maxsize=16)
def _projection(h: int) -> np.ndarray:
    """(4, 2h + 1) least-squares projection onto 1, tau, tau^2, tau^3 at tau = j / h,
    j = -h .. h (read-only: cached and shared)."""
    tau = np.arange(-h, h + 1) / h
    design = np.vander(tau, 4, increasing=True)
    proj = np.linalg.solve(design.T @ design, design.T)
    proj.flags.writeable = False
    return proj


def _score(
    times: np.ndarray, xy: np.ndarray, centres: np.ndarray, half: float, steepness: float
) -> float | None:
    value = _comfort_kernel(times, xy, centres, float(half), float(steepness))
    return None if math.isnan(value) else value


@kernel
def _hcs_kernel(times, xy, span, steepness):  # pragma: no cover - compiled
    """`hcs` in one compiled call (NaN: no value): it runs every tick for every channel."""
    n = times.shape[0]
    if n < MIN_POINTS or times[n - 1] - times[0] < span - TIME_EPS:
        return math.nan
    first = 0
    while times[first] < times[n - 1] - span - TIME_EPS:
        first += 1
    centres = np.empty(1)
    centres[0] = times[n - 1] - 0.5 * span
    return _comfort_kernel(times[first:], xy[first:], centres, 0.5 * span, steepness)


def hcs(times: np.ndarray, xy: np.ndarray, span: float, steepness: float) -> float | None:
    """History Comfort Score of ego positions (n, 2) at `times` (n,), oldest first.

    One cubic fit over the samples of the last `span` seconds, centred on `times[-1] - span/2`.
    None until the samples reach back `span` seconds, or with fewer than four of them.
    """
    value = _hcs_kernel(times, xy, float(span), float(steepness))
    return None if math.isnan(value) else value


def ppcs(plan: np.ndarray, span: float, steepness: float) -> float | None:
    """Planned Path Comfort Score of a plan (N, 3) `[dt, x, y]` on the canonical time grid.

    Cubic fits over windows of `span` seconds centred on every plan point whose window lies
    inside the plan; a plan shorter than `span` is fitted once, whole, centred on its middle.
    None below four points.
    """
    n = len(plan)
    if n < MIN_POINTS:
        return None
    half = 0.5 * span
    # Python floats: the same IEEE arithmetic as numpy's scalars, without their cost
    first, last = float(plan[0, 0]), float(plan[n - 1, 0])
    if last - first >= span - TIME_EPS:
        step = (last - first) / (n - 1)
        h = round(half / step)
        rows = np.ascontiguousarray(plan)
        # a window of 2h + 1 < 4 samples cannot fix a cubic: the general path below says so
        # (no value) instead of the singular projection raising
        if 2 * h + 1 >= MIN_POINTS and abs(h * step - half) <= TIME_EPS and _uniform(rows, step):
            # the canonical grid (always, for a resampled plan): one projection for every
            # window, read from the plan's rows in place
            return _uniform_kernel(
                rows, h, n - 1 - h, _projection(h), float(half), float(steepness), 1
            )
    times = np.ascontiguousarray(plan[:, 0])
    xy = np.ascontiguousarray(plan[:, 1:3])
    if last - first < span - TIME_EPS:
        return _score(times, xy, np.array([0.5 * (first + last)]), 0.5 * (last - first), steepness)
    inside = (times - half >= first - TIME_EPS) & (times + half <= last + TIME_EPS)
    return _score(times, xy, times[inside], half, steepness)


@kernel
def _push_row(buf, start, end, i, t, a, b, span, max_gap):  # pragma: no cover - compiled
    """`family.PoseWindow.push(t, a, b)` on window i of `family.PoseWindows`: this module's
    copy of `situation.push_row` (a kernel calls only kernels of its own module, monitor.jit);
    a test holds both to `PoseWindow`."""
    s = start[i]
    e = end[i]
    if e > s and t - buf[i, e - 1, 0] > max_gap + 1e-9:
        s = 0
        e = 0
    if e == buf.shape[1]:  # move the live rows to the front (there is room: make_room)
        live = e - s
        for r in range(live):
            buf[i, r, 0] = buf[i, s + r, 0]
            buf[i, r, 1] = buf[i, s + r, 1]
            buf[i, r, 2] = buf[i, s + r, 2]
        s = 0
        e = live
        if e == buf.shape[1]:
            raise IndexError("a full window: PoseWindows.make_room was not called")
    buf[i, e, 0] = t
    buf[i, e, 1] = a
    buf[i, e, 2] = b
    e += 1
    limit = t - span + 1e-9
    while e - s > 1 and buf[i, s + 1, 0] <= limit:
        s += 1
    start[i] = s
    end[i] = e
    return e - s


@kernel
def _uniform_h(plan, span):  # pragma: no cover - compiled
    """The window half-width h (samples) with which `ppcs` takes the uniform-grid kernel for
    `plan`, or -1 when it takes the general fit: `ppcs`'s tests, to the bit (`round` is
    Python's, half to even, as np.rint)."""
    n = plan.shape[0]
    if n < MIN_POINTS:
        return -1
    half = 0.5 * span
    first = plan[0, 0]
    last = plan[n - 1, 0]
    if last - first >= span - TIME_EPS:
        step = (last - first) / (n - 1)
        h = int(np.rint(half / step))
        if 2 * h + 1 >= MIN_POINTS and abs(h * step - half) <= TIME_EPS and _uniform(plan, step):
            return h
    return -1


@kernel
def _ppcs_general(plan, span, steepness):  # pragma: no cover - compiled
    """`ppcs`'s general fit (not the uniform grid), NaN for no value (n >= MIN_POINTS)."""
    n = plan.shape[0]
    half = 0.5 * span
    first = plan[0, 0]
    last = plan[n - 1, 0]
    times = plan[:, 0]
    xy = plan[:, 1:3]
    if last - first < span - TIME_EPS:
        centres = np.empty(1)
        centres[0] = 0.5 * (first + last)
        return _comfort_kernel(times, xy, centres, 0.5 * (last - first), steepness)
    count = 0
    for j in range(n):
        if times[j] - half >= first - TIME_EPS and times[j] + half <= last + TIME_EPS:
            count += 1
    centres = np.empty(count)
    count = 0
    for j in range(n):
        if times[j] - half >= first - TIME_EPS and times[j] + half <= last + TIME_EPS:
            centres[count] = times[j]
            count += 1
    return _comfort_kernel(times, xy, centres, half, steepness)


@kernel
def comfort_tick(
    t, chans, ego, e_start, e_end, span, max_gap, steepness, projs, have, vals, nones
):  # pragma: no cover - compiled
    """Every comfort signal of one tick in one call (issue 36): each channel's ego position
    pushed on its window of `family.PoseWindows` `ego` (the path the situation family reads
    too), hcs and ppcs per channel into `vals[2 i]`, `vals[2 i + 1]`, then their worst
    `vals[2 n:]`, as `families.comfort` computed them with `hcs`, `ppcs` and `family.worst`.

    `chans[i]` is (present, x, y, plan) of channel i. `projs[h, :, :2 h + 1]` is
    `_projection(h)` where `have[h]`. A value with no value is NaN and its row listed in
    `nones` (a NaN the uniform kernel returns stays a value, as in `ppcs`). Returns (bit mask
    of the rows with no value, or -1 beyond 62 rows, their count, the most rows in a window),
    or (-2, h, 0) before changing anything when a plan needs the projection h not in `projs`."""
    nc = len(chans)
    for i in range(nc):
        ch = chans[i]
        if ch[0]:
            h = _uniform_h(ch[3], span)
            if h >= 0 and (h >= have.shape[0] or not have[h]):
                return -2, h, 0
    rows = 2 * (nc + 1)
    none = np.zeros(rows, dtype=np.bool_)
    live = 0
    for i in range(nc):
        ch = chans[i]
        if not ch[0]:
            none[2 * i] = True
            none[2 * i + 1] = True
            continue
        n = _push_row(ego, e_start, e_end, i, t, ch[1], ch[2], span, max_gap)
        if n > live:
            live = n
        s0 = e_start[i]
        s1 = e_end[i]
        v = _hcs_kernel(ego[i, s0:s1, 0], ego[i, s0:s1, 1:3], span, steepness)
        vals[2 * i] = v
        if math.isnan(v):
            none[2 * i] = True
        plan = ch[3]
        if plan.shape[0] < MIN_POINTS:
            none[2 * i + 1] = True
            continue
        h = _uniform_h(plan, span)
        if h >= 0:
            n = plan.shape[0]
            half = 0.5 * span
            vals[2 * i + 1] = _uniform_kernel(
                plan, h, n - 1 - h, projs[h, :, : 2 * h + 1], half, steepness, 1
            )
        else:
            v = _ppcs_general(plan, span, steepness)
            vals[2 * i + 1] = v
            if math.isnan(v):
                none[2 * i + 1] = True
    # the worst (smallest) over the channels (`family.worst`): no value when any has none
    top = 2 * nc
    for m in range(2):
        missing = False
        best = 0.0
        for i in range(nc):
            if none[2 * i + m]:
                missing = True
                break
            v = vals[2 * i + m]
            if i == 0 or v < best:
                best = v
        if missing or nc == 0:
            none[top + m] = True
        else:
            vals[top + m] = best
    count = 0
    mask = 0
    for r in range(rows):
        if none[r]:
            vals[r] = math.nan
            nones[count] = r
            count += 1
            if rows <= 62:
                mask |= 1 << r
    return (mask if rows <= 62 else -1), count, live
